//! Which service and virtual channel each message uses, and the message classes the link keeps
//! statistics for. The integrator calls [`uplink_service`] and [`downlink_service`] to route a
//! message and the endpoint calls [`LinkMessage::class`] to count it.
use crate::codec::WireMessage;
use crate::link::frame::VirtualChannel;
use crate::messages::{HostToTarget, TargetToHost, TelemetryEvent};

/// What a message is, for per-class counters (sent, retransmitted, delivered, lost to reset).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum MessageClass {
    /// The target's boot announcement.
    Hello,
    /// Ping and Pong.
    LinkCheck,
    /// The lockstep time driver's grants.
    TimeGrant,
    /// The target's report that a granted frame is done.
    FrameDone,
    /// State-buffer updates.
    StateUpdate,
    /// Commands the executive dispatches.
    CommandDispatch,
    /// Subsystems' replies to dispatched commands.
    CommandResponse,
    /// Task-network uplink chunks.
    UplinkChunk,
    /// The target's UplinkAck and UplinkNak.
    UplinkReply,
    /// The host's reset requests.
    ResetRequest,
    /// Task transitions and plan modifications.
    Telemetry,
    /// Named measurements (costs, counters).
    Metric,
    /// Kernel health-monitor events.
    HealthEvent,
    /// defmt log chunks.
    Log,
    /// Panic reports.
    Panic,
    /// Authenticated ground commands.
    GroundCommand,
    /// The target's GroundCommandAck and GroundCommandNak.
    GroundCommandReply,
}

impl MessageClass {
    /// Number of classes (size of per-class arrays).
    pub const COUNT: usize = 17;

    /// Every class, in index order.
    pub const ALL: [MessageClass; MessageClass::COUNT] = [
        MessageClass::Hello,
        MessageClass::LinkCheck,
        MessageClass::TimeGrant,
        MessageClass::FrameDone,
        MessageClass::StateUpdate,
        MessageClass::CommandDispatch,
        MessageClass::CommandResponse,
        MessageClass::UplinkChunk,
        MessageClass::UplinkReply,
        MessageClass::ResetRequest,
        MessageClass::Telemetry,
        MessageClass::Metric,
        MessageClass::HealthEvent,
        MessageClass::Log,
        MessageClass::Panic,
        MessageClass::GroundCommand,
        MessageClass::GroundCommandReply,
    ];

    /// Index into per-class arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Name for report tables.
    pub const fn name(self) -> &'static str {
        match self {
            MessageClass::Hello => "hello",
            MessageClass::LinkCheck => "link check",
            MessageClass::TimeGrant => "time grant",
            MessageClass::FrameDone => "frame done",
            MessageClass::StateUpdate => "state update",
            MessageClass::CommandDispatch => "command dispatch",
            MessageClass::CommandResponse => "command response",
            MessageClass::UplinkChunk => "uplink chunk",
            MessageClass::UplinkReply => "uplink ack/nak",
            MessageClass::ResetRequest => "reset request",
            MessageClass::Telemetry => "telemetry",
            MessageClass::Metric => "metric",
            MessageClass::HealthEvent => "health event",
            MessageClass::Log => "log",
            MessageClass::Panic => "panic",
            MessageClass::GroundCommand => "ground command",
            MessageClass::GroundCommandReply => "ground command ack/nak",
        }
    }
}

/// A message set the reliable link carries: it can be framed and it knows its class.
pub trait LinkMessage: WireMessage {
    /// The class this message is counted under.
    fn class(&self) -> MessageClass;
}

impl LinkMessage for HostToTarget {
    fn class(&self) -> MessageClass {
        match self {
            HostToTarget::Ping { .. } => MessageClass::LinkCheck,
            HostToTarget::TimeGrant { .. } => MessageClass::TimeGrant,
            HostToTarget::StateUpdate { .. } => MessageClass::StateUpdate,
            HostToTarget::CommandResponse { .. } => MessageClass::CommandResponse,
            HostToTarget::UplinkChunk { .. } => MessageClass::UplinkChunk,
            HostToTarget::ResetRequest { .. } => MessageClass::ResetRequest,
            HostToTarget::GroundCommand { .. } => MessageClass::GroundCommand,
            // A temporal task is an uplink too, counted with the task-network chunks.
            HostToTarget::TemporalBegin { .. } | HostToTarget::TemporalChunk { .. } => {
                MessageClass::UplinkChunk
            }
            // The lander executor's setup is an uplink too; its steps are the host's
            // observations, counted with the state updates.
            HostToTarget::LanderBegin { .. } | HostToTarget::LanderChunk { .. } => {
                MessageClass::UplinkChunk
            }
            HostToTarget::LanderStep { .. } | HostToTarget::LanderInput { .. } => {
                MessageClass::StateUpdate
            }
            // The rover mission's events are the host's observations too.
            HostToTarget::Rover { .. } => MessageClass::StateUpdate,
        }
    }
}

