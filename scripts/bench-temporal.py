#!/usr/bin/env python3
"""The onboard temporal planner on every benchmark instance, natively and on the emulated
target (issue 13, item 6 goals): one Markdown table row per instance with, natively, solved,
host time, makespan, expansions and peak arena bytes, and on the emulated RAD750 (`hil plan
--emulated`, the planner partition) the guest instructions planning took, its peak arena
bytes and whether its plan is the native plan. Every native plan is checked by
unified-planning's time-triggered validator when the peers' venv exists (scripts/peers.sh).

Both targets plan in the target's 8 MiB arena (`--arena-kib 8192` natively), so the searches
are the same. Host times depend on the machine's load (a benchmark, not a test); guest
instructions do not.

    scripts/bench-temporal.py --firmware target/firmware/powerpc-unknown-linux-gnu/release/rad750-firmware \\
        --out temporal-bench.md

`--max-frames` bounds each emulated job (10 ms frames). A window may run as little as one
expansion (the search stops before an expansion that would overrun the window's share), so
frames say little about instructions: rovers 18 took 1,981 frames for 507 million
instructions, driverlog 14 1,922 for 380 million. The default, 12,000, lets every job within
the goal of 500 million finish.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCH = os.path.normpath(os.path.join(ROOT, "..", "shared", "benchmarks", "pddl"))
DOMAINS = {
    "satellite": "satellite-time-simple-automatic",
    "rovers": "rovers-time-simple-automatic",
    "driverlog": "driverlog-time-simple-automatic",
}
GOAL_INSTRUCTIONS = 500_000_000


def run_json(argv, timeout):
    try:
        p = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, "killed"
    try:
        return json.loads(p.stdout), None
    except json.JSONDecodeError:
        return None, (p.stderr or p.stdout).strip()[-200:]


def validate(python, domain, problem, plan):
    """unified-planning's validator through bench-planners.py's worker; None if no venv."""
    if not python or not os.path.exists(python):
        return None
    with tempfile.NamedTemporaryFile("w", suffix=".plan", delete=False) as f:
        for s in plan:
            f.write(f"{s['start']:.3f}: {s['action']} [{s['duration']:.3f}]\n")
        name = f.name
    try:
        p = subprocess.run(
            [python, os.path.join(ROOT, "scripts", "bench-planners.py"), "--worker-validate", domain, problem, name],
            capture_output=True,
            text=True,
            timeout=600,
        )
        for line in reversed(p.stdout.strip().splitlines()):
            if line.startswith("{"):
                return json.loads(line)["valid"]
        return False
    finally:
        os.unlink(name)


def parse_range(s):
    out = []
    for part in s.split(","):
        if "-" in part:
            a, b = part.split("-")
            out += list(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hil", default=os.path.join(ROOT, "target", "release", "hil"))
    ap.add_argument("--firmware", help="firmware ELF for --emulated (omit: native only)")
    ap.add_argument("--bench", default=BENCH)
    ap.add_argument("--domains", default="satellite,rovers,driverlog")
    ap.add_argument("--instances", default="1-20")
    ap.add_argument("--limit", type=float, default=60.0, help="native host seconds per instance")
    ap.add_argument("--max-frames", type=int, default=12000)
    ap.add_argument("--python", default=os.path.join(ROOT, "target", "peers-venv", "bin", "python"),
                    help="the peers' venv python, for the validator")
    ap.add_argument("--out", help="write the Markdown table here too")
    ap.add_argument("--json", help="write every result as JSON here")
    a = ap.parse_args()
    lines = [
        "| instance | native | time | makespan | expanded | peak arena (bytes) | valid | emulated guest instructions | emulated peak arena | same plan | within 500 M |",
        "|---|---|---:|---:|---:|---:|---|---:|---:|---|---|",
    ]
    print("\n".join(lines), flush=True)
    results = []
    for dom in a.domains.split(","):
        folder = os.path.join(a.bench, DOMAINS[dom])
        domain = os.path.join(folder, "domain.pddl")
        for i in parse_range(a.instances):
            problem = os.path.join(folder, "instances", f"instance-{i}.pddl")
            nat, err = run_json(
                [a.hil, "plan", domain, problem, "--native", "--json", "--arena-kib", "8192", "--time-limit", str(a.limit)],
                a.limit + 120,
            )
            row = {"domain": dom, "instance": i, "native": nat, "native_error": err}
            if nat and nat["solved"]:
                row["valid"] = validate(a.python, domain, problem, nat["plan"])
            if a.firmware:
                emu, eerr = run_json(
                    [a.hil, "plan", domain, problem, "--emulated", "--firmware", a.firmware, "--json",
                     "--max-frames", str(a.max_frames)],
                    3600,
                )
                row["emulated"], row["emulated_error"] = emu, eerr
            results.append(row)
            lines.append(cells(row))
            print(lines[-1], flush=True)
    lines.append("")
    for dom in a.domains.split(","):
        rows = [r for r in results if r["domain"] == dom]
        nat = sum(1 for r in rows if r["native"] and r["native"]["solved"])
        emu = sum(1 for r in rows if within(r))
        lines.append(f"{dom}: native solved {nat}/{len(rows)}, emulated within 500 M instructions {emu}/{len(rows)}  ")
        print(lines[-1], flush=True)
    if a.out:
        with open(a.out, "w") as f:
            f.write("\n".join(lines) + "\n")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


def within(r):
    e = r.get("emulated")
    return bool(e and e["solved"] and e["emulated"] and e["emulated"]["guest_instructions"] <= GOAL_INSTRUCTIONS)


def cells(r):
    n = r["native"]
    tag = f"{r['domain']} {r['instance']}"
    if not n:
        nat = f"error ({r['native_error']})"
        native = [nat, "", "", "", "", ""]
    else:
        v = r.get("valid")
        native = [
            "solved" if n["solved"] else n["outcome"],
            f"{(n['compile_ms'] + n['search_ms']) / 1e3:.2f} s",
            f"{n['makespan']:.2f}" if n["makespan"] is not None else "-",
            f"{n['expanded']:,}",
            f"{n['peak_arena_bytes']:,}",
            "-" if v is None else ("yes" if v else "NO"),
        ]
    if "emulated" not in r:
        emulated = ["", "", "", ""]
    elif not r["emulated"]:
        emulated = [f"error ({r['emulated_error']})", "", "", "no"]
    else:
        e = r["emulated"]
        g = e["emulated"]["guest_instructions"] if e["emulated"] else None
        same = bool(n and e["plan"] == n["plan"] and e["expanded"] == n["expanded"])
        instr = f"{g:,}" if g is not None else "-"
        if not e["solved"]:
            instr += f" ({e['outcome']})"
        emulated = [
            instr,
            f"{e['peak_arena_bytes']:,}",
            "yes" if same else ("-" if not e["solved"] else "NO"),
            "yes" if within(r) else "no",
        ]
    return "| " + " | ".join([tag] + native + emulated) + " |"


if __name__ == "__main__":
    main()
