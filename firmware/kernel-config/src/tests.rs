//! The checker on the shipped configuration and on broken ones: each broken configuration is
//! refused with a message that names the offending entry.
use super::system::*;
use super::*;

const fn part(name: &'static str, regions: &'static [Region]) -> Partition {
    Partition {
        name,
        entry: "entry",
        regions,
        stack_size: 0x1000,
        capabilities: Capabilities::NONE,
        health: HealthTable::RESTART_ON_FAULT,
    }
}

const IO_PART: Partition = Partition {
    capabilities: Capabilities {
        link_owner: true,
        warm_area: None,
        nv_memory: None,
    },
    ..part("io", &[IO_REGION, MAC_IO_REGION])
};

const WINDOWS_OK: [Window; 3] = [
    Window {
        partition: 0,
        offset: 0,
        duration: 100,
    },
    Window {
        partition: 1,
        offset: 100,
        duration: 100,
    },
    Window {
        partition: 2,
        offset: 200,
        duration: 100,
    },
];

fn config(
    partitions: &'static [Partition],
    windows: &'static [Window],
    ports: &'static [Port],
) -> SystemConfig {
    SystemConfig {
        partitions,
        schedule: Schedule {
            major_frame: 1000,
            windows,
        },
        ports,
    }
}

const THREE: [Partition; 3] = [
    IO_PART,
    part("executive", &[EXECUTIVE_REGION]),
    part("planner", &[PLANNER_REGION]),
];

fn message(config: &SystemConfig) -> String {
    let error = check(config).expect_err("configuration must be refused");
    error.describe(config).as_str().to_owned()
}

extern crate std;
use std::borrow::ToOwned;
use std::string::String;

#[test]
fn the_shipped_configurations_are_valid() {
    assert_eq!(check(&PRODUCT), Ok(()));
    assert_eq!(check(&TEST), Ok(()));
    // And evaluate at compile time.
    const _: () = assert_valid(&PRODUCT);
    const _: () = assert_valid(&TEST);
}

#[test]
fn the_test_image_keeps_the_products_indices_and_timing() {
    for (i, p) in PRODUCT.partitions.iter().enumerate() {
        assert_eq!(TEST.partitions[i].name, p.name);
    }
    for (i, w) in PRODUCT.schedule.windows.iter().enumerate() {
        let t = &TEST.schedule.windows[i];
        assert_eq!(
            (t.partition, t.offset, t.duration),
            (w.partition, w.offset, w.duration)
        );
    }
    for (i, p) in PRODUCT.ports.iter().enumerate() {
        assert_eq!(TEST.ports[i].name, p.name);
    }
    assert_eq!(port_index(&TEST, "io_to_rogue"), Some(PORT_IO_TO_ROGUE));
    assert_eq!(port_index(&TEST, "rogue_to_io"), Some(PORT_ROGUE_TO_IO));
    assert_eq!(partition_index(&TEST, "rogue"), Some(ROGUE));
}

#[test]
fn a_minimal_good_configuration_is_valid() {
    assert_eq!(check(&config(&THREE, &WINDOWS_OK, &[])), Ok(()));
}

#[test]
fn overlapping_windows_are_refused_naming_both() {
    static W: [Window; 3] = [
        WINDOWS_OK[0],
        WINDOWS_OK[1],
        Window {
            partition: 2,
            offset: 150,
            duration: 100,
        },
    ];
    let c = config(&THREE, &W, &[]);
    assert_eq!(
        check(&c),
        Err(ConfigError::WindowsOverlap {
            window: 2,
            previous: 1
        })
    );
    assert_eq!(
        message(&c),
        "kernel configuration: window 2 (planner) overlaps window 1 (executive)"
    );
}

#[test]
fn a_window_beyond_the_major_frame_is_refused() {
    static W: [Window; 3] = [
        WINDOWS_OK[0],
        WINDOWS_OK[1],
        Window {
            partition: 2,
            offset: 900,
            duration: 101,
        },
    ];
    assert_eq!(
        message(&config(&THREE, &W, &[])),
        "kernel configuration: window 2 (planner) ends at tick 1001, after the major frame (1000 ticks)"
    );
}

