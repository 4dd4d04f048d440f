#!/bin/sh
# Guest-instruction profile of a lander run on the emulated target, by component.
# usage: firmware/lander/tools/guest_profile.sh [SCENARIO]   (default scenarios/lander/rsm-1.toml)
# GUEST_PROFILE_DETAIL=N also lists the N costliest source lines of lander code.
# QEMU logs every executed block (-d exec,nochain,in_asm) into a FIFO that guest_profile.py
# reads as the run goes (about 3 minutes for RSM-1; no large file is written). The counts
# are the run's own (icount makes them deterministic); the run is slower, not different.
set -eu
root=$(cd "$(dirname "$0")/../../.." && pwd)
scenario=${1:-scenarios/lander/rsm-1.toml}
. "$root/scripts/qemu_trace.sh"
python3 "$root/firmware/lander/tools/guest_profile.py" "$work/trace" "$elf" ${GUEST_PROFILE_DETAIL:-} > "$work/split" &
reader=$!
HIL_QEMU="$work/qemu" ./target/release/hil lander run "$scenario" --emulated | grep -E "plan at step 0|emulated:" || true
wait "$reader"
cat "$work/split"
