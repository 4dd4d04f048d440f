//! The partitioning kernel: ARINC 653-style time and space partitioning on the 750.
//!
//! The kernel owns the machine with the MMU off and runs only in exception handlers (plus its
//! boot and idle loop). Partitions run in problem state with their own BAT mappings
//! ([`mmu`]), in the windows of a cyclic major frame driven by the decrementer ([`sched`]);
//! they reach the kernel through `sc` ([`syscall`], with pointers checked by [`umem`]) and
//! exchange messages through kernel-copied [`ports`]. Every exception, bad system call, panic
//! or overrun in a partition goes to the [`health`] monitor, which applies the configured
//! action and reports it; a fault in the kernel itself warm-resets the module. The host can
//! also have the module warm-reset at a chosen point inside a partition's work
//! ([`armed_reset`]).
//!
//! The kernel is the link's byte pipe ([`link`]). When the whole module has nothing to do
//! until the host sends something, the I/O partition asks to wait for input
//! (`SYS_WAIT_FOR_INPUT`) and the kernel stops the schedule ("parks"): the CPU dozes with no
//! timer armed, which under QEMU's `-icount sleep=off` costs no host CPU, and the UART's
//! receive interrupt (the external interrupt, 0x500, through the Heathrow controller) is let
//! through; it restarts the schedule at a fresh major frame once a whole frame has arrived.
//! While the schedule runs the interrupt is held back and the I/O partition's reads drain the
//! UART, so no partition's CPU time includes a handler and no window start is delayed by one.
pub mod armed_reset;
pub mod deferred;
pub mod health;
pub mod klog;
pub mod link;
pub mod mmu;
pub mod ports;
pub mod sched;
pub mod syscall;
pub mod umem;

use core::ptr::addr_of_mut;

use kernel_config::abi::metric;
use kernel_logic::park::IdleDeclarations;

use crate::board::{heathrow, timebase};
use crate::boot;
use crate::config::{partition_image, PARTITION_COUNT};
use crate::shared;

use crate::context::{Context, KERNEL_FAULT_CONTEXT};

/// `table[i]` for an index the kernel made itself (a partition or window of the static
/// schedule, the running partition): out of range only if the kernel's own state is corrupt,
/// which ends in [`invariant_broken`] instead of a panic. Costs what a bounds check costs.
#[inline(always)]
#[track_caller]
pub fn at<T>(table: &[T], i: usize) -> &T {
    match table.get(i) {
        Some(item) => item,
        None => invariant_broken(),
    }
}

/// [`at`], mutable.
#[inline(always)]
#[track_caller]
pub fn at_mut<T>(table: &mut [T], i: usize) -> &mut T {
    match table.get_mut(i) {
        Some(item) => item,
        None => invariant_broken(),
    }
}

/// A kernel invariant did not hold (an index the kernel made itself was out of range): the
/// kernel reports the site to the host and warm-resets, as for a panic in the kernel
/// ([`crate::kernel_panic`]), without going through the panic machinery.
#[cold]
#[inline(never)]
#[track_caller]
pub fn invariant_broken() -> ! {
    let site = core::panic::Location::caller();
    crate::kernel_panic(site.file(), site.line())
}

impl Context {
    /// The context that starts partition `p` from scratch (see `__partition_start`): its
    /// run-time header and statics zeroed, not its stack (nothing reads a stack word it has
    /// not written, and the stack is the partition's own: 128 KiB of the executive's and of the
    /// planner's starts, about 115 ticks each, were spent zeroing it).
    fn partition_start(p: usize) -> Context {
        let image = partition_image(p);
        let mut ctx = Context::ZERO;
        ctx.gpr[3] = image.stack_top;
        ctx.gpr[4] = image.zero_end;
        ctx.gpr[5] = image.entry;
        ctx.gpr[6] = image.stack_top;
        ctx.srr0 = boot::__partition_start as *const () as u32;
        ctx.srr1 = boot::msr::PARTITION;
        ctx
    }

