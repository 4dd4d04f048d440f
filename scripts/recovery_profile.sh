#!/bin/sh
# Guest-instruction profile of a warm reset's recovery on the emulated target, by function.
# usage: scripts/recovery_profile.sh [SCENARIO [RESET_NUMBER [LIMIT [RUNS_FILE]]]]
#   (default scenarios/flyby-early-reset.toml, the first warm reset (2), 2,000,000 instructions)
# As firmware/lander/tools/guest_profile.sh: QEMU logs every executed block into a FIFO that
# recovery_profile.py reads as the run goes (no large file is written); the counts are the
# run's own (icount), the run is slower, not different.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
scenario=${1:-scenarios/flyby-early-reset.toml}
. "$root/scripts/qemu_trace.sh"
python3 "$root/scripts/recovery_profile.py" "$work/trace" "$elf" "${2:-2}" "${3:-2000000}" ${4:-} > "$work/split" &
reader=$!
HIL_QEMU="$work/qemu" ./target/release/hil run "$scenario" | grep -E "warm reset at|ticks by part" || true
wait "$reader"
cat "$work/split"
