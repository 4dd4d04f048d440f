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
        warm_area: false,
        nv_memory: false,
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
                base: 0x0008_0000,
                size: 0x0008_0000,
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
        nv_memory: true,
        ..Capabilities::NONE
    };
    const WARM: Capabilities = Capabilities {
        warm_area: true,
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
        "kernel configuration: more than one partition owns the non-volatile memory"
    );
    assert_eq!(
        message(&config(&TWO_WARM, &WINDOWS_OK, &[])),
        "kernel configuration: more than one partition owns the warm area"
    );
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
    // 4 ports of 160/64 bytes x 8, 2 sampling ports of 32 bytes, 16-byte slot headers.
    let product = 2 * 8 * (160 + 16) + 2 * 8 * (64 + 16) + 2 * (32 + 16);
    assert_eq!(port_storage_bytes(&PRODUCT), product);
    // Plus io_to_rogue (160 bytes x 2) and rogue_to_io (64 bytes x 2).
    assert_eq!(
        port_storage_bytes(&TEST),
        product + 2 * (160 + 16) + 2 * (64 + 16)
    );
}