    /// The kernel's idle loop.
    fn idle() -> Context {
        let mut ctx = Context::ZERO;
        ctx.srr0 = boot::__kernel_idle as *const () as u32;
        ctx.srr1 = boot::msr::IDLE;
        ctx
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug, defmt::Format)]
pub enum RunState {
    /// Runs in its windows.
    Ready,
    /// Gave up the rest of its window; resumes at its next window start.
    Waiting,
    /// Stopped by the health monitor until the module resets.
    Halted,
}

/// Per-partition kernel bookkeeping.
#[derive(Clone, Copy)]
pub struct PartitionState {
    pub run: RunState,
    /// Restarts since boot; carried by every message the partition sends.
    pub generation: u32,
    /// Ticks used since boot.
    pub cpu_total: u64,
    /// Ticks used in the current window so far (up to the last switch-out).
    pub window_ticks: u32,
    /// Ticks used in the current major frame so far.
    pub frame_ticks: u32,
    pub last_frame_ticks: u32,
    pub worst_frame_ticks: u32,
    pub overruns: u32,
    pub max_jitter: u32,
    /// An overrun with action Log has been reported since the last (re)start.
    pub overrun_reported: bool,
}

impl PartitionState {
    const NEW: PartitionState = PartitionState {
        run: RunState::Ready,
        generation: 0,
        cpu_total: 0,
        window_ticks: 0,
        frame_ticks: 0,
        last_frame_ticks: 0,
        worst_frame_ticks: 0,
        overruns: 0,
        max_jitter: 0,
        overrun_reported: false,
    };
}

/// What runs after the kernel returns.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Next {
    Partition(usize),
    Idle,
}

pub struct Kernel {
    contexts: [Context; PARTITION_COUNT],
    idle: Context,
    pub parts: [PartitionState; PARTITION_COUNT],
    pub sched: sched::Scheduler,
    pub ports: ports::Ports,
    pub events: health::EventQueue,
    pub boot_cause: u32,
    pub boot_count: u32,
    /// Bytes of non-volatile memory mapped at `kernel_config::NV_BASE` (0: none).
    pub nv_bytes: u32,
    pub mission_time_us: u64,
    /// Ticks from the reset vector to the start of the schedule (SYS_UPTIME's r5).
    pub boot_ticks: u64,
    /// A warm reset the host armed inside a partition's work, if any.
    pub armed: armed_reset::ArmedReset,
    /// Partition whose regions DBAT1..3 map now.
    mapped: Option<usize>,
    /// The link to the host (transport, receive ring, counters).
    pub link: link::KernelLink,
    /// Partitions that have nothing to do until a message arrives for them.
    pub idle_declared: IdleDeclarations,
    /// The link's receive interrupt is let through the Heathrow controller (only while parked).
    link_interrupt_enabled: bool,
    /// Times the schedule was stopped to wait for input.
    pub parks: u32,
}

static mut KERNEL: Kernel = Kernel {
    contexts: [Context::ZERO; PARTITION_COUNT],
    idle: Context::ZERO,
    parts: [PartitionState::NEW; PARTITION_COUNT],
    sched: sched::Scheduler::new(),
    ports: ports::Ports::new(),
    events: health::EventQueue::new(),
    boot_cause: 0,
    boot_count: 0,
    nv_bytes: 0,
    mission_time_us: 0,
    boot_ticks: 0,
    armed: armed_reset::ArmedReset::new(),
    mapped: None,
    link: link::KernelLink::new(),
    idle_declared: IdleDeclarations::new(),
    link_interrupt_enabled: false,
    parks: 0,
};

/// The kernel's state, for kernel code only.
///
/// # Safety
/// 1. Called only in kernel context (boot, trap handlers) with interrupts off, on the single
///    core, and the returned reference is not kept across a return to a partition; so no two
///    live `&mut Kernel` exist.
pub unsafe fn kernel() -> &'static mut Kernel {
    &mut *addr_of_mut!(KERNEL)
}

/// What the reset stub did, for the boot breakdown (`metric::BOOT_*`).
#[derive(Clone, Copy)]
pub struct StubReport {
    /// How the RAM image was made good.
    pub image: boot::ImageCheck,
    /// Reset vector to the image checked or copied (and `.kshared` and kernel data reloaded).
    pub image_ticks: u32,
    /// `.bss` and the hashed page table cleared.
    pub clear_ticks: u32,
}

