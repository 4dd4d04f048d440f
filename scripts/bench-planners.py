#!/usr/bin/env python3
"""Side-by-side benchmark of the onboard temporal planner and peer planners on the temporal
PDDL benchmarks in ../shared/benchmarks/pddl (issue 13, item 6), all in one invocation with one
time limit.

For each instance: solved or not, makespan, time and peak memory, per planner:
- ours natively (`hil plan --native`, in the target's 8 MiB arena by default, so the search is
  the emulated target's): makespan, host time, peak arena bytes (the planner's whole search
  memory) and the hil process's peak RSS;
- ours on the emulated RAD750 (`hil plan --emulated`, the planner partition; with `--firmware`):
  guest instructions of planning, peak arena bytes, whether plan and statistics are the native
  ones, and whether it stayed within issue 13's 500 million instructions (the job is given
  `--max-frames` 10 ms frames, by default 12,000: a window may run as little as one expansion,
  so a job within the goal can take a few thousand frames; rovers 18 took 1,981 for 507
  million instructions);
- LPG-td (the binary's peak RSS), and Aries and Tamer (the peak RSS of their process tree): on
  every instance with `--others all`, or by default only where LPG-td and ours (natively)
  disagree on solved.
Every plan, ours and the peers', is checked with unified-planning's time-triggered plan
validator. Host times are wall time and depend on the machine's load (a benchmark, not a test);
guest instructions do not.

Set up the peers first: scripts/peers.sh (a venv in target/peers-venv). Then, e.g.:

    nice -n 10 target/peers-venv/bin/python scripts/bench-planners.py --limit 60 \\
        --firmware target/firmware/powerpc-unknown-linux-gnu/release/rad750-firmware \\
        --out bench.md --json bench.json

A peer that fails (timeout or no plan) on `--give-up` consecutive instances of a domain is not
run on the domain's remaining (larger) instances; the table says so ("skipped").
"""
import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_BENCH = os.path.normpath(os.path.join(ROOT, "..", "shared", "benchmarks", "pddl"))
DOMAINS = {
    "satellite": "satellite-time-simple-automatic",
    "rovers": "rovers-time-simple-automatic",
    "driverlog": "driverlog-time-simple-automatic",
    "crew": "crew-planning-temporal-satisficing-strips",
    "pipesworld": "pipesworld-no-tankage-temporal-deadlines-strips",
}
PEERS = {"lpg": "lpg", "aries": "aries", "tamer": "tamer"}


def run_measured(argv, timeout_s):
    """Run argv in its own session; return (exit code or None on timeout, stdout, stderr).
    On timeout the session we started is ended by its process-group id. (RUSAGE_CHILDREN only
    grows, so each run's peak RSS comes from a fresh `--measure` wrapper: see `wrap`.)"""
    proc = subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True, text=True
    )
    try:
        out, _err = proc.communicate(timeout=timeout_s)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _err = proc.communicate()
        code = None
    return code, out, _err


def wrap(argv):
    """argv run under this script's `--measure` mode, which prints the tree's peak RSS last."""
    return [sys.executable, os.path.abspath(__file__), "--measure", "--"] + argv


def measure_main(argv):
    """`--measure -- CMD...`: run CMD, forward its stdout, print `PEAK_RSS_KIB n` last."""
    import resource

    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
    out, _ = proc.communicate()
    # This process's only child has been waited for: the largest RSS of it and of the
    # descendants it waited for.
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    sys.stdout.write(out)
    sys.stdout.write(f"\nPEAK_RSS_KIB {peak}\n")
    sys.exit(proc.returncode)


def split_peak(out):
    m = re.search(r"\nPEAK_RSS_KIB (\d+)\n?$", out or "")
    if not m:
        return out, None
    return out[: m.start()], int(m.group(1))


# ----- workers (run in a child process, so each run's memory is its own) ----------------------


def load_problem(domain, problem):
    import warnings

    warnings.filterwarnings("ignore")
    from unified_planning.io import PDDLReader

    return PDDLReader().parse_problem(domain, problem)


