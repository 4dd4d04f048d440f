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
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkfifo "$work/trace"
cat > "$work/qemu" <<WRAP
#!/bin/sh
exec ${HIL_QEMU:-qemu-system-ppc} "\$@" -d exec,nochain,in_asm -D "$work/trace"
WRAP
chmod +x "$work/qemu"
elf="$root/target/firmware/powerpc-unknown-linux-gnu/release/rad750-firmware"
cd "$root"
cargo build --release --quiet -p host-harness --bin hil
python3 "$root/scripts/recovery_profile.py" "$work/trace" "$elf" "${2:-2}" "${3:-2000000}" ${4:-} > "$work/split" &
reader=$!
HIL_QEMU="$work/qemu" ./target/release/hil run "$scenario" | grep -E "warm reset at|ticks by part" || true
wait "$reader"
cat "$work/split"