/// Start the partitions: called once at boot, never returns. `link_device`: the shared-memory
/// link transport, when the board has it. `stub`: what the reset stub did, queued for the host
/// with the kernel's own part of the boot as the schedule starts.
pub fn start(
    boot_cause: u32,
    boot_count: u32,
    nv_bytes: u32,
    link_device: Option<link::SharedMemoryDevice>,
    stub: StubReport,
) -> ! {
    boot::enable_doze();
    mmu::init();
    deferred::boot(stub.image);
    // SAFETY: boot, interrupts off, nothing else holds the kernel state.
    let k = unsafe { kernel() };
    if let Some(device) = link_device {
        k.link.use_shared_memory(device);
    }
    k.boot_cause = boot_cause;
    k.boot_count = boot_count;
    k.nv_bytes = nv_bytes;
    for (p, ctx) in k.contexts.iter_mut().enumerate() {
        *ctx = Context::partition_start(p);
    }
    let now = timebase::now().0;
    // The kernel's part of boot to ready: reset stub, board bring-up and the set-up above.
    k.boot_ticks = now.wrapping_sub(shared::boot_ticks());
    let stub_ticks = u64::from(stub.image_ticks) + u64::from(stub.clear_ticks);
    k.events
        .metric(metric::BOOT_STUB_IMAGE_TICKS, u64::from(stub.image_ticks));
    k.events
        .metric(metric::BOOT_STUB_CLEAR_TICKS, u64::from(stub.clear_ticks));
    k.events.metric(
        metric::BOOT_KERNEL_INIT_TICKS,
        k.boot_ticks.saturating_sub(stub_ticks),
    );
    k.events.metric(metric::BOOT_IMAGE, stub.image.code());
    let next = k.sched_start(now);
    let ctx = k.resume(next, now);
    // SAFETY:
    // 1. `ctx` is a complete context the kernel prepared (a partition start or idle).
    // 2. `__context_resume` points SPRG2 at it, so the next exception saves into it.
    unsafe { boot::__context_resume(ctx) }
}

impl Kernel {
    /// Prepare `next` to run: map its regions, account the switch, and say which context the
    /// resume code enters.
    fn resume(&mut self, next: Next, entry: u64) -> *const Context {
        // The receive interrupt only while the schedule is stopped waiting for input: a
        // partition's CPU time, counted with the decrementer, never includes a handler, and no
        // handler ever delays a window start (the I/O partition reads what arrives meanwhile).
        self.set_link_interrupt(next == Next::Idle && self.is_parked());
        match next {
            Next::Partition(p) => {
                if self.mapped != Some(p) {
                    mmu::map(p);
                    self.mapped = Some(p);
                }
                shared::set_running(Some(p));
                // A switch (not the return from a system call, which stays charged to `p`).
                // Last: it writes the decrementer `p`'s CPU time counts from.
                if self.sched.running != Some(p) {
                    let now = timebase::now().0;
                    self.switched_in(p, entry, now);
                }
                at(&self.contexts, p)
            }
            Next::Idle => {
                self.sched.running = None;
                self.idle = Context::idle();
                shared::set_running(None);
                &self.idle
            }
        }
    }

    fn set_link_interrupt(&mut self, enabled: bool) {
        if self.link_interrupt_enabled != enabled {
            heathrow::enable_link_interrupt(enabled);
            self.link_interrupt_enabled = enabled;
        }
    }

    /// The link's receive interrupt: clear its event, move what the UART holds into the ring.
    fn on_link_interrupt(&mut self) {
        heathrow::take_link_event();
        self.link.drain_uart();
    }

    /// (Re)start partition `p` from its entry: fresh statics, next generation.
    pub fn restart(&mut self, p: usize) {
        self.idle_declared.withdraw(p);
        *at_mut(&mut self.contexts, p) = Context::partition_start(p);
        let state = at_mut(&mut self.parts, p);
        state.generation = state.generation.wrapping_add(1);
        state.run = RunState::Ready;
        state.overrun_reported = false;
    }

    pub fn context(&mut self, p: usize) -> &mut Context {
        at_mut(&mut self.contexts, p)
    }
}