impl LinkMessage for TargetToHost {
    fn class(&self) -> MessageClass {
        match self {
            TargetToHost::Hello { .. } => MessageClass::Hello,
            TargetToHost::Pong { .. } => MessageClass::LinkCheck,
            TargetToHost::FrameDone { .. } => MessageClass::FrameDone,
            TargetToHost::CommandDispatch { .. } => MessageClass::CommandDispatch,
            TargetToHost::Log { .. } => MessageClass::Log,
            TargetToHost::Telemetry(TelemetryEvent::Metric { .. }) => MessageClass::Metric,
            TargetToHost::Telemetry(TelemetryEvent::HealthMonitor { .. }) => {
                MessageClass::HealthEvent
            }
            TargetToHost::Telemetry(
                TelemetryEvent::TaskTransition { .. }
                | TelemetryEvent::PlanModification { .. }
                | TelemetryEvent::StateStale { .. },
            ) => MessageClass::Telemetry,
            TargetToHost::UplinkAck { .. } | TargetToHost::UplinkNak { .. } => {
                MessageClass::UplinkReply
            }
            TargetToHost::Panic { .. } => MessageClass::Panic,
            TargetToHost::GroundCommandAck { .. } | TargetToHost::GroundCommandNak { .. } => {
                MessageClass::GroundCommandReply
            }
            // The answers to a temporal uplink, its plan included.
            TargetToHost::Temporal(_) => MessageClass::UplinkReply,
            // The lander executor's answers (its setup's acceptance, its decisions).
            TargetToHost::Lander(_) => MessageClass::UplinkReply,
        }
    }
}

/// How a message travels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Service {
    /// Type-AD on this virtual channel: delivered exactly once and in order, or the link is
    /// declared lost.
    Sequenced(VirtualChannel),
    /// Type-BD: sent once, may be lost or duplicated by the channel.
    Expedited,
}

/// The service of a host-to-target message: Ping is expedited (a link check must not wait
/// behind retransmissions); everything else is on the Mission channel, ResetRequest included
/// (a mid-frame reset must arrive before the grant it applies to), and so are ground commands
/// (exactly once and in order: their anti-replay sequence numbers must arrive increasing).
pub fn uplink_service(msg: &HostToTarget) -> Service {
    match msg {
        HostToTarget::Ping { .. } => Service::Expedited,
        HostToTarget::TimeGrant { .. }
        | HostToTarget::StateUpdate { .. }
        | HostToTarget::CommandResponse { .. }
        | HostToTarget::UplinkChunk { .. }
        | HostToTarget::ResetRequest { .. }
        | HostToTarget::GroundCommand { .. }
        | HostToTarget::TemporalBegin { .. }
        | HostToTarget::TemporalChunk { .. }
        | HostToTarget::LanderBegin { .. }
        | HostToTarget::LanderChunk { .. }
        | HostToTarget::LanderStep { .. }
        | HostToTarget::LanderInput { .. }
        | HostToTarget::Rover { .. } => Service::Sequenced(VirtualChannel::Mission),
    }
}

/// The service of a target-to-host message. Hello, Pong and Panic are expedited. Logs go on the
/// Instrument channel; a telemetry event goes where the telemetry dictionary says
/// ([`crate::dictionary::event_channel`]: health-monitor events, measured costs and the
/// platform's metrics, which only the emulated target sends, on the Instrument channel).
/// Everything else is on the Mission channel, identical on every target.
pub fn downlink_service(msg: &TargetToHost) -> Service {
    use VirtualChannel::Mission;
    match msg {
        // A panic report is the last thing a target sends before it resets itself: it cannot
        // wait for an acknowledgement, so it travels like the Hello that follows it.
        TargetToHost::Hello { .. } | TargetToHost::Pong { .. } | TargetToHost::Panic { .. } => {
            Service::Expedited
        }
        TargetToHost::Log { .. } => Service::Sequenced(VirtualChannel::Instrument),
        TargetToHost::Telemetry(event) => {
            Service::Sequenced(crate::dictionary::event_channel(event))
        }
        TargetToHost::FrameDone { .. }
        | TargetToHost::CommandDispatch { .. }
        | TargetToHost::UplinkAck { .. }
        | TargetToHost::UplinkNak { .. }
        | TargetToHost::GroundCommandAck { .. }
        | TargetToHost::GroundCommandNak { .. }
        | TargetToHost::Temporal(_)
        | TargetToHost::Lander(_) => Service::Sequenced(Mission),
    }
}
