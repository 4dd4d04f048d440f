//! Kernel event records: how the kernel queues a health-monitor event or a metric for the host
//! and hands it to the I/O partition (`SYS_EVENT_DRAIN`, [`EVENT_RECORD_SIZE`] bytes each, four
//! big-endian words), and the message the I/O partition makes of one. The format is the ABI
//! between the kernel (`firmware/image`) and the I/O partition (`firmware/task-io`), so both
//! take it from here.
use fsw_bridge::{TargetToHost, TelemetryEvent};
use kernel_config::abi::{EVENT_HEALTH_MONITOR, EVENT_METRIC, EVENT_RECORD_SIZE};
use kernel_config::{ErrorKind, HmAction};

/// A kernel event as the I/O partition drains it: `[EVENT_HEALTH_MONITOR, partition | kind <<
/// 8 | action << 16, address, 0]` or `[EVENT_METRIC, id, value high, value low]`.
pub type EventRecord = [u32; 4];

/// The record of metric `id` with `value`.
pub fn metric_record(id: u16, value: u64) -> EventRecord {
    [
        EVENT_METRIC,
        u32::from(id),
        (value >> 32) as u32,
        value as u32,
    ]
}

/// The record of a health-monitor event: `kind` in `partition` at `address`, and the `action`
/// taken.
pub fn health_record(
    partition: u8,
    kind: ErrorKind,
    address: u32,
    action: HmAction,
) -> EventRecord {
    [
        EVENT_HEALTH_MONITOR,
        u32::from(partition) | (kind as u32) << 8 | (action as u32) << 16,
        address,
        0,
    ]
}

/// The message an event record stands for (None: not a kind of record this build knows).
pub fn event_message(record: &EventRecord) -> Option<TargetToHost> {
    let [kind, a, b, c] = *record;
    let event = match kind {
        EVENT_HEALTH_MONITOR => TelemetryEvent::HealthMonitor {
            partition: a as u8,
            kind: (a >> 8) as u8,
            address: b,
            action: (a >> 16) as u8,
        },
        EVENT_METRIC => TelemetryEvent::Metric {
            id: a as u16,
            value: (u64::from(b) << 32) | u64::from(c),
        },
        _ => return None,
    };
    Some(TargetToHost::Telemetry(event))
}

/// A record as `SYS_EVENT_DRAIN` writes it into the partition's buffer.
pub fn record_bytes(record: &EventRecord) -> [u8; EVENT_RECORD_SIZE] {
    let mut out = [0u8; EVENT_RECORD_SIZE];
    for (bytes, word) in out.as_chunks_mut::<4>().0.iter_mut().zip(record) {
        *bytes = word.to_be_bytes();
    }
    out
}

/// The record `bytes` hold ([`record_bytes`] undone).
pub fn record_from_bytes(bytes: &[u8; EVENT_RECORD_SIZE]) -> EventRecord {
    let mut record = [0u32; 4];
    for (word, be) in record.iter_mut().zip(bytes.as_chunks::<4>().0) {
        *word = u32::from_be_bytes(*be);
    }
    record
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_health_record_becomes_the_health_monitor_event_it_was_made_from() {
        let record = health_record(
            2,
            ErrorKind::DataStorage,
            0x0123_4568,
            HmAction::RestartPartition,
        );
        let bytes = record_bytes(&record);
        assert_eq!(record_from_bytes(&bytes), record);
        assert_eq!(
            event_message(&record_from_bytes(&bytes)),
            Some(TargetToHost::Telemetry(TelemetryEvent::HealthMonitor {
                partition: 2,
                kind: ErrorKind::DataStorage as u8,
                address: 0x0123_4568,
                action: HmAction::RestartPartition as u8,
            }))
        );
    }

    #[test]
    fn a_metric_record_keeps_all_64_bits_of_its_value() {
        let record = metric_record(0x1234, 0x0102_0304_0506_0708);
        assert_eq!(record_bytes(&record)[..4], EVENT_METRIC.to_be_bytes());
        assert_eq!(
            event_message(&record_from_bytes(&record_bytes(&record))),
            Some(TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: 0x1234,
                value: 0x0102_0304_0506_0708,
            }))
        );
    }

    #[test]
    fn an_unknown_record_kind_is_no_message() {
        assert_eq!(event_message(&[0, 1, 2, 3]), None);
        assert_eq!(event_message(&[EVENT_METRIC + 1, 1, 2, 3]), None);
    }
}
