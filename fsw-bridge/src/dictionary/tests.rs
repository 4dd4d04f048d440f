//! The dictionary's own checks: ids and names unique, families apart, every measured cost on
//! the Instrument channel, and the compact routes the firmware links agreeing with the tables.

use super::*;

#[test]
fn the_compact_routes_the_firmware_links_agree_with_the_dictionary() {
    for m in metrics() {
        for id in m.id..m.id + m.instances {
            assert_eq!(metric_channel(id), m.channel, "{}", m.name);
        }
    }
    for id in [0x0fff, 0x1fff, 0xffff] {
        if metric(id).is_none() {
            assert_eq!(metric_channel(id), VirtualChannel::Instrument);
        }
    }
    let at = crate::MissionTimeUs::ZERO;
    let events = [
        TelemetryEvent::TaskTransition {
            task: 1,
            from: 0,
            to: 1,
            at,
        },
        TelemetryEvent::PlanModification {
            kind: 1,
            task: 1,
            template: 1,
            at,
        },
        TelemetryEvent::StateStale {
            key: crate::StateKey(1),
            measured_at: at,
            at,
        },
    ];
    for ev in &events {
        assert_eq!(event_channel(ev), event(ev).channel);
    }
}
use crate::security::SecurityRefusal;
use std::collections::BTreeSet;
use std::vec::Vec;

fn every_id() -> Vec<(u16, &'static str)> {
    metrics()
        .flat_map(|m| (0..m.instances).map(move |i| (m.id + i, m.constant)))
        .collect()
}

#[test]
fn every_id_is_unique_and_families_do_not_overlap() {
    let ids = every_id();
    let unique: BTreeSet<u16> = ids.iter().map(|(id, _)| *id).collect();
    assert_eq!(unique.len(), ids.len(), "an id is used twice: {ids:x?}");
    for (id, constant) in &ids {
        let found = metric(*id).expect("every id resolves");
        assert_eq!(found.constant, *constant, "{id:#06x}");
    }
    assert!(metric(0x0fff).is_none());
    assert!(metric(0x0100 + PARTITION_IDS).is_some_and(|m| m.constant == "WORST_FRAME_TICKS"));
}

#[test]
fn names_and_constants_are_unique_and_lookups_find_them() {
    let names: BTreeSet<&str> = metrics().map(|m| m.name).collect();
    let constants: BTreeSet<&str> = metrics().map(|m| m.constant).collect();
    let count = metrics().count();
    assert_eq!(names.len(), count, "a name is used twice");
    assert_eq!(constants.len(), count, "a constant is used twice");
    for m in metrics() {
        assert_eq!(metric_named(m.name), Some(m));
        assert!(
            !m.meaning.trim().is_empty(),
            "{} has no meaning",
            m.constant
        );
        assert!(
            m.name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_'),
            "{} is not snake case",
            m.name
        );
    }
}

#[test]
fn the_tables_hold_their_id_ranges() {
    assert!(platform::PLATFORM_METRICS
        .iter()
        .all(|m| m.id + m.instances <= 0x1000));
    assert!(app::APP_METRICS.iter().all(|m| m.id >= 0x1000));
}

/// The Mission channel must be identical on the native and the emulated target: a measured
/// cost (which the native target cannot have) never travels on it, nor does anything only
/// the firmware's platform sends.
#[test]
fn measured_costs_and_platform_metrics_are_instrumentation() {
    for m in metrics() {
        if m.is_measured_cost() || m.sender != Sender::FlightApp {
            assert_eq!(m.channel, VirtualChannel::Instrument, "{}", m.constant);
        } else {
            assert_eq!(m.channel, VirtualChannel::Mission, "{}", m.constant);
        }
    }
    assert!(is_measured_cost(app::STEP_TICKS));
    assert!(!is_measured_cost(app::GROUND_HOLDS));
    assert_eq!(metric_channel(0x0fff), VirtualChannel::Instrument);
    assert_eq!(metric_channel(app::GROUND_HOLDS), VirtualChannel::Mission);
    assert_eq!(
        metric_channel(platform::OVERRUNS + 3),
        VirtualChannel::Instrument
    );
}

#[test]
fn code_values_have_names_and_codes_only() {
    for m in metrics() {
        assert_eq!(m.unit == Unit::Code, !m.values.is_empty(), "{}", m.constant);
        let values: BTreeSet<u64> = m.values.iter().map(|(v, _)| *v).collect();
        assert_eq!(values.len(), m.values.len(), "{}", m.constant);
    }
    let boot = metric(platform::BOOT_IMAGE).unwrap();
    assert_eq!(boot.value_name(boot_image::REPAIRED), Some("repaired"));
    assert_eq!(boot.value_name(99), None);
}

#[test]
fn refusal_family_covers_every_reason() {
    for reason in SecurityRefusal::ALL {
        let id = app::security_refusals(reason);
        assert_eq!(app::security_refusal_of(id), Some(reason));
        assert_eq!(
            metric(id).map(|m| m.constant),
            Some("SECURITY_REFUSALS_FIRST")
        );
    }
    let past = app::SECURITY_REFUSALS_FIRST + SecurityRefusal::COUNT as u16;
    assert_eq!(app::security_refusal_of(past), None);
    assert!(metric(past).is_none());
}

#[test]
fn events_are_indexed_by_their_variant_and_have_severities() {
    use crate::types::{MissionTimeUs, StateKey};
    let at = MissionTimeUs(1);
    let samples = [
        TelemetryEvent::TaskTransition {
            task: 1,
            from: 0,
            to: 1,
            at,
        },
        TelemetryEvent::PlanModification {
            kind: 0,
            task: 1,
            template: 2,
            at,
        },
        TelemetryEvent::HealthMonitor {
            partition: 1,
            kind: 2,
            address: 0,
            action: 1,
        },
        TelemetryEvent::Metric {
            id: app::GROUND_HOLDS,
            value: 1,
        },
        TelemetryEvent::StateStale {
            key: StateKey(3),
            measured_at: at,
            at,
        },
    ];
    for (i, ev) in samples.iter().enumerate() {
        let def = event(ev);
        assert_eq!(usize::from(def.id), i);
        // The id is the variant's postcard index: its first byte on the wire.
        let mut buf = [0u8; 32];
        let bytes = postcard::to_slice(ev, &mut buf).unwrap();
        assert_eq!(bytes[0], def.id, "{ev:?}");
    }
    assert_eq!(event(&samples[2]).severity, Severity::Error);
    assert!(event(&samples[4]).severity > Severity::Info);
    // A metric event travels where its metric does.
    assert_eq!(event_channel(&samples[3]), VirtualChannel::Mission);
    assert_eq!(
        event_channel(&TelemetryEvent::Metric {
            id: app::STEP_TICKS,
            value: 1
        }),
        VirtualChannel::Instrument
    );
}
