#!/usr/bin/env python3
"""Where a warm reset's recovery goes, in guest instructions, by function.

Reads QEMU's `-d exec,nochain,in_asm` log from a FIFO while a mission runs (each executed
block's instruction count, in execution order: exact counts, icount makes them the run's own),
keeps the blocks from the N-th execution of the reset vector (0xfff00100; N = 2 for the first
warm reset) on, up to LIMIT guest instructions, and attributes them to the outermost function
of the block's inlined frames (`llvm-symbolizer` on the firmware ELF). Used by
`recovery_profile.sh`; see the README's "Where the recovery goes".

usage: recovery_profile.py FIFO ELF [RESET_NUMBER [LIMIT [RUNS_FILE]]]
"""
import collections
import os
import re
import sys

from qemu_blocks import BlockLog, symbolize

fifo, elf = sys.argv[1], sys.argv[2]
reset_number = int(sys.argv[3]) if len(sys.argv) > 3 else 2
limit = int(sys.argv[4]) if len(sys.argv) > 4 else 2_000_000
RESET_VECTOR = 0xFFF00100

blocks = BlockLog(fifo)
order = []  # block start pcs after the reset, in execution order
resets = 0
taken = 0
for pc in blocks:
    if pc == RESET_VECTOR:
        resets += 1
    if resets >= reset_number and taken < limit:
        order.append(pc)
        taken += blocks.instructions(pc)

pcs = sorted(set(order))
if os.environ.get("RECOVERY_PCS"):
    # Every executed block (start and instruction count): which code the recovery runs.
    with open(os.environ["RECOVERY_PCS"], "w") as out:
        for pc in pcs:
            out.write(f"{pc:08x} {blocks.instructions(pc)}\n")
frames = symbolize(elf, pcs)
name = {}
for pc, lines in zip(pcs, frames):
    # The outermost frame is the function the block's code lies in.
    name[pc] = re.sub(r"::h[0-9a-f]{16}", "", lines[-2]) if len(lines) >= 2 else "?"

# The partition (or the kernel) a block runs for: from its function's name where that names
# one, else the last one named (library code such as memcpy runs for its caller).
FAMILIES = [
    ("reset stub", ("__reset_body",)),
    ("partition start", ("__partition_start",)),
    ("kernel", ("rad750_firmware::", "kernel_trap", "__exception_common", "__context_resume", "rust_start")),
    ("io", ("task_io", "partition_io_main", "fsw_bridge::link", "fsw_bridge::codec")),
    ("executive", ("partition_executive_main", "flight_app::executive_app", "ExecutivePartition", "flight_app::persistence", "flight_app::memories")),
    ("planner", ("partition_planner_main", "PlannerPartition", "autonomy::planner", "task_planner", "flight_app::planner_app")),
]


def family_of(fn, last):
    for family, keys in FAMILIES:
        if any(k in fn for k in keys):
            return family
    return last


per = collections.Counter()
runs = []  # (family, function, instructions) in execution order, consecutive blocks merged
family = "reset stub"
for pc in order:
    fn = name[pc]
    family = family_of(fn, family)
    n = blocks.instructions(pc)
    per[(family, fn)] += n
    if runs and runs[-1][0] == family and runs[-1][1] == fn:
        runs[-1][2] += n
    else:
        runs.append([family, fn, n])
total = sum(per.values())
print(f"{total:,} guest instructions from reset {reset_number} on (limit {limit:,})")
families = collections.Counter()
for (f, _), n in per.items():
    families[f] += n
for f, n in families.most_common():
    print(f"{n:12,d}  {f}")
for f, _ in families.most_common():
    print(f"\n{f}:")
    for (g, fn), count in per.most_common():
        if g == f and count >= 500:
            print(f"{count:12,d}  {fn[:150]}")
if len(sys.argv) > 5:
    with open(sys.argv[5], "w") as out:
        at = 0
        for f, fn, n in runs:
            at += n
            out.write(f"{at:9d} {n:7d} {f:16s} {fn[:160]}\n")
