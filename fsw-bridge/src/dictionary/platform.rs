//! The kernel's metrics and the partitions' instrumentation (ids below 0x1000): only the
//! emulated target sends them, all on the Instrument channel. Per-partition ids add the
//! partition index to the first id.

use super::{armed_reset_point, boot_image, PARTITION_IDS};

metric_table! {
    PLATFORM_METRICS;
    /// Ticks partition p used in the last complete major frame.
    FRAME_TICKS = 0x0100 * PARTITION_IDS,
        "frame_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// Most ticks partition p used in any one major frame since boot.
    WORST_FRAME_TICKS = 0x0110 * PARTITION_IDS,
        "worst_frame_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// Windows in which partition p was still running at the end (preempted).
    OVERRUNS = 0x0120 * PARTITION_IDS,
        "overruns", Count, Value, Kernel, Instrument;
    /// Largest start jitter of p's windows (actual switch-in minus scheduled start), ticks.
    MAX_JITTER = 0x0130 * PARTITION_IDS,
        "max_jitter_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// Generation of p (number of restarts).
    GENERATION = 0x0140 * PARTITION_IDS,
        "generation", Count, Value, Kernel, Instrument;
    /// The number of the major frame the per-partition figures sent with it belong to.
    FRAME_NUMBER = 0x0200,
        "frame_number", Count, Value, Kernel, Instrument;
    /// Largest window-start jitter over all partitions since boot, ticks.
    MAX_JITTER_ALL = 0x0201,
        "max_jitter_all_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// Kernel time per partition switch (timer interrupt entry to return), averaged over
    /// all switches since boot, in thousandths of a tick.
    SWITCH_MILLITICKS = 0x0202,
        "switch_mean_milliticks", MilliTicks, MeasuredCost, Kernel, Instrument;
    /// Number of partition switches since boot.
    SWITCHES = 0x0203,
        "switches", Count, Value, Kernel, Instrument;
    /// Largest kernel time of one switch, ticks.
    SWITCH_MAX_TICKS = 0x0204,
        "switch_max_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// Kernel events dropped because the queue was full.
    EVENTS_DROPPED = 0x0210,
        "kernel_events_dropped", Count, Value, Kernel, Instrument;
    /// Log bytes dropped because the kernel log buffer was full.
    LOG_BYTES_DROPPED = 0x0211,
        "log_bytes_dropped", Bytes, Value, Kernel, Instrument;
    /// Bytes the kernel received on the link since boot (in every kernel report).
    LINK_RX_BYTES = 0x0212,
        "link_rx_bytes", Bytes, Value, Kernel, Instrument;
    /// Bytes the link's receiver lost since boot (UART overruns; QEMU's ESCC holds bytes
    /// back instead, so on the emulated target this stays 0).
    LINK_RX_LOST = 0x0213,
        "link_rx_lost_bytes", Bytes, Value, Kernel, Instrument;
    /// Times the kernel's receive ring was full and the kernel left bytes in the UART until
    /// the I/O partition read (flow control, nothing lost).
    LINK_RX_RING_FULL = 0x0214,
        "link_rx_ring_full", Count, Value, Kernel, Instrument;
    /// Times the module stopped its schedule to wait for input (SYS_WAIT_FOR_INPUT parked).
    PARKS = 0x0215,
        "parks", Count, Value, Kernel, Instrument;
    /// The link's transport: 0 the serial line, 1 shared memory (the emulated target with
    /// the link device).
    LINK_TRANSPORT = 0x0216,
        "link_transport", Code, Value, Kernel, Instrument,
        values &[(0, "serial line"), (1, "shared memory")];
    /// Shared-memory rings whose counts made no sense, dropped (the host wrote garbage).
    LINK_RING_ERRORS = 0x0217,
        "link_ring_errors", Count, Value, Kernel, Instrument;
    /// Messages for the host's Instrument channel (costs, kernel events, logs) the I/O
    /// partition dropped since boot because that channel's send queue and its holding
    /// queue were full (a link too noisy for the instrumentation), or because the link was
    /// lost. Sent by the I/O partition, on the Instrument channel, after a drop, once it
    /// has room.
    LINK_INSTRUMENT_DROPPED = 0x0218,
        "instrument_messages_dropped", Count, Value, Io, Instrument;
    /// Queuing-port messages the kernel dropped on receive since boot because their
    /// sender had restarted since it sent them (an older generation:
    /// `kernel_logic::port_queue`). In every kernel report, before EVENTS_DROPPED.
    PORT_STALE_DROPPED = 0x0219,
        "port_stale_messages_dropped", Count, Value, Kernel, Instrument;
    /// An armed reset (SYS_RESET_MODULE with a point) is about to happen: where it landed,
    /// one of [`armed_reset_point`]. Sent straight to the host with the next ones, before
    /// the Hello.
    ARMED_RESET_POINT = 0x0220,
        "armed_reset_point", Code, Value, Kernel, Instrument,
        values &[
            (armed_reset_point::IN_CODE, "in code"),
            (armed_reset_point::IN_WARM_WRITE, "in warm write"),
            (armed_reset_point::AFTER_WORK, "after work"),
            (armed_reset_point::PARTITION_STOPPED, "partition stopped"),
        ];
    /// Ticks the partition ran from its receipt of the anchor message to the reset
    /// (measured with the decrementer, so the same on every run).
    ARMED_RESET_TICKS = 0x0221,
        "armed_reset_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// The partition's last warm-area write since the anchor: offset in the checkpoint part
    /// << 32 | length in bytes. Sent only if there was one.
    ARMED_RESET_WARM_WRITE = 0x0222,
        "armed_reset_warm_write", OffsetLength, Value, Kernel, Instrument;
    /// Bytes of that write copied before the reset (its whole length unless it was torn).
    ARMED_RESET_WARM_COPIED = 0x0223,
        "armed_reset_warm_copied", Bytes, Value, Kernel, Instrument;
    /// When that write ran: ticks since the anchor at its start << 32 | at its end (or
    /// tear).
    ARMED_RESET_WARM_WRITE_TICKS = 0x0224,
        "armed_reset_warm_write_ticks", TickPair, MeasuredCost, Kernel, Instrument;
    /// CRC-32 of the planner's search table (sent by the planner on request).
    PLANNER_CHECKSUM = 0x0300,
        "planner_checksum", Checksum, Value, Planner, Instrument;
    /// State updates the executive received since its (re)start.
    EXECUTIVE_STATE_UPDATES = 0x0301,
        "executive_state_updates", Count, Value, Executive, Instrument;
    /// Ticks for SYSCALL_BENCH_CALLS null system calls (sent by the executive on request).
    SYSCALL_BENCH_TICKS = 0x0302,
        "syscall_bench_ticks", Ticks, MeasuredCost, Executive, Instrument;
    /// Planner iterations since its (re)start.
    PLANNER_ITERATIONS = 0x0303,
        "planner_iterations", Count, Value, Planner, Instrument;
    /// Generation of the planner seen by the planner itself when it reports its checksum.
    PLANNER_GENERATION = 0x0304,
        "planner_generation", Count, Value, Planner, Instrument;
    /// Test image: the rogue partition's probe, sent through `rogue_to_io` (value: the
    /// rogue's generation when it sent it); the stale-message test watches for it.
    ROGUE_PROBE = 0x03f0,
        "rogue_probe", Count, Value, Rogue, Instrument;
    /// Boot to ready, sent by the executive once per boot when the flight application has
    /// restored its checkpoint (or found none) and can take its first grant: the kernel's
    /// boot (reset vector to the start of the schedule, SYS_UPTIME's r5) plus the CPU the
    /// executive partition used from its start to that point. Ticks of CPU on the way to
    /// ready, the same every boot from the same memory contents; the schedule's latency
    /// (the lead time, the other partitions' windows before and between the executive's)
    /// is not in it.
    BOOT_TO_READY_TICKS = 0x0310,
        "boot_to_ready_ticks", Ticks, MeasuredCost, Executive, Instrument;
    /// The kernel's part of BOOT_TO_READY_TICKS (reset vector to the start of the
    /// schedule), sent just before it.
    KERNEL_BOOT_TICKS = 0x0311,
        "kernel_boot_ticks", Ticks, MeasuredCost, Executive, Instrument;
    /// The boot breakdown, sent by the kernel at the start of the schedule (the parts of
    /// KERNEL_BOOT_TICKS) and by the executive with BOOT_TO_READY_TICKS (the parts of its
    /// own), all in ticks of CPU. The reset stub's image step: reset vector to the RAM
    /// image checked (or copied from ROM) and `.kshared` and the kernel data reloaded.
    BOOT_STUB_IMAGE_TICKS = 0x0312,
        "boot_image_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// The reset stub's clearing of `.bss` and the hashed page table.
    BOOT_STUB_CLEAR_TICKS = 0x0313,
        "boot_clear_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// From the stub's end to the start of the schedule: board bring-up (PCI, mac-io, the
    /// interrupt controller, the ESCC, the ivshmem devices), the boot record, the first log
    /// lines, MMU and BATs, the kernel's tables.
    BOOT_KERNEL_INIT_TICKS = 0x0314,
        "boot_kernel_init_ticks", Ticks, MeasuredCost, Kernel, Instrument;
    /// How the reset stub made the RAM image good: one of [`boot_image`]. A fact, not a
    /// cost (sent with the costs, on the Instrument channel).
    BOOT_IMAGE = 0x0315,
        "boot_image", Code, Value, Kernel, Instrument,
        values &[
            (boot_image::VERIFIED, "verified"),
            (boot_image::COPIED, "copied"),
            (boot_image::REPAIRED, "repaired"),
        ];
    /// The executive partition's start: its statics and stack zeroed by the kernel's
    /// partition start, up to its entry function.
    BOOT_EXECUTIVE_START_TICKS = 0x0316,
        "boot_executive_start_ticks", Ticks, MeasuredCost, Executive, Instrument;
    /// The executive's entry up to the flight application's boot: the application put in
    /// place and the checkpoint records of both memories read through the kernel.
    BOOT_EXECUTIVE_INIT_TICKS = 0x0317,
        "boot_executive_init_ticks", Ticks, MeasuredCost, Executive, Instrument;
    /// The planner partition's start at a boot: its statics and stack zeroed by the
    /// kernel's partition start, up to its entry function (its restore is
    /// PLANNER_RESTORE_TICKS). Sent once per boot.
    BOOT_PLANNER_START_TICKS = 0x0318,
        "boot_planner_start_ticks", Ticks, MeasuredCost, Planner, Instrument;
}