#[test]
fn windows_out_of_order_are_refused() {
    static W: [Window; 3] = [WINDOWS_OK[0], WINDOWS_OK[2], WINDOWS_OK[1]];
    assert_eq!(
        message(&config(&THREE, &W, &[])),
        "kernel configuration: window 2 (executive) starts before window 1 (planner) (list windows by offset)"
    );
}

#[test]
fn a_partition_without_a_window_is_refused() {
    static W: [Window; 2] = [WINDOWS_OK[0], WINDOWS_OK[1]];
    assert_eq!(
        message(&config(&THREE, &W, &[])),
        "kernel configuration: partition planner has no window in the major frame"
    );
}

#[test]
fn overlapping_regions_are_refused_naming_both() {
    static P: [Partition; 3] = [
        IO_PART,
        part("executive", &[EXECUTIVE_REGION]),
        part(
            "planner",
            &[Region {
                base: 0x0040_0000,
                size: 0x0040_0000,
                access: Access::ReadWrite,
            }],
        ),
    ];
    assert_eq!(
        message(&config(&P, &WINDOWS_OK, &[])),
        "kernel configuration: partition planner region 0 (0x00400000, 0x00400000 bytes) overlaps partition executive region 0 (0x00400000, 0x00200000 bytes)"
    );
}

#[test]
fn a_misaligned_region_is_refused() {
    static P: [Partition; 3] = [
        IO_PART,
        part(
            "executive",
            &[Region {
                base: 0x0030_0000,
                size: 0x0020_0000,
                access: Access::ReadWrite,
            }],
        ),
        part("planner", &[PLANNER_REGION]),
    ];
    assert_eq!(
        message(&config(&P, &WINDOWS_OK, &[])),
        "kernel configuration: partition executive region 0 (0x00300000, 0x00200000 bytes) is not aligned to its size"
    );
}

#[test]
fn a_region_that_is_no_bat_block_is_refused() {
    static P: [Partition; 3] = [
        IO_PART,
        part(
            "executive",
            &[Region {
                base: 0x0040_0000,
                size: 0x0003_0000,
                access: Access::ReadWrite,
            }],
        ),
        part("planner", &[PLANNER_REGION]),
    ];
    assert!(message(&config(&P, &WINDOWS_OK, &[])).contains("not a power of two"));
}

#[test]
fn kernel_memory_cannot_be_given_to_a_partition() {
    static P: [Partition; 3] = [
        IO_PART,
        part(
            "executive",
            &[Region {
                base: crate::KERNEL_DATA_BASE,
                size: crate::KERNEL_DATA_SIZE,
                access: Access::ReadWrite,
            }],
        ),
        part("planner", &[PLANNER_REGION]),
    ];
    assert_eq!(
        check(&config(&P, &WINDOWS_OK, &[])),
        Err(ConfigError::RegionOutsidePartitionRam {
            partition: 1,
            region: 0
        })
    );
}

#[test]
fn devices_are_mapped_only_into_the_io_partition() {
    static P: [Partition; 3] = [
        IO_PART,
        part("executive", &[EXECUTIVE_REGION, MAC_IO_REGION]),
        part("planner", &[PLANNER_REGION]),
    ];
    // It also overlaps the I/O partition's device region; the device rule is checked first.
    assert_eq!(
        message(&config(&P, &WINDOWS_OK, &[])),
        "kernel configuration: partition executive region 1 (0xf3000000, 0x00080000 bytes) maps devices, but only the I/O (link owner) partition may"
    );
}

#[test]
fn a_port_without_a_destination_is_refused() {
    static PORTS: [Port; 1] = [Port {
        name: "dangling",
        kind: PortKind::Queuing,
        message_size: 16,
        depth: 4,
        source: 1,
        destinations: &[],
    }];
    assert_eq!(
        message(&config(&THREE, &WINDOWS_OK, &PORTS)),
        "kernel configuration: port dangling has no destination"
    );
}

#[test]
fn a_port_without_a_source_is_refused() {
    static PORTS: [Port; 1] = [Port {
        name: "orphan",
        kind: PortKind::Sampling,
        message_size: 16,
        depth: 1,
        source: 9,
        destinations: &[1],
    }];
    assert_eq!(
        message(&config(&THREE, &WINDOWS_OK, &PORTS)),
        "kernel configuration: port orphan has no source (its source partition does not exist)"
    );
}

