#!/usr/bin/env python3
"""Where the emulated target's guest instructions go in `hil plan --emulated`, by temporal
planner source file and function.

Reads QEMU's `-d exec,nochain,in_asm` log from a FIFO while the run goes on (each translated
block's executions times its instruction count: exact, nothing sampled), then attributes every
block to the innermost `firmware/temporal/src` frame of its (inlined) source frames
(`llvm-symbolizer` on the firmware ELF). Used by `guest_profile.sh` (the lander's
`firmware/lander/tools/guest_profile.py` does the same by lander component).

usage: guest_profile.py FIFO ELF [DETAIL]
With DETAIL (a number N), also the N costliest source lines of temporal code.
"""
import collections
import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "scripts"))
from qemu_blocks import BlockLog, symbolize  # noqa: E402

fifo, elf = sys.argv[1], sys.argv[2]
blocks = BlockLog(fifo)
execs = collections.Counter(blocks)
pcs = sorted(execs)
weight = {pc: execs[pc] * blocks.instructions(pc) for pc in pcs}
frames = symbolize(elf, pcs)

KEY = "/temporal/src/"


def clean(function):
    return re.sub(r"::h[0-9a-f]{16}", "", function)


by_file = collections.Counter()
by_function = collections.Counter()
detail = collections.Counter()
for pc, lines in zip(pcs, frames):
    functions, locations = lines[0::2], lines[1::2]
    inner = [k for k, l in enumerate(locations) if KEY in l]
    if inner:
        k = inner[0]
        where = locations[k].split(KEY)[-1]
        file = where.rsplit(":", 2)[0]
        function = clean(functions[k])[-70:]
        by_file[file] += weight[pc]
        by_function[f"{file}  {function}"] += weight[pc]
        via = "" if k == 0 else " <- " + clean(functions[0])[-40:]
        detail[f"{where}  {function[-40:]}{via}"] += weight[pc]
    else:
        top = clean(functions[-1])
        src = locations[-1].rsplit(":", 2)[0].split("/")[-1] if locations else "?"
        if top in ("memcpy", "memset", "memmove", "memcmp"):
            name = "library: " + top
        else:
            name = "other: " + src
        by_file[name] += weight[pc]
print(f"{sum(weight.values()):,} guest instructions traced (the whole run, every partition)")
print("by file:")
for name, count in by_file.most_common(25):
    print(f"{count:14,d}  {name}")
print("by function (innermost temporal frame):")
for name, count in by_function.most_common(25):
    print(f"{count:14,d}  {name}")
if len(sys.argv) > 3:
    print("costliest lines of temporal code (innermost frame):")
    for name, count in detail.most_common(int(sys.argv[3])):
        print(f"{count:14,d}  {name}")
