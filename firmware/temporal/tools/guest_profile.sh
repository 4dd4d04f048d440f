#!/bin/sh
# Guest-instruction profile of `hil plan --emulated` on the emulated target, by source file and
# function of the temporal planner (firmware/temporal/src).
# usage: firmware/temporal/tools/guest_profile.sh DOMAIN PROBLEM [DETAIL]
# DETAIL=N also lists the N costliest source lines. QEMU logs every executed block
# (-d exec,nochain,in_asm) into a FIFO that guest_profile.py reads as the run goes (no large
# file is written); the counts are the run's own (icount: deterministic), the run is slower.
# The whole run is counted: the task's uplink and authentication too (the other partitions'
# and the kernel's blocks are listed under their own files).
set -eu
root=$(cd "$(dirname "$0")/../../.." && pwd)
domain=$1
problem=$2
. "$root/scripts/qemu_trace.sh"
python3 "$root/firmware/temporal/tools/guest_profile.py" "$work/trace" "$elf" ${3:-} > "$work/split" &
reader=$!
HIL_QEMU="$work/qemu" ./target/release/hil plan "$domain" "$problem" --emulated --max-frames 12000 | grep -E "guest instructions|evaluat|makespan" || true
wait "$reader"
cat "$work/split"
