//! System calls (`sc`): the number in r0, arguments in r3..r7, results in r3 (negative: an
//! `abi::E_*` code) and r4/r5. See `kernel_config::abi` for the table. The number is decoded
//! once, into a [`Sysnum`], before anything else; every handler fails with a [`SysError`], and
//! the return path encodes it into r3. A fault (`SysError::is_fault`: anything but Empty, Full,
//! NoDevice) is also reported to the health monitor, which applies the partition's
//! IllegalSyscall action; the kernel itself never fails because of what a partition passed.
use fsw_bridge::ResetCause;
use kernel_config::abi::*;
use kernel_config::{NV_BASE, WARM_AREA_BASE, WARM_BOOT_RECORD_SIZE};
use kernel_logic::park::{
    check_wait_for_input_args, decide, reasons_not_to_park, wait_declares_idle, Decision,
    ModuleState,
};

use super::ports::Ports;
use super::umem::{copy, USlice};
use super::{at, health, klog, Kernel, Next, RunState};
use crate::config::{PARTITION_COUNT, SYSTEM};

enum Outcome {
    /// Return to the caller with r3, r4, r5.
    Return(u32, u32, u32),
    /// Something else runs next (wait, panic, reset).
    Switch(Next),
}

use Outcome::Return;

fn ok() -> Result<Outcome, SysError> {
    Ok(Return(0, 0, 0))
}

impl Kernel {
    pub fn syscall(&mut self, p: usize, now: u64) -> Next {
        let ctx = *self.context(p);
        let call = ctx.gpr[0];
        let a = [ctx.gpr[3], ctx.gpr[4], ctx.gpr[5], ctx.gpr[6], ctx.gpr[7]];
        let outcome = Sysnum::try_from(call).and_then(|sysnum| self.dispatch(p, sysnum, a, now));
        match outcome {
            Ok(Outcome::Return(r3, r4, r5)) => {
                let ctx = self.context(p);
                ctx.gpr[3] = r3;
                ctx.gpr[4] = r4;
                ctx.gpr[5] = r5;
                Next::Partition(p)
            }
            Ok(Outcome::Switch(next)) => next,
            Err(error) => {
                self.context(p).gpr[3] = encode_result(Err(error));
                if error.is_fault() {
                    self.syscall_fault(p, call, now)
                } else {
                    Next::Partition(p)
                }
            }
        }
    }

    fn link_owner(p: usize) -> Result<(), SysError> {
        if at(SYSTEM.partitions, p).capabilities.link_owner {
            Ok(())
        } else {
            Err(SysError::Denied)
        }
    }

    /// The kernel address of bytes `offset..offset + len` of partition `p`'s slice of the
    /// warm area's checkpoint part.
    fn warm_range(p: usize, offset: u32, len: u32) -> Result<u32, SysError> {
        let Some(slice) = at(SYSTEM.partitions, p).capabilities.warm_area else {
            return Err(SysError::Denied);
        };
        match offset.checked_add(len) {
            Some(end) if end <= slice.len => {
                Ok(WARM_AREA_BASE + WARM_BOOT_RECORD_SIZE + slice.offset + offset)
            }
            _ => Err(SysError::Range),
        }
    }

    /// Bytes of non-volatile memory partition `p`'s slice offers on this board (its slice,
    /// cut at the end of the device).
    fn nv_offered(&self, p: usize) -> Result<(kernel_config::Slice, u32), SysError> {
        let Some(slice) = at(SYSTEM.partitions, p).capabilities.nv_memory else {
            return Err(SysError::Denied);
        };
        let offered = self.nv_bytes.saturating_sub(slice.offset).min(slice.len);
        if offered == 0 {
            return Err(SysError::NoDevice);
        }
        Ok((slice, offered))
    }

    /// The device address of bytes `offset..offset + len` of partition `p`'s slice of
    /// non-volatile memory.
    fn nv_range(&self, p: usize, offset: u32, len: u32) -> Result<u32, SysError> {
        let (slice, offered) = self.nv_offered(p)?;
        match offset.checked_add(len) {
            Some(end) if end <= offered => Ok(NV_BASE + slice.offset + offset),
            _ => Err(SysError::Range),
        }
    }