#[test]
fn a_queuing_port_has_one_destination_and_a_sane_depth() {
    static PORTS: [Port; 2] = [
        Port {
            name: "fanout",
            kind: PortKind::Queuing,
            message_size: 16,
            depth: 4,
            source: 0,
            destinations: &[1, 2],
        },
        Port {
            name: "deep",
            kind: PortKind::Queuing,
            message_size: 16,
            depth: 100,
            source: 0,
            destinations: &[1],
        },
    ];
    assert_eq!(
        check(&config(&THREE, &WINDOWS_OK, &PORTS[..1])),
        Err(ConfigError::QueuingPortDestinations { port: 0 })
    );
    assert_eq!(
        check(&config(&THREE, &WINDOWS_OK, &PORTS[1..])),
        Err(ConfigError::PortBadDepth { port: 0 })
    );
}

#[test]
fn continuing_after_a_panic_is_refused() {
    static P: [Partition; 3] = [
        IO_PART,
        Partition {
            health: HealthTable::RESTART_ON_FAULT.with(ErrorKind::Panic, HmAction::Log),
            ..part("executive", &[EXECUTIVE_REGION])
        },
        part("planner", &[PLANNER_REGION]),
    ];
    assert_eq!(
        message(&config(&P, &WINDOWS_OK, &[])),
        "kernel configuration: partition executive: health-monitor action `log` (continue) is not possible for panic"
    );
}

#[test]
fn exactly_one_partition_owns_the_link() {
    static P: [Partition; 3] = [
        part("io", &[IO_REGION]),
        part("executive", &[EXECUTIVE_REGION]),
        part("planner", &[PLANNER_REGION]),
    ];
    assert_eq!(
        check(&config(&P, &WINDOWS_OK, &[])),
        Err(ConfigError::LinkOwnerCount { count: 0 })
    );
}

#[test]
fn at_most_one_partition_owns_each_persistent_memory() {
    const NV: Capabilities = Capabilities {
        nv_memory: Some(Slice {
            offset: 0,
            len: 0x1000,
        }),
        ..Capabilities::NONE
    };
    const WARM: Capabilities = Capabilities {
        warm_area: Some(Slice {
            offset: 0x800,
            len: 0x1000,
        }),
        ..Capabilities::NONE
    };
    static TWO_NV: [Partition; 3] = [
        IO_PART,
        Partition {
            capabilities: NV,
            ..part("executive", &[EXECUTIVE_REGION])
        },
        Partition {
            capabilities: NV,
            ..part("planner", &[PLANNER_REGION])
        },
    ];
    static TWO_WARM: [Partition; 3] = [
        IO_PART,
        Partition {
            capabilities: WARM,
            ..part("executive", &[EXECUTIVE_REGION])
        },
        Partition {
            capabilities: WARM,
            ..part("planner", &[PLANNER_REGION])
        },
    ];
    assert_eq!(
        message(&config(&TWO_NV, &WINDOWS_OK, &[])),
        "kernel configuration: two partitions' slices of the non-volatile memory overlap"
    );
    assert_eq!(
        message(&config(&TWO_WARM, &WINDOWS_OK, &[])),
        "kernel configuration: two partitions' slices of the warm area overlap"
    );
    // Side by side is fine; past the end, or empty, is not.
    const WARM_AFTER: Capabilities = Capabilities {
        warm_area: Some(Slice {
            offset: 0x1800,
            len: 0x1000,
        }),
        ..Capabilities::NONE
    };
    static SIDE_BY_SIDE: [Partition; 3] = [
        IO_PART,
        Partition {
            capabilities: WARM,
            ..part("executive", &[EXECUTIVE_REGION])
        },
        Partition {
            capabilities: WARM_AFTER,
            ..part("planner", &[PLANNER_REGION])
        },
    ];
    assert_eq!(check(&config(&SIDE_BY_SIDE, &WINDOWS_OK, &[])), Ok(()));
    const PAST_THE_END: Capabilities = Capabilities {
        warm_area: Some(Slice {
            offset: WARM_CHECKPOINT_PART - 8,
            len: 16,
        }),
        ..Capabilities::NONE
    };
    static TOO_FAR: [Partition; 3] = [
        IO_PART,
        Partition {
            capabilities: PAST_THE_END,
            ..part("executive", &[EXECUTIVE_REGION])
        },
        part("planner", &[PLANNER_REGION]),
    ];
    assert_eq!(
        check(&config(&TOO_FAR, &WINDOWS_OK, &[])),
        Err(ConfigError::SliceOutOfRange { partition: 1 })
    );
}

