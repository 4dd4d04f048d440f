//! The health monitor: turns what goes wrong in a partition (exceptions, bad system calls,
//! panics, overruns) into the action its configuration names (log, halt the partition, restart
//! it, warm-reset the module), and reports every event to the host as
//! `TelemetryEvent::HealthMonitor { partition, kind, address, action }` (codes:
//! `kernel_config::ErrorKind`, `kernel_config::HmAction`) plus a defmt line. A fault in the
//! kernel itself is reported with partition `KERNEL_PARTITION_ID` and warm-resets the module
//! with reset cause HealthMonitor. No fault ends in a `while(1)`.
use fsw_bridge::ResetCause;
use heapless::Deque;
use kernel_config::{ErrorKind, HmAction, KERNEL_PARTITION_ID};
use kernel_logic::event::{self, event_message, EventRecord};

use super::{at, at_mut, klog, Kernel, Next, RunState};
use crate::boot;
use crate::config::SYSTEM;
use crate::warm;

/// Kernel events waiting for the I/O partition (records: `kernel_logic::event`).
pub const EVENT_QUEUE_DEPTH: usize = 48;

pub struct EventQueue {
    queue: Deque<EventRecord, EVENT_QUEUE_DEPTH>,
    pub dropped: u32,
}

impl EventQueue {
    pub const fn new() -> Self {
        Self {
            queue: Deque::new(),
            dropped: 0,
        }
    }

    fn push(&mut self, record: EventRecord) {
        if self.queue.push_back(record).is_err() {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    pub fn metric(&mut self, id: u16, value: u64) {
        self.push(event::metric_record(id, value));
    }

    pub fn health(&mut self, partition: u8, kind: ErrorKind, address: u32, action: HmAction) {
        self.push(event::health_record(partition, kind, address, action));
    }

    pub fn pop(&mut self) -> Option<EventRecord> {
        self.queue.pop_front()
    }

    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }
}

impl Kernel {
    fn report(&mut self, p: usize, kind: ErrorKind, address: u32, action: HmAction) {
        // Where a window ended in a partition's work is a timing artefact that QEMU does not
        // reproduce to the instruction (observed: one instruction either way in a few runs
        // in ten), so an overrun's event carries no address and the host's transcript stays
        // the same run to run; the log line below has it.
        let reported = if kind == ErrorKind::Overrun {
            0
        } else {
            address
        };
        self.events.health(p as u8, kind, reported, action);
        defmt::warn!(
            "hm: partition {=str} {=str} at {=u32:#x}: {=str}",
            at(SYSTEM.partitions, p).name,
            kind.name(),
            address,
            action.name()
        );
    }

    /// An exception (or a panic) in partition `p`, which was running.
    pub fn partition_fault(&mut self, p: usize, kind: ErrorKind, address: u32, now: u64) -> Next {
        let action = at(SYSTEM.partitions, p).health.action(kind);
        self.report(p, kind, address, action);
        match action {
            // Continue after the faulting instruction (the checker refuses this for panics and
            // instruction-storage faults, which cannot be continued).
            HmAction::Log => {
                self.context(p).srr0 = self.context(p).srr0.wrapping_add(4);
                Next::Partition(p)
            }
            _ => self.stop_partition(p, action, now),
        }
    }

    /// The deferred code failed its check at its first fetch (`address`, in partition `p`):
    /// reported as an instruction-storage event with a warm reset, whose reset stub copies the
    /// whole image from ROM again (the image record made to say so), as for a damaged image
    /// at boot. Nothing of the block has run.
    pub fn deferred_code_damaged(&mut self, p: usize, address: u32) -> ! {
        self.report(
            p,
            ErrorKind::InstructionStorage,
            address,
            HmAction::WarmReset,
        );
        defmt::warn!("kernel: the deferred code failed its checksum; the image is copied again from ROM at the reset");
        warm::image_record_fail();
        self.warm_reset(ResetCause::HealthMonitor)
    }