    fn dispatch(
        &mut self,
        p: usize,
        call: Sysnum,
        a: [u32; 5],
        now: u64,
    ) -> Result<Outcome, SysError> {
        match call {
            Sysnum::WaitNextWindow => {
                if wait_declares_idle(a[0])? {
                    self.idle_declared.declare(p);
                }
                self.context(p).gpr[3] = 0;
                Ok(Outcome::Switch(self.wait_next_window(p, now)))
            }
            Sysnum::PortSend => {
                let message = USlice::from_raw(a[1], a[2])?.readable_by(p)?;
                let generation = at(&self.parts, p).generation;
                let port = a[0] as usize;
                self.ports.send(p, port, message, generation, now)?;
                // A queued message is work for its destination.
                let queuing = SYSTEM.ports.get(port);
                if let Some(config) = queuing.filter(|c| c.kind == kernel_config::PortKind::Queuing)
                {
                    for &destination in config.destinations {
                        self.idle_declared.withdraw(destination);
                    }
                }
                ok()
            }
            Sysnum::PortReceive => {
                let buffer = USlice::from_raw(a[1], a[2])?.writable_by(p)?;
                let port = a[0] as usize;
                // Messages older than their sender's current generation are dropped (stale).
                let sender_generation = Ports::source(port)
                    .and_then(|source| self.parts.get(source))
                    .map_or(0, |s| s.generation);
                let got = self.ports.receive(p, port, buffer, sender_generation)?;
                let age = now.saturating_sub(got.sent_at).min(u64::from(u32::MAX)) as u32;
                // Last before the return path: it may start a stint that counts from here.
                self.armed_reset_on_receive(p, a[0] as usize);
                Ok(Return(got.len as u32, got.generation, age))
            }
            Sysnum::MissionTime => {
                let t = self.mission_time_us;
                Ok(Return((t >> 32) as u32, t as u32, 0))
            }
            Sysnum::CpuTime => {
                let s = at(&self.parts, p);
                let stint = u64::from(self.stint_ticks());
                let window = u64::from(s.window_ticks) + stint;
                let total = s.cpu_total + stint;
                Ok(Return((total >> 32) as u32, total as u32, window as u32))
            }
            Sysnum::Log => {
                let frame = USlice::from_raw(a[0], a[1])?.readable_by(p)?;
                klog::with_ring(|ring| ring.push_frame(frame));
                ok()
            }
            Sysnum::WarmRead => {
                let buffer = USlice::from_raw(a[1], a[2])?.writable_by(p)?;
                let at = Self::warm_range(p, a[0], a[2])?;
                // SAFETY:
                // 1. `at..at + len` lies inside the warm area's checkpoint part (checked by
                //    `warm_range`), kernel RAM that is not otherwise borrowed during this call.
                let area = unsafe { core::slice::from_raw_parts(at as *const u8, buffer.len()) };
                copy(buffer, area);
                ok()
            }
            Sysnum::WarmWrite => {
                let data = USlice::from_raw(a[1], a[2])?.readable_by(p)?;
                let at = Self::warm_range(p, a[0], a[2])?;
                // SAFETY: as for SYS_WARM_READ; the boot record before the part is not touched.
                let area = unsafe { core::slice::from_raw_parts_mut(at as *mut u8, data.len()) };
                if self.armed.counting(p) {
                    // A reset armed inside this partition's work may tear this write.
                    self.armed_warm_write(p, a[0], area, data);
                } else {
                    copy(area, data);
                }
                ok()
            }
            Sysnum::NvRead => {
                let buffer = USlice::from_raw(a[1], a[2])?.writable_by(p)?;
                let at = self.nv_range(p, a[0], a[2])?;
                // SAFETY:
                // 1. `at..at + len` lies inside the non-volatile memory the boot code mapped at
                //    NV_BASE (checked by `nv_range`): device memory behind PCI that only this
                //    call and SYS_NV_WRITE touch, with the MMU off in the kernel.
                let area = unsafe { core::slice::from_raw_parts(at as *const u8, buffer.len()) };
                copy(buffer, area);
                Ok(Return(self.nv_offered(p)?.1, 0, 0))
            }
            Sysnum::NvWrite => {
                let data = USlice::from_raw(a[1], a[2])?.readable_by(p)?;
                let at = self.nv_range(p, a[0], a[2])?;
                // SAFETY: as for SYS_NV_READ.
                let area = unsafe { core::slice::from_raw_parts_mut(at as *mut u8, data.len()) };
                copy(area, data);
                ok()
            }
            Sysnum::Identity => Ok(Return(p as u32, at(&self.parts, p).generation, 0)),
            Sysnum::Uptime => {
                let up = now.wrapping_sub(crate::shared::boot_ticks());
                let boot = self.boot_ticks.min(u64::from(u32::MAX)) as u32;
                Ok(Return((up >> 32) as u32, up as u32, boot))
            }
            Sysnum::Panic => {
                let file = USlice::from_raw(a[0], a[1].min(128))
                    .and_then(|s| s.readable_by(p))
                    .unwrap_or(b"<bad pointer>");
                defmt::error!(
                    "partition {=str} panicked at {=str}:{=u32}",
                    at(SYSTEM.partitions, p).name,
                    core::str::from_utf8(file).unwrap_or("<not utf-8>"),
                    a[2]
                );
                Ok(Outcome::Switch(self.partition_fault(
                    p,
                    kernel_config::ErrorKind::Panic,
                    a[2],
                    now,
                )))
            }
            Sysnum::BootInfo => {
                Self::link_owner(p)?;
                match a[0] {
                    BOOT_INFO_CAUSE => Ok(Return(self.boot_cause, self.boot_count, 0)),
                    BOOT_INFO_KERNEL_FAULT => Ok(match crate::warm::boot_kernel_fault() {
                        Some(f) => Return(f.vector, f.pc, f.dar),
                        None => Return(0, 0, 0),
                    }),
                    _ => Err(SysError::Range),
                }
            }
            Sysnum::LogDrain => {
                Self::link_owner(p)?;
                let buffer = USlice::from_raw(a[0], a[1])?.writable_by(p)?;
                let n = klog::with_ring(|ring| ring.drain(buffer));
                Ok(Return(n as u32, 0, 0))
            }
            Sysnum::EventDrain => {
                Self::link_owner(p)?;
                let records = a[1].clamp(1, health::EVENT_QUEUE_DEPTH as u32);
                let bytes = records * EVENT_RECORD_SIZE as u32;
                let buffer = USlice::from_raw(a[0], bytes)?.writable_by(p)?;
                let mut written = 0;
                for slot in buffer.chunks_exact_mut(EVENT_RECORD_SIZE) {
                    let Some(record) = self.events.pop() else {
                        break;
                    };
                    copy(slot, &kernel_logic::event::record_bytes(&record));
                    written += 1;
                }
                Ok(Return(written, 0, 0))
            }
            Sysnum::SetMissionTime => {
                Self::link_owner(p)?;
                self.mission_time_us = (u64::from(a[0]) << 32) | u64::from(a[1]);
                ok()
            }
            Sysnum::ResetModule => {
                Self::link_owner(p)?;
                match a[0] {
                    reset_at::NOW => self.warm_reset(ResetCause::Warm),
                    mode => {
                        let chain = (a[3] != reset_at::NO_CHAIN).then_some(a[3] as usize);
                        self.arm_reset(p, mode, a[1], a[2] as usize, chain)?;
                        ok()
                    }
                }
            }
            Sysnum::RequestMetrics => {
                Self::link_owner(p)?;
                match a[0] {
                    0 => self.report_metrics(),
                    REPORT_OFF => self.sched.report_period = 0,
                    period => self.sched.report_period = period,
                }
                ok()
            }
            Sysnum::LinkRead => {
                Self::link_owner(p)?;
                let buffer = USlice::from_raw(a[0], a[1])?.writable_by(p)?;
                let n = self.link.read(buffer);
                Ok(Return(n as u32, self.link.lost, 0))
            }
            Sysnum::LinkWrite => {
                Self::link_owner(p)?;
                let data = USlice::from_raw(a[0], a[1])?.readable_by(p)?;
                Ok(Return(self.link.write(data) as u32, 0, 0))
            }
            Sysnum::WaitForInput => {
                Self::link_owner(p)?;
                if check_wait_for_input_args(&a)? {
                    let state = self.module_state(p);
                    return Ok(Return(
                        wait_input::NOT_PARKED,
                        reasons_not_to_park(&state),
                        state.busy_partitions,
                    ));
                }
                match decide(&self.module_state(p)) {
                    Decision::InputPending => Ok(Return(wait_input::INPUT_PENDING, 0, 0)),
                    Decision::Park => {
                        let ctx = self.context(p);
                        ctx.gpr[3] = wait_input::PARKED;
                        ctx.gpr[4] = 0;
                        ctx.gpr[5] = 0;
                        Ok(Outcome::Switch(self.park(p, now)))
                    }
                    Decision::NextWindow { reasons, busy } => {
                        let ctx = self.context(p);
                        ctx.gpr[3] = wait_input::NOT_PARKED;
                        ctx.gpr[4] = reasons;
                        ctx.gpr[5] = busy;
                        Ok(Outcome::Switch(self.wait_next_window(p, now)))
                    }
                }
            }
        }
    }

    /// What SYS_WAIT_FOR_INPUT from `caller` decides on.
    fn module_state(&self, caller: usize) -> ModuleState {
        let halted = (self.parts.iter().enumerate())
            .filter(|(_, s)| s.run == RunState::Halted)
            .fold(0u32, |bits, (q, _)| bits | 1 << q);
        ModuleState {
            input_pending: self.link.pending(),
            busy_partitions: self.idle_declared.busy(caller, halted, PARTITION_COUNT),
            message_in_flight: self.ports.any_queued(),
            log_pending: klog::with_ring(|ring| !ring.is_empty()),
            events_pending: !self.events.is_empty(),
            periodic_reports: self.sched.report_period != 0,
            reset_armed: !self.armed.is_off(),
        }
    }
}