#[test]
fn the_product_gives_the_executive_and_the_planner_their_own_persistent_memory() {
    let executive = PRODUCT.partitions[EXECUTIVE].capabilities;
    let planner = PRODUCT.partitions[PLANNER].capabilities;
    let (ew, pw) = (executive.warm_area.unwrap(), planner.warm_area.unwrap());
    let (en, pn) = (executive.nv_memory.unwrap(), planner.nv_memory.unwrap());
    assert!(!ew.overlaps(&pw) && !en.overlaps(&pn));
    assert_eq!(
        pw.end(),
        WARM_CHECKPOINT_PART,
        "the warm area is shared out whole"
    );
    assert!(PRODUCT.partitions[IO].capabilities.warm_area.is_none());
}

#[test]
fn a_stack_larger_than_its_region_is_refused() {
    static P: [Partition; 3] = [
        IO_PART,
        Partition {
            stack_size: 0x0020_0000,
            ..part("executive", &[EXECUTIVE_REGION])
        },
        part("planner", &[PLANNER_REGION]),
    ];
    assert_eq!(
        check(&config(&P, &WINDOWS_OK, &[])),
        Err(ConfigError::StackDoesNotFit { partition: 1 })
    );
}

#[test]
fn region_containment_rejects_wrap_around_and_straddling() {
    let r = EXECUTIVE_REGION;
    assert!(r.contains(0x0040_0000, 0x0020_0000));
    assert!(!r.contains(0x005f_fffc, 8));
    assert!(!r.contains(0x003f_fffc, 8));
    assert!(!r.contains(0xffff_fff0, 0x20));
}

#[test]
fn port_storage_is_sized_from_the_configuration() {
    // 4 ports of 160/64 bytes x 8, the planner's channel (128 and 96 bytes x 16), 16-byte
    // slot headers.
    let product = 2 * 8 * (160 + 16) + 2 * 8 * (64 + 16) + 16 * (128 + 16) + 16 * (96 + 16);
    assert_eq!(port_storage_bytes(&PRODUCT), product);
    // Plus io_to_rogue (160 bytes x 2) and rogue_to_io (64 bytes x 2).
    assert_eq!(
        port_storage_bytes(&TEST),
        product + 2 * (160 + 16) + 2 * (64 + 16)
    );
}

