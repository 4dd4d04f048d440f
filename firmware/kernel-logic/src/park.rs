//! Whether the module may stop its schedule while it waits for the host.
//!
//! The link owner (the I/O partition) calls `SYS_WAIT_FOR_INPUT` when it has sent everything and
//! has nothing left to decode: typically right after the end of a lockstep round (FrameDone and
//! everything before it have left). The kernel then stops the schedule only if nobody else has
//! anything to do either: every other partition has declared itself idle (`SYS_WAIT_NEXT_WINDOW`
//! with `wait::IDLE`) and received nothing since, no queuing port holds a message, the kernel
//! has no log bytes or events for the host, the host has not asked for periodic reports, and no
//! reset is armed inside a partition's work. Input already received wins over all of that: the
//! caller is told to read it.
//!
//! Stopping the schedule is what lets an emulated target wait without burning a host core: under
//! `-icount sleep=off` QEMU jumps virtual time to the next timer deadline whenever the CPU idles,
//! so a schedule that keeps running while the host thinks turns into a busy loop of window starts.
use kernel_config::abi::{wait, wait_input, SysError};

/// What the kernel knows when the link owner asks to wait for input.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModuleState {
    /// Bytes received and not yet read by the link owner (the kernel's ring, or the UART).
    pub input_pending: bool,
    /// Partitions (bit p) other than the caller that are neither halted nor idle.
    pub busy_partitions: u32,
    /// A queuing port holds a message its destination has not taken.
    pub message_in_flight: bool,
    pub log_pending: bool,
    pub events_pending: bool,
    pub periodic_reports: bool,
    pub reset_armed: bool,
}

/// What `SYS_WAIT_FOR_INPUT` does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Return at once: there is input to read.
    InputPending,
    /// Stop the schedule until input arrives.
    Park,
    /// Wait for the caller's next window like `SYS_WAIT_NEXT_WINDOW`; `reasons` are
    /// `wait_input::*` bits, `busy` the busy partitions.
    NextWindow { reasons: u32, busy: u32 },
}

/// The decision for `state`.
pub fn decide(state: &ModuleState) -> Decision {
    if state.input_pending {
        return Decision::InputPending;
    }
    let reasons = reasons_not_to_park(state);
    if reasons == 0 {
        Decision::Park
    } else {
        Decision::NextWindow {
            reasons,
            busy: state.busy_partitions,
        }
    }
}

/// Why the module could not park now, input aside (`wait_input::*` bits; 0: quiet).
pub fn reasons_not_to_park(state: &ModuleState) -> u32 {
    [
        (state.busy_partitions != 0, wait_input::PARTITION_BUSY),
        (state.message_in_flight, wait_input::MESSAGE_IN_FLIGHT),
        (state.log_pending, wait_input::LOG_PENDING),
        (state.events_pending, wait_input::EVENTS_PENDING),
        (state.periodic_reports, wait_input::PERIODIC_REPORTS),
        (state.reset_armed, wait_input::RESET_ARMED),
    ]
    .iter()
    .filter(|(holds, _)| *holds)
    .fold(0, |bits, (_, bit)| bits | bit)
}

/// `SYS_WAIT_FOR_INPUT`'s arguments: r3 is 0 (wait) or `wait_input::QUERY` (ask without
/// waiting), every other register 0, so that a later revision can give them a meaning without
/// old callers passing garbage. Returns true for a query.
pub fn check_wait_for_input_args(args: &[u32; 5]) -> Result<bool, SysError> {
    let query = match args[0] {
        0 => false,
        wait_input::QUERY => true,
        _ => return Err(SysError::Range),
    };
    if args[1..].iter().all(|&a| a == 0) {
        Ok(query)
    } else {
        Err(SysError::Range)
    }
}

/// `SYS_WAIT_NEXT_WINDOW`'s argument: true when the caller declares itself idle.
pub fn wait_declares_idle(until: u32) -> Result<bool, SysError> {
    match until {
        wait::NEXT_WINDOW => Ok(false),
        wait::IDLE => Ok(true),
        _ => Err(SysError::Range),
    }
}

/// Which partitions have declared themselves idle, as bits. A declaration holds until the
/// partition runs again or a message is sent to it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IdleDeclarations {
    idle: u32,
}

impl IdleDeclarations {
    pub const fn new() -> Self {
        Self { idle: 0 }
    }

    /// Partition `p` has nothing to do until a message arrives for it.
    pub fn declare(&mut self, p: usize) {
        self.idle |= 1 << p;
    }

    /// Partition `p` runs again, or a message was sent to it: it may have work.
    pub fn withdraw(&mut self, p: usize) {
        self.idle &= !(1 << p);
    }

    pub fn is_idle(&self, p: usize) -> bool {
        self.idle & (1 << p) != 0
    }