    /// A system call from `p` failed with a fault code (already in its r3).
    pub fn syscall_fault(&mut self, p: usize, call: u32, now: u64) -> Next {
        let kind = ErrorKind::IllegalSyscall;
        let action = at(SYSTEM.partitions, p).health.action(kind);
        self.report(p, kind, call, action);
        match action {
            HmAction::Log => Next::Partition(p),
            _ => self.stop_partition(p, action, now),
        }
    }

    /// Halt, restart or reset for the running partition `p`.
    fn stop_partition(&mut self, p: usize, action: HmAction, now: u64) -> Next {
        self.armed_reset_on_stop(p);
        self.charge(p, now);
        match action {
            HmAction::Log => Next::Partition(p),
            HmAction::HaltPartition => {
                at_mut(&mut self.parts, p).run = RunState::Halted;
                Next::Idle
            }
            // A fresh start in the rest of its window.
            HmAction::RestartPartition => {
                self.restart(p);
                Next::Partition(p)
            }
            HmAction::WarmReset => self.warm_reset(ResetCause::HealthMonitor),
        }
    }

    /// `p` overran its window (already charged and preempted).
    pub fn overrun_action(&mut self, p: usize, action: HmAction) {
        match action {
            HmAction::Log => {
                // Counted every time (accounting metrics); reported once per (re)start so a
                // runaway partition does not flood the link.
                if !at(&self.parts, p).overrun_reported {
                    at_mut(&mut self.parts, p).overrun_reported = true;
                    self.report(p, ErrorKind::Overrun, at(&self.contexts, p).srr0, action);
                }
            }
            HmAction::HaltPartition => {
                self.report(p, ErrorKind::Overrun, at(&self.contexts, p).srr0, action);
                self.armed_reset_on_stop(p);
                at_mut(&mut self.parts, p).run = RunState::Halted;
            }
            HmAction::RestartPartition => {
                self.report(p, ErrorKind::Overrun, at(&self.contexts, p).srr0, action);
                self.armed_reset_on_stop(p);
                self.restart(p);
            }
            HmAction::WarmReset => {
                self.report(p, ErrorKind::Overrun, at(&self.contexts, p).srr0, action);
                self.warm_reset(ResetCause::HealthMonitor)
            }
        }
    }

    /// Send what is pending straight to the host, record the cause, restart from the reset
    /// vector with RAM kept.
    pub fn warm_reset(&mut self, cause: ResetCause) -> ! {
        boot::disable_interrupts();
        while let Some(record) = self.events.pop() {
            if let Some(msg) = event_message(&record) {
                klog::send_direct(&mut self.link, &msg);
            }
        }
        klog::with_ring(|ring| klog::flush_direct(&mut self.link, ring));
        warm::set_pending_cause(cause);
        boot::software_reset()
    }
}

/// A fault in the kernel itself (or anything the kernel cannot attribute to a partition):
/// report it with partition `KERNEL_PARTITION_ID`, record it in the warm area for the next
/// boot's Hello, then warm-reset with cause KernelFault.
pub fn kernel_fault(vector: u32, srr0: u32, srr1: u32, dar: u32, dsisr: u32) -> ! {
    boot::disable_interrupts();
    let address = if vector == 0x300 { dar } else { srr0 };
    // SAFETY: kernel context, interrupts off; whatever the kernel was doing is abandoned.
    let k = unsafe { super::kernel() };
    k.events.health(
        KERNEL_PARTITION_ID,
        ErrorKind::from_vector(vector),
        address,
        HmAction::WarmReset,
    );
    defmt::error!(
        "kernel exception {=u32:#x} at {=u32:#x} (srr1 {=u32:#x}, dar {=u32:#x}, dsisr {=u32:#x}): warm reset",
        vector,
        srr0,
        srr1,
        dar,
        dsisr
    );
    warm::set_pending_cause(ResetCause::KernelFault);
    warm::set_kernel_fault(fsw_bridge::KernelFault {
        vector,
        pc: srr0,
        dar: if matches!(vector, 0x300 | 0x600) {
            dar
        } else {
            0
        },
    });
    k.warm_reset(ResetCause::KernelFault)
}