/// Every metric id the kernel and the partitions send (`abi::metric`) is in the telemetry
/// dictionary, under its own constant's name, on the Instrument channel; the per-partition
/// families leave room for every partition the kernel supports.
#[test]
fn every_platform_metric_is_in_the_dictionary() {
    use abi::metric::*;
    use fsw_bridge::dictionary;
    let ids = [
        (FRAME_TICKS, "FRAME_TICKS"),
        (WORST_FRAME_TICKS, "WORST_FRAME_TICKS"),
        (OVERRUNS, "OVERRUNS"),
        (MAX_JITTER, "MAX_JITTER"),
        (GENERATION, "GENERATION"),
        (FRAME_NUMBER, "FRAME_NUMBER"),
        (MAX_JITTER_ALL, "MAX_JITTER_ALL"),
        (SWITCH_MILLITICKS, "SWITCH_MILLITICKS"),
        (SWITCHES, "SWITCHES"),
        (SWITCH_MAX_TICKS, "SWITCH_MAX_TICKS"),
        (EVENTS_DROPPED, "EVENTS_DROPPED"),
        (LOG_BYTES_DROPPED, "LOG_BYTES_DROPPED"),
        (LINK_RX_BYTES, "LINK_RX_BYTES"),
        (LINK_RX_LOST, "LINK_RX_LOST"),
        (LINK_RX_RING_FULL, "LINK_RX_RING_FULL"),
        (PARKS, "PARKS"),
        (LINK_TRANSPORT, "LINK_TRANSPORT"),
        (LINK_RING_ERRORS, "LINK_RING_ERRORS"),
        (LINK_INSTRUMENT_DROPPED, "LINK_INSTRUMENT_DROPPED"),
        (PORT_STALE_DROPPED, "PORT_STALE_DROPPED"),
        (ARMED_RESET_POINT, "ARMED_RESET_POINT"),
        (ARMED_RESET_TICKS, "ARMED_RESET_TICKS"),
        (ARMED_RESET_WARM_WRITE, "ARMED_RESET_WARM_WRITE"),
        (ARMED_RESET_WARM_COPIED, "ARMED_RESET_WARM_COPIED"),
        (ARMED_RESET_WARM_WRITE_TICKS, "ARMED_RESET_WARM_WRITE_TICKS"),
        (PLANNER_CHECKSUM, "PLANNER_CHECKSUM"),
        (EXECUTIVE_STATE_UPDATES, "EXECUTIVE_STATE_UPDATES"),
        (SYSCALL_BENCH_TICKS, "SYSCALL_BENCH_TICKS"),
        (PLANNER_ITERATIONS, "PLANNER_ITERATIONS"),
        (PLANNER_GENERATION, "PLANNER_GENERATION"),
        (ROGUE_PROBE, "ROGUE_PROBE"),
        (BOOT_TO_READY_TICKS, "BOOT_TO_READY_TICKS"),
        (KERNEL_BOOT_TICKS, "KERNEL_BOOT_TICKS"),
        (BOOT_STUB_IMAGE_TICKS, "BOOT_STUB_IMAGE_TICKS"),
        (BOOT_STUB_CLEAR_TICKS, "BOOT_STUB_CLEAR_TICKS"),
        (BOOT_KERNEL_INIT_TICKS, "BOOT_KERNEL_INIT_TICKS"),
        (BOOT_IMAGE, "BOOT_IMAGE"),
        (BOOT_EXECUTIVE_START_TICKS, "BOOT_EXECUTIVE_START_TICKS"),
        (BOOT_EXECUTIVE_INIT_TICKS, "BOOT_EXECUTIVE_INIT_TICKS"),
        (BOOT_PLANNER_START_TICKS, "BOOT_PLANNER_START_TICKS"),
    ];
    // The wire ids are fixed (transcripts and budgets depend on them): spot checks.
    assert_eq!(FRAME_TICKS, 0x0100);
    assert_eq!(ARMED_RESET_TICKS, 0x0221);
    assert_eq!(BOOT_EXECUTIVE_INIT_TICKS, 0x0317);
    assert_eq!(
        ids.len(),
        PLATFORM_METRICS.len(),
        "a constant is missing here"
    );
    for (id, constant) in ids {
        let m = dictionary::metric(id).unwrap_or_else(|| panic!("{constant} not in dictionary"));
        assert_eq!((m.id, m.constant), (id, constant));
        assert_eq!(m.channel, fsw_bridge::link::VirtualChannel::Instrument);
    }
    for family in [
        FRAME_TICKS,
        WORST_FRAME_TICKS,
        OVERRUNS,
        MAX_JITTER,
        GENERATION,
    ] {
        let last = family + MAX_PARTITIONS as u16 - 1;
        assert_eq!(dictionary::metric(last).map(|m| m.id), Some(family));
    }
    let point = dictionary::metric(ARMED_RESET_POINT).unwrap();
    for landed in [
        abi::reset_at::LANDED_IN_CODE,
        abi::reset_at::LANDED_IN_WARM_WRITE,
        abi::reset_at::LANDED_AFTER_WORK,
        abi::reset_at::LANDED_PARTITION_STOPPED,
    ] {
        assert!(point.value_name(landed).is_some(), "{landed}");
    }
}

/// Every system-call number decodes to the call that has it and back; unassigned numbers are
/// refused as UnknownCall (a fault), and the numbers are the ABI's.
#[test]
fn sysnums_round_trip_and_unknown_numbers_are_refused() {
    use abi::{SysError, Sysnum};
    for (n, call) in Sysnum::ALL.iter().enumerate() {
        assert_eq!(call.number(), n as u32);
        assert_eq!(Sysnum::try_from(n as u32), Ok(*call));
    }
    for n in [abi::SYSCALL_COUNT, abi::SYSCALL_COUNT + 1, 0x100, u32::MAX] {
        assert_eq!(Sysnum::try_from(n), Err(SysError::UnknownCall), "{n}");
    }
    assert!(SysError::UnknownCall.is_fault());
    // The numeric ABI is unchanged.
    assert_eq!(Sysnum::WaitNextWindow.number(), abi::SYS_WAIT_NEXT_WINDOW);
    assert_eq!(Sysnum::PortSend.number(), 1);
    assert_eq!(Sysnum::ResetModule.number(), 14);
    assert_eq!(Sysnum::LinkWrite.number(), 21);
}

