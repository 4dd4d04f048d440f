#!/usr/bin/env python3
"""Where the emulated target's guest instructions go, by lander component.

Reads QEMU's `-d exec,nochain,in_asm` log from a FIFO while a run goes on (each translated
block's executions times its instruction count: exact counts, nothing sampled), then
attributes every block to the innermost `firmware/lander/src` file of its (inlined) source
frames (`llvm-symbolizer` on the firmware ELF). Used by `guest_profile.sh`; see the README's
"Where an exploration's instructions go".

usage: guest_profile.py FIFO ELF [DETAIL]
With DETAIL (a number N), also the N costliest source lines of lander code (the innermost
inlined frame in firmware/lander/src: file:line and function, and the library function inlined
there, if any), to find what to change inside a component.
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

GROUPS = [
    (("placement.rs", "htn.rs"), "placement (timeline: candidates, overlaps, holds, energy, Earth)"),
    (("search.rs", "utility.rs"), "search (queue, h comparisons, paths, nodes)"),
    (("comms.rs", "downlink/"), "data-volume check (DataPlacement, downlink manager)"),
    (("assessor.rs",), "Assessor (map rules, prediction)"),
    (("executor/",), "executor (planning set-up, per call)"),
]


def group(functions, locations):
    files = [l.split("/lander/src/")[-1].rsplit(":", 2)[0] for l in locations if "/lander/src/" in l]
    if files:
        for keys, name in GROUPS:
            if any(files[0].startswith(k) for k in keys):
                return name
        return "other lander: " + files[0]
    top = re.sub(r"::h[0-9a-f]{16}", "", functions[-1])
    if "slice::sort" in top:
        return "library: sorting"
    if "div_rem" in top or "udiv" in top or "umod" in top:
        return "library: 64/128-bit division"
    if top in ("memcpy", "memset"):
        return "library: " + top + " (all partitions)"
    return None


split = collections.Counter()
detail = collections.Counter()
for pc, lines in zip(pcs, frames):
    name = group(lines[0::2], lines[1::2])
    if name:
        split[name] += weight[pc]
    inner = [k for k in range(1, len(lines), 2) if "/lander/src/" in lines[k]]
    if inner:
        k = inner[0]
        function = re.sub(r"::h[0-9a-f]{16}", "", lines[k - 1])[-60:]
        where = lines[k].split("/lander/src/")[-1]
        via = "" if k == 1 else " <- " + re.sub(r"::h[0-9a-f]{16}", "", lines[0])[-40:]
        detail[f"{where}  {function}{via}"] += weight[pc]
print(f"{sum(weight.values()):,} guest instructions traced (the whole run, every partition)")
for name, count in split.most_common():
    print(f"{count:14,d}  {name}")
if len(sys.argv) > 3:
    print("costliest lines of lander code (innermost frame):")
    for name, count in detail.most_common(int(sys.argv[3])):
        print(f"{count:14,d}  {name}")