def validate(problem, plan):
    from unified_planning.engines.plan_validator import TimeTriggeredPlanValidator

    v = TimeTriggeredPlanValidator()
    r = v.validate(problem, plan)
    return r.status.name == "VALID", (r.reason.name if r.reason else "") + (
        f" {r.inapplicable_action}" if getattr(r, "inapplicable_action", None) else ""
    )


def makespan_of(plan):
    end = 0
    for start, action, duration in plan.timed_actions:
        end = max(end, float(start) + float(duration or 0))
    return end


def run_lpg_binary(binary, domain, problem, limit, tmp):
    """One LPG-td run on these files in `tmp`: (exit status from os.wait4, wall seconds, peak RSS
    in KiB, the .SOL file's path or None)."""
    t0 = time.monotonic()
    proc = subprocess.Popen(
        [binary, "-o", domain, "-f", problem, "-n", "1", "-cputime", str(int(limit)), "-out", os.path.join(tmp, "plan")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        cwd=tmp,
    )
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = time.monotonic() - t0
    sols = sorted(f for f in os.listdir(tmp) if f.endswith(".SOL"))
    return status, elapsed, usage.ru_maxrss, os.path.join(tmp, sols[0]) if sols else None


def worker_lpg(domain, problem, limit):
    """LPG-td straight from the up-lpg wheel's binary on the original files: up-lpg 0.1.3 cannot
    parse this binary's temporal plans (`[2.0000])` ends each line), so the wrapper reports an
    error on every instance. The peak RSS is the binary's own (os.wait4).

    If the binary dies by a signal on the original files (it does on every crew planning
    instance: a segmentation fault, on the domain's `- objects` supertype), it is run again on
    the files unified-planning's PDDL writer makes of the same problem, as up-lpg itself would
    give it; the result says so (`input: "written"`), and its time and memory are that second
    run's alone. The plan is validated against the problem read from the original files."""
    import up_lpg
    from unified_planning.io import PDDLReader, PDDLWriter

    binary = os.path.join(os.path.dirname(up_lpg.__file__), "lpg")
    pb = load_problem(domain, problem)
    with tempfile.TemporaryDirectory() as tmp:
        status, elapsed, rss, sol = run_lpg_binary(binary, domain, problem, limit, tmp)
        source = "original"
        if os.WIFSIGNALED(status):
            written = os.path.join(tmp, "written")
            os.mkdir(written)
            writer = PDDLWriter(pb)
            writer.write_domain(os.path.join(written, "domain.pddl"))
            writer.write_problem(os.path.join(written, "problem.pddl"))
            status, elapsed, rss, sol = run_lpg_binary(
                binary, os.path.join(written, "domain.pddl"), os.path.join(written, "problem.pddl"), limit, written
            )
            source = "written"
        out = {"status": "SOLVED" if sol else "NO_PLAN", "time_s": elapsed, "solved": bool(sol), "binary_rss_kib": rss, "input": source}
        if os.WIFSIGNALED(status) and not sol:
            out["status"] = f"crashed (signal {os.WTERMSIG(status)})"
        if sol:
            steps = []
            with open(sol) as f:
                for line in f:
                    m = re.match(r"^\s*([\d.]+):\s*\(([^)]*)\)\s*\[([\d.]+)\]", line)
                    if m:
                        steps.append(f"{m.group(1)}: ({m.group(2).strip()}) [{m.group(3)}]")
            plan = PDDLReader().parse_plan_string(pb, "\n".join(steps))
            out["makespan"] = makespan_of(plan)
            ok, why = validate(pb, plan)
            out["valid"] = ok
            out["invalid_reason"] = why
    print(json.dumps(out))


def worker_peer(name, domain, problem, limit):
    if name == "lpg":
        return worker_lpg(domain, problem, limit)
    import warnings

    warnings.filterwarnings("ignore")
    import unified_planning.shortcuts as up

    up.get_environment().credits_stream = None
    pb = load_problem(domain, problem)
    t0 = time.monotonic()
    with up.OneshotPlanner(name=name) as planner:
        res = planner.solve(pb, timeout=limit)
    elapsed = time.monotonic() - t0
    out = {"status": res.status.name, "time_s": elapsed, "solved": res.plan is not None}
    if res.plan is not None:
        out["makespan"] = makespan_of(res.plan)
        ok, why = validate(pb, res.plan)
        out["valid"] = ok
        out["invalid_reason"] = why
    print(json.dumps(out))


def worker_validate(domain, problem, plan_file):
    from unified_planning.io import PDDLReader

    pb = load_problem(domain, problem)
    plan = PDDLReader().parse_plan(pb, plan_file)
    ok, why = validate(pb, plan)
    print(json.dumps({"valid": ok, "reason": why}))


# ----- the driver ---------------------------------------------------------------------------


def last_json(out):
    for line in reversed((out or "").strip().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            try:
                return json.loads(line)
            except json.JSONDecodeError:
                pass
    return None


def run_ours(hil, domain, problem, limit, arena_kib):
    argv = wrap(
        [hil, "plan", domain, problem, "--native", "--json", "--time-limit", str(limit)]
        + ["--arena-kib", str(arena_kib)]
    )
    code, out, err = run_measured(argv, limit + 30)
    out, rss = split_peak(out)
    if code is None:
        return {"solved": False, "outcome": "killed"}
    try:
        rep = json.loads(out)
    except json.JSONDecodeError:
        return {"solved": False, "outcome": "error: " + (err or out).strip()[-200:]}
    res = {
        "solved": rep["solved"],
        "outcome": rep["outcome"],
        "makespan": rep.get("makespan"),
        "time_s": (rep["compile_ms"] + rep["search_ms"]) / 1e3,
        "peak_arena_bytes": rep["peak_arena_bytes"],
        "rss_kib": rss,
        "expanded": rep["expanded"],
        "evaluated": rep["evaluated"],
        "actions": rep["actions"],
        "task_bytes": rep["task_bytes"],
        "plan": rep["plan"],
    }
    if rep["solved"]:
        with tempfile.NamedTemporaryFile("w", suffix=".plan", delete=False) as f:
            for s in rep["plan"]:
                f.write(f"{s['start']:.3f}: {s['action']} [{s['duration']:.3f}]\n")
            plan_file = f.name
        code, vout, verr = run_measured(
            [sys.executable, os.path.abspath(__file__), "--worker-validate", domain, problem, plan_file],
            300,
        )
        os.unlink(plan_file)
        v = last_json(vout)
        res["valid"] = bool(v and v["valid"])
        res["invalid_reason"] = (v or {}).get("reason") or (verr or "").strip()[-200:]
    return res


GOAL_INSTRUCTIONS = 500_000_000


def run_emulated(hil, firmware, domain, problem, max_frames, native):
    """`hil plan --emulated` in the planner partition: guest instructions, peak arena, and
    whether the plan and the search statistics are the native run's."""
    argv = [hil, "plan", domain, problem, "--emulated", "--firmware", firmware, "--json"]
    argv += ["--max-frames", str(max_frames)]
    code, out, err = run_measured(argv, 3600)
    if code is None:
        return {"solved": False, "outcome": "killed"}
    try:
        rep = json.loads(out)
    except json.JSONDecodeError:
        return {"solved": False, "outcome": "error: " + one_line((err or out).strip()[-300:])}
    emu = rep.get("emulated") or {}
    res = {
        "solved": rep["solved"],
        "outcome": rep["outcome"],
        # To the search's plan (the goal's measure); the action elimination that improves it
        # after (the makespan reported is the improved plan's) is counted apart.
        "guest_instructions": emu.get("guest_instructions"),
        "elimination_instructions": emu.get("elimination_instructions"),
        "frames": emu.get("frames"),
        "peak_arena_bytes": rep["peak_arena_bytes"],
        "expanded": rep["expanded"],
    }
    res["same_plan"] = bool(
        native and native.get("solved") and rep["solved"]
        and rep["plan"] == native.get("plan") and rep["expanded"] == native.get("expanded")
    )
    g = res["guest_instructions"]
    res["within_goal"] = bool(rep["solved"] and g is not None and g <= GOAL_INSTRUCTIONS)
    return res


def run_peer(peer, domain, problem, limit):
    argv = wrap([sys.executable, os.path.abspath(__file__), "--worker-peer", peer, domain, problem, str(limit)])
    t0 = time.monotonic()
    code, out, err = run_measured(argv, limit + 30)
    wall = time.monotonic() - t0
    out, rss = split_peak(out)
    if code is None:
        return {"solved": False, "outcome": "killed", "time_s": wall}
    r = last_json(out)
    if r is None:
        return {"solved": False, "outcome": "error: " + (err or "").strip()[-200:], "rss_kib": rss}
    r["outcome"] = r.pop("status")
    r["rss_kib"] = r.get("binary_rss_kib", rss)
    return r


def one_line(text):
    """The last line of an outcome or error, safe in a Markdown table cell."""
    lines = [l.strip() for l in str(text).strip().splitlines() if l.strip()]
    return (lines[-1] if lines else "?").replace("|", "/")[:120]


def cell_ours(r):
    if not r.get("solved"):
        return f"- ({one_line(r.get('outcome', '?'))})"
    v = "" if r.get("valid") else " INVALID"
    return (
        f"{r['makespan']:.2f} / {r['time_s']:.2f} s / {r['peak_arena_bytes'] / 1024:,.0f} KiB"
        f" ({(r.get('rss_kib') or 0) / 1024:.0f} MB RSS){v}"
    )


def cell_emulated(e):
    if e is None:
        return "-"
    g = e.get("guest_instructions")
    if not e.get("solved"):
        m = re.search(r"no answer from the planner partition after (\d+) frames", e.get("outcome", ""))
        if m:
            # A window may run as little as one expansion (the search stops before one that
            # would overrun the window's share), so frames say nothing sure about instructions.
            return f"no plan within {int(m.group(1)):,} frames"
        if g is not None:
            return f"- ({one_line(e.get('outcome', '?'))} after {g:,})"
        return f"- ({one_line(e.get('outcome', '?'))})"
    same = "" if e.get("same_plan") else ", NOT the native plan"
    goal = "" if e.get("within_goal") else " (over 500 M)"
    x = e.get("elimination_instructions")
    elim = f" (+{x:,} elimination)" if x else ""
    return f"{g:,}{goal}{elim} / {e['peak_arena_bytes'] / 1024:,.0f} KiB{same}"


def valid_plan(r):
    """A result with a plan the validator accepted."""
    return bool(r and r.get("solved") and r.get("valid"))


def cell_peer(r):
    if r is None:
        return "not run"
    if not r.get("solved"):
        o = r.get("outcome", "?")
        return "- (" + ("timeout" if o in ("killed", "TIMEOUT") else one_line(o).lower()) + ")"
    v = "" if r.get("valid") else " INVALID"
    w = " (written files)" if r.get("input") == "written" else ""
    return f"{r['makespan']:.2f} / {r['time_s']:.2f} s / {(r.get('rss_kib') or 0) / 1024:.0f} MB{v}{w}"


def ratio(row, peers):
    """Our peak arena over the lowest peak RSS of the peers that solved the instance."""
    o = row["ours"]
    rss = [row[p]["rss_kib"] for p in peers if row.get(p) and row[p].get("solved") and row[p].get("rss_kib")]
    if not o.get("solved") or not rss:
        return ""
    return f"{o['peak_arena_bytes'] / (1024 * min(rss)):.4f}"


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
    ap.add_argument("--firmware", help="firmware ELF: also plan on the emulated target (omit: native only)")
    ap.add_argument("--max-frames", type=int, default=12000, help="10 ms frames granted to each emulated job")
    ap.add_argument("--bench", default=DEFAULT_BENCH)
    ap.add_argument("--domains", default="satellite,rovers,driverlog")
    ap.add_argument("--instances", default="1-20")
    ap.add_argument("--peers", default="lpg,aries,tamer", help="comma list, or 'none'")
    ap.add_argument("--others", choices=["disagree", "all"], default="disagree",
                    help="run the peers after the first only where it and ours disagree on solved (default), or everywhere")
    ap.add_argument("--limit", type=float, default=60.0, help="seconds per planner and instance")
    ap.add_argument("--arena-kib", type=int, default=8192, help="our native arena (the target's: 8192)")
    ap.add_argument("--give-up", type=int, default=2)
    ap.add_argument("--out", help="write the Markdown table here too")
    ap.add_argument("--json", help="write every result as JSON here")
    a = ap.parse_args()
    peers = [] if a.peers == "none" else a.peers.split(",")
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    results = []
    head = "| instance | ours, native: makespan / time / peak arena (RSS) |"
    sep = "|---|---|"
    if a.firmware:
        head += " ours, emulated: guest instructions to the search's plan (+ elimination) / peak arena |"
        sep += "---|"
    head += "".join(f" {p}: makespan / time / peak RSS |" for p in peers) + " arena / lowest peer RSS |"
    sep += "---|" * len(peers) + "---:|"
    lines = [
        f"Run of {started}: limit {a.limit:g} s per planner and instance, our native arena"
        f" {a.arena_kib} KiB" + (f", emulated jobs at most {a.max_frames} frames" if a.firmware else "") + ".",
        "",
        head,
        sep,
    ]
    print("\n".join(lines), flush=True)
    for dom in a.domains.split(","):
        folder = os.path.join(a.bench, DOMAINS[dom])
        domain = os.path.join(folder, "domain.pddl")
        fails = {p: 0 for p in peers}
        for i in parse_range(a.instances):
            problem = os.path.join(folder, "instances", f"instance-{i}.pddl")
            row = {"domain": dom, "instance": i, "ours": run_ours(a.hil, domain, problem, a.limit, a.arena_kib)}
            if a.firmware:
                row["emulated"] = run_emulated(a.hil, a.firmware, domain, problem, a.max_frames, row["ours"])
            for k, p in enumerate(peers):
                disagree = k > 0 and a.others == "disagree" and (
                    row[peers[0]] is not None and bool(row[peers[0]].get("solved")) == bool(row["ours"].get("solved"))
                )
                if fails[p] >= a.give_up or disagree:
                    row[p] = None
                    continue
                r = run_peer(PEERS[p], domain, problem, a.limit)
                fails[p] = 0 if r.get("solved") else fails[p] + 1
                row[p] = r
            results.append(row)
            line = f"| {dom} {i} | {cell_ours(row['ours'])} |"
            if a.firmware:
                line += f" {cell_emulated(row['emulated'])} |"
            line += "".join(f" {cell_peer(row[p])} |" for p in peers) + f" {ratio(row, peers)} |"
            lines.append(line)
            print(line, flush=True)
            if a.json:
                with open(a.json, "w") as f:
                    json.dump(results, f, indent=1)
    # A plan the validator refuses is not counted as solved (it is listed below the table).
    lines += ["", "| solved with a valid plan (of instances run) | ours, native |" + (" ours, emulated within 500 M |" if a.firmware else "")
              + "".join(f" {p} |" for p in peers), "|---|---:|" + ("---:|" if a.firmware else "") + "---:|" * len(peers)]
    for dom in a.domains.split(","):
        rows = [r for r in results if r["domain"] == dom]
        s = f"| {dom} ({len(rows)}) | {sum(1 for r in rows if valid_plan(r['ours']))} |"
        if a.firmware:
            # Within the goal with the native plan, which the validator accepted.
            s += f" {sum(1 for r in rows if r['emulated'].get('within_goal') and r['emulated'].get('same_plan') and valid_plan(r['ours']))} |"
        for p in peers:
            ran = sum(1 for r in rows if r[p] is not None)
            s += f" {sum(1 for r in rows if valid_plan(r[p]))} (of {ran} run) |"
        lines.append(s)
    invalid = [f"{r['domain']} {r['instance']} {k}" for r in results for k in ["ours"] + peers
               if r.get(k) and r[k].get("solved") and not r[k].get("valid")]
    lines += ["", "Plans the validator refused: " + (", ".join(invalid) if invalid else "none") + "."]
    ended = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    lines.append(f"Started {started}, ended {ended}.")
    print("\n".join(lines[-(len(a.domains.split(',')) + 5):]), flush=True)
    if a.out:
        with open(a.out, "w") as f:
            f.write("\n".join(lines) + "\n")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--measure":
        measure_main(sys.argv[3:])
    elif len(sys.argv) > 1 and sys.argv[1] == "--worker-peer":
        worker_peer(sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5]))
    elif len(sys.argv) > 1 and sys.argv[1] == "--worker-validate":
        worker_validate(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        main()