/// Every error code decodes to its error and back, r3 values outside the codes are values, and
/// only Empty, Full and NoDevice are recoverable (the rest are the health monitor's business).
#[test]
fn sys_errors_round_trip_and_separate_recoverable_from_faults() {
    use abi::{decode_result, encode_result, ErrorClass, SysError};
    for (i, e) in SysError::ALL.iter().enumerate() {
        assert_eq!(e.code(), -(i as i32) - 1);
        assert_eq!(SysError::from_code(e.code()), Some(*e));
        assert_eq!(decode_result(encode_result(Err(*e))), Err(*e));
        assert_eq!(i32::from(*e), e.code());
    }
    assert_eq!(SysError::BadPointer.code(), abi::E_BAD_POINTER);
    assert_eq!(SysError::NoDevice.code(), abi::E_NO_DEVICE);
    for code in [0, 1, -10, i32::MIN, i32::MAX] {
        assert_eq!(SysError::from_code(code), None, "{code}");
    }
    for value in [0u32, 1, 160, 0x7fff_ffff, (-10i32) as u32] {
        assert_eq!(decode_result(encode_result(Ok(value))), Ok(value));
    }
    let recoverable: std::vec::Vec<SysError> = SysError::ALL
        .into_iter()
        .filter(|e| e.class() == ErrorClass::Recoverable)
        .collect();
    assert_eq!(
        recoverable,
        [SysError::Empty, SysError::Full, SysError::NoDevice]
    );
    for e in SysError::ALL {
        assert_eq!(e.is_fault(), !recoverable.contains(&e));
    }
}

/// Every port name of both configurations resolves to its own port, names are unique, and the
/// named ids the partitions use are the lookups' results (the product's ids unchanged in the
/// test image).
#[test]
fn every_port_name_resolves_and_is_unique() {
    for config in [&PRODUCT, &TEST] {
        for (i, p) in config.ports.iter().enumerate() {
            assert_eq!(port_index(config, p.name), Some(i), "{}", p.name);
            assert_eq!(port_id(config, p.name), i);
        }
        let mut names: std::vec::Vec<&str> = config.ports.iter().map(|p| p.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), config.ports.len(), "a port name is used twice");
        assert_eq!(port_index(config, "no_such_port"), None);
        assert!(max_port_message(config) >= ROUTED_MESSAGE_SIZE as usize);
    }
    let named = [
        ("io_to_executive", PORT_IO_TO_EXECUTIVE),
        ("io_to_planner", PORT_IO_TO_PLANNER),
        ("executive_to_io", PORT_EXECUTIVE_TO_IO),
        ("planner_to_io", PORT_PLANNER_TO_IO),
        ("executive_to_planner", PORT_EXECUTIVE_TO_PLANNER),
        ("planner_to_executive", PORT_PLANNER_TO_EXECUTIVE),
    ];
    for (name, id) in named {
        assert_eq!(PRODUCT.ports[id].name, name);
        assert_eq!(TEST.ports[id].name, name);
    }
    assert_eq!(TEST.ports[PORT_IO_TO_ROGUE].name, "io_to_rogue");
}

#[test]
fn two_ports_with_one_name_are_refused() {
    static PORTS: [Port; 2] = [
        Port {
            name: "twice",
            kind: PortKind::Sampling,
            message_size: 16,
            depth: 1,
            source: 0,
            destinations: &[1],
        },
        Port {
            name: "twice",
            kind: PortKind::Sampling,
            message_size: 16,
            depth: 1,
            source: 1,
            destinations: &[0],
        },
    ];
    assert_eq!(
        message(&config(&THREE, &WINDOWS_OK, &PORTS)),
        "kernel configuration: port twice: another port has the same name"
    );
}