    /// Of `partitions` partitions, those other than `caller` that are neither idle nor in
    /// `halted` (bits), as bits.
    pub fn busy(&self, caller: usize, halted: u32, partitions: usize) -> u32 {
        let all = if partitions >= 32 {
            u32::MAX
        } else {
            (1u32 << partitions) - 1
        };
        all & !self.idle & !halted & !(1 << caller)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quiet_module_parks() {
        assert_eq!(decide(&ModuleState::default()), Decision::Park);
    }

    #[test]
    fn input_already_received_is_read_first_whatever_else_holds() {
        let state = ModuleState {
            input_pending: true,
            busy_partitions: 0b110,
            log_pending: true,
            ..ModuleState::default()
        };
        assert_eq!(decide(&state), Decision::InputPending);
    }

    #[test]
    fn every_reason_not_to_park_is_named() {
        let cases = [
            (
                ModuleState {
                    busy_partitions: 0b100,
                    ..ModuleState::default()
                },
                wait_input::PARTITION_BUSY,
            ),
            (
                ModuleState {
                    message_in_flight: true,
                    ..ModuleState::default()
                },
                wait_input::MESSAGE_IN_FLIGHT,
            ),
            (
                ModuleState {
                    log_pending: true,
                    ..ModuleState::default()
                },
                wait_input::LOG_PENDING,
            ),
            (
                ModuleState {
                    events_pending: true,
                    ..ModuleState::default()
                },
                wait_input::EVENTS_PENDING,
            ),
            (
                ModuleState {
                    periodic_reports: true,
                    ..ModuleState::default()
                },
                wait_input::PERIODIC_REPORTS,
            ),
            (
                ModuleState {
                    reset_armed: true,
                    ..ModuleState::default()
                },
                wait_input::RESET_ARMED,
            ),
        ];
        for (state, reason) in cases {
            assert_eq!(
                decide(&state),
                Decision::NextWindow {
                    reasons: reason,
                    busy: state.busy_partitions
                },
                "{state:?}"
            );
        }
        let everything = ModuleState {
            input_pending: false,
            busy_partitions: 0b10,
            message_in_flight: true,
            log_pending: true,
            events_pending: true,
            periodic_reports: true,
            reset_armed: true,
        };
        assert_eq!(
            decide(&everything),
            Decision::NextWindow {
                reasons: 0b11_1111,
                busy: 0b10
            }
        );
    }

    #[test]
    fn wait_for_input_takes_only_its_query_mode() {
        assert_eq!(check_wait_for_input_args(&[0; 5]), Ok(false));
        assert_eq!(
            check_wait_for_input_args(&[wait_input::QUERY, 0, 0, 0, 0]),
            Ok(true)
        );
        assert_eq!(
            check_wait_for_input_args(&[2, 0, 0, 0, 0]),
            Err(SysError::Range)
        );
        for i in 1..5 {
            let mut args = [0; 5];
            args[i] = 1;
            assert_eq!(
                check_wait_for_input_args(&args),
                Err(SysError::Range),
                "argument {i}"
            );
        }
        assert_eq!(
            check_wait_for_input_args(&[u32::MAX; 5]),
            Err(SysError::Range)
        );
    }

    #[test]
    fn wait_next_window_accepts_only_its_two_modes() {
        assert_eq!(wait_declares_idle(wait::NEXT_WINDOW), Ok(false));
        assert_eq!(wait_declares_idle(wait::IDLE), Ok(true));
        assert_eq!(wait_declares_idle(2), Err(SysError::Range));
        assert_eq!(wait_declares_idle(u32::MAX), Err(SysError::Range));
    }

    #[test]
    fn a_declaration_holds_until_the_partition_runs_or_gets_a_message() {
        let mut idle = IdleDeclarations::new();
        // Partitions 0 (the caller), 1, 2; none declared: 1 and 2 are busy.
        assert_eq!(idle.busy(0, 0, 3), 0b110);
        idle.declare(1);
        idle.declare(2);
        assert_eq!(idle.busy(0, 0, 3), 0);
        // A message for 2: busy again until it declares once more.
        idle.withdraw(2);
        assert_eq!(idle.busy(0, 0, 3), 0b100);
        assert!(!idle.is_idle(2));
        idle.declare(2);
        assert!(idle.is_idle(2));
        assert_eq!(idle.busy(0, 0, 3), 0);
    }

    #[test]
    fn halted_partitions_and_the_caller_never_count_as_busy() {
        let idle = IdleDeclarations::new();
        assert_eq!(idle.busy(0, 0b1000, 4), 0b0110);
        assert_eq!(idle.busy(2, 0, 3), 0b011);
        assert_eq!(idle.busy(0, 0, 32), !1);
    }
}
