# Sourced by the guest-instruction profile scripts (firmware/temporal/tools/guest_profile.sh,
# firmware/lander/tools/guest_profile.sh, scripts/recovery_profile.sh), with `root` set to the
# checkout: a temporary directory `work` (removed on exit) holding a FIFO `work/trace` and a
# QEMU wrapper `work/qemu` that logs every executed block (-d exec,nochain,in_asm) into it,
# `elf` the firmware, and `hil` built in release. The caller starts its reader on the FIFO in
# the background, then runs hil with HIL_QEMU="$work/qemu".
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