/// Test image: the rogue partition's `rogue::KERNEL_FAULT_CALL` makes the kernel itself fault
/// (a `trap`, a program exception in supervisor state outside any partition), so that the
/// tests can watch a kernel fault warm-reset the module and reach the next Hello.
#[cfg(feature = "test-partitions")]
fn test_fault_hook(p: usize, ctx: &Context) {
    if p == kernel_config::system::ROGUE
        && ctx.gpr[0] == kernel_config::abi::rogue::KERNEL_FAULT_CALL
    {
        // SAFETY: deliberately faults: `trap` raises a program exception, which the entry code
        // saves in the kernel-fault area and `kernel_trap` turns into a warm reset; nothing
        // after it runs.
        unsafe { core::arch::asm!("trap", options(nomem, nostack)) };
    }
}

/// Entered from `__exception_common` with the MMU off, interrupts off, on the kernel stack.
/// `ctx` is where the interrupted registers were saved. Returns the context to resume.
#[no_mangle]
pub extern "C" fn kernel_trap(
    vector: u32,
    ctx: *mut Context,
    dar: u32,
    dsisr: u32,
) -> *const Context {
    let entry = timebase::now().0;
    let entry_dec = sched::read_dec();
    shared::set_running(None);
    if ctx == addr_of_mut!(KERNEL_FAULT_CONTEXT) {
        // SAFETY: the entry code just wrote this context; nothing else uses it.
        let c = unsafe { &*ctx };
        health::kernel_fault(vector, c.srr0, c.srr1, dar, dsisr);
    }
    // SAFETY: kernel context, interrupts off; the reference ends when this trap returns.
    let k = unsafe { kernel() };
    k.sched.entry_dec = entry_dec;
    if vector == 0x900 && sched::is_stale_decrementer_interrupt(entry_dec) {
        // Raised by a deadline the kernel has replaced since (see `sched`): whoever was
        // interrupted continues as if nothing happened.
        let next = match k.sched.running {
            Some(p) => Next::Partition(p),
            None => Next::Idle,
        };
        return k.resume(next, entry);
    }
    let next = match k.sched.running {
        Some(p) => {
            debug_assert!(core::ptr::eq(ctx, at(&k.contexts, p)));
            match vector {
                0x900 => k.on_timer(entry),
                0xc00 => {
                    #[cfg(feature = "test-partitions")]
                    test_fault_hook(p, at(&k.contexts, p));
                    k.syscall(p, entry)
                }
                // Held back at the controller while partitions run; should one get through
                // anyway, the partition continues (its stint includes this handler).
                0x500 => {
                    k.on_link_interrupt();
                    Next::Partition(p)
                }
                0x400 if at(&k.contexts, p).srr0 >= kernel_config::DEFERRED_CODE_BASE => {
                    let srr0 = at(&k.contexts, p).srr0;
                    match deferred::on_fetch_fault(srr0) {
                        // Checked and mapped: the partition fetches the instruction again.
                        deferred::FetchFault::Checked => Next::Partition(p),
                        deferred::FetchFault::Damaged => k.deferred_code_damaged(p, srr0),
                        deferred::FetchFault::Fault => k.partition_fault(
                            p,
                            kernel_config::ErrorKind::InstructionStorage,
                            srr0,
                            entry,
                        ),
                    }
                }
                _ => {
                    let srr0 = at(&k.contexts, p).srr0;
                    let address = if vector == 0x300 { dar } else { srr0 };
                    let kind = kernel_config::ErrorKind::from_vector(vector);
                    k.partition_fault(p, kind, address, entry)
                }
            }
        }
        None => {
            // SAFETY: as above, the entry code wrote it.
            let c = unsafe { &*ctx };
            if vector == 0x900 && c.srr1 & boot::msr::PR == 0 {
                k.on_timer(entry)
            } else if vector == 0x500 && c.srr1 & boot::msr::PR == 0 {
                k.on_link_interrupt();
                k.on_input_while_idle(timebase::now().0)
            } else {
                health::kernel_fault(vector, c.srr0, c.srr1, dar, dsisr)
            }
        }
    };
    k.resume(next, entry)
}
