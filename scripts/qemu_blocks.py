"""QEMU's block log (`-d exec,nochain,in_asm`) and the firmware's inlined frames, for the guest
profiles (`firmware/temporal/tools/guest_profile.py`, `firmware/lander/tools/guest_profile.py`)
and `scripts/recovery_profile.py`.

With icount the counts are the run's own: every executed block is logged, nothing is sampled.
"""
import subprocess


class BlockLog:
    """The log read from `path` as the run goes. Iterating gives the start address of every
    executed block, in execution order; `size[pc]` is that block's instruction count (QEMU
    prints a block's instructions when it translates it, before its first execution)."""

    def __init__(self, path):
        self.path = path
        self.size = {}

    def __iter__(self):
        current = None
        with open(self.path, "rb", buffering=1 << 20) as log:
            for line in log:
                if line.startswith(b"Trace"):
                    fields = line[line.index(b"[") + 1 : line.index(b"]")].split(b"/")
                    yield int(fields[1], 16)
                elif line.startswith(b"IN:"):
                    current = None
                elif line.startswith(b"0x"):
                    pc = int(line.split(b":")[0], 16)
                    if current is None:
                        current = pc
                        self.size[current] = 0
                    self.size[current] += 1

    def instructions(self, pc):
        return self.size.get(pc, 1)


def symbolize(elf, pcs):
    """Each address's inlined frames from `llvm-symbolizer` on the ELF: per address, a list of
    lines alternating function and location, innermost first."""
    out = subprocess.run(
        ["llvm-symbolizer", "--obj=" + elf, "--inlining=true", "--functions=linkage", "--demangle"],
        input="\n".join(hex(pc) for pc in pcs),
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    return [block.split("\n") for block in out.split("\n\n")]
