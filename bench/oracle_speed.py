#!/usr/bin/env python3
"""Cost of the error-bound oracles against bfa at equal link counts
(issue "Error control", item 6: `error` and `kv` within 1.5x of `bfa`).

For each scene, bfa runs over a ladder of eps values (half-decade steps) and
gives a curve of CPU time against links; `error` and `kv` run at a few eps
values, and each of their runs is compared with bfa's time at the same link
count, interpolated log-log between the two nearest bfa points (never
extrapolated: a run outside bfa's link range is reported without a ratio).
Times are the child process's user + system CPU seconds (`--threads 1`, so a
loaded machine stretches wall time, not CPU time), and the solver's own
refinement seconds from summary.json.

Usage: /usr/bin/python3 bench/oracle_speed.py [--hrad build/apps/hrad]
       [--quick] [--out bench/results/oracle_speed.md]
Scenes under ../shared/scenes are skipped when that folder is absent.
Standard library only.
"""
import argparse
import datetime
import json
import math
import os
import resource
import subprocess
import sys
import tempfile

from hr_bench import machine  # bench/hr_bench.py, next to this script

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "scenes")


def load():
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "unknown"


def run(hrad, scene, extra, tmp):
    out = tempfile.mkdtemp(dir=tmp)
    cmd = [hrad, "--log", "quiet", "--threads", "1", "solve", scene, "-o", out,
           "--no-images", "--no-ply", "--no-progress"] + extra
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(cmd, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.stderr.write(f"failed: {' '.join(cmd)}\n{p.stderr}\n")
        return None
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {
        "links": s["counts"]["links"],
        "cpu": cpu,
        "refine": s["timings"].get("refine", 0.0),
    }


def interpolate(curve, links):
    """bfa CPU seconds at `links`, log-log between the bracketing points."""
    pts = sorted((c["links"], c["cpu"]) for c in curve)
    for (l0, t0), (l1, t1) in zip(pts, pts[1:]):
        if l0 <= links <= l1:
            if l1 == l0:
                return 0.5 * (t0 + t1)
            a = (math.log(links) - math.log(l0)) / (math.log(l1) - math.log(l0))
            return math.exp((1 - a) * math.log(max(t0, 1e-3)) + a * math.log(max(t1, 1e-3)))
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hrad", default=os.path.join(ROOT, "build", "apps", "hrad"))
    ap.add_argument("--quick", action="store_true", help="cornell and furnace only")
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "oracle_speed.md"))
    args = ap.parse_args()

    ladder = ["1e-2", "3e-3", "1e-3", "3e-4", "1e-4", "3e-5", "1e-5"]
    # scene label, scene argument, extra settings, bfa ladder, error/kv eps
    cases = [
        ("furnace", "furnace", ["--cluster", "none"], ladder[2:], ["1e-3", "1e-4"]),
        ("cornell", "cornell", ["--cluster", "none"], ladder, ["1e-2", "1e-3", "1e-4"]),
        ("office:2", "office:2", ["--cluster", "none"], ladder[:6], ["1e-2", "1e-3", "1e-4"]),
    ]
    rp = os.path.join(SHARED, "renderpark-mgf")
    if not args.quick and os.path.isdir(rp):
        cases += [
            ("corridor, oriented", os.path.join(rp, "corridor.mgf"), ["--cluster", "oriented"],
             ladder[:6], ["1e-2", "1e-3", "1e-4"]),
            ("classroom, oriented", os.path.join(rp, "salon", "classroom.mgf"),
             ["--cluster", "oriented"], ladder[:6], ["1e-2", "1e-3", "1e-4"]),
        ]
    if args.quick:
        cases = cases[:2]

    start_load = load()
    started = datetime.datetime.now(datetime.timezone.utc)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, scene, extra, bfa_eps, other_eps in cases:
            curve = []
            for e in bfa_eps:
                r = run(args.hrad, scene, extra + ["--oracle", "bfa", "--eps", e], tmp)
                if r:
                    curve.append(r)
                    rows.append((label, "bfa", e, r, None, None))
            for oracle in ("error", "kv"):
                for e in other_eps:
                    r = run(args.hrad, scene, extra + ["--oracle", oracle, "--eps", e], tmp)
                    if not r:
                        continue
                    ref = interpolate(curve, r["links"])
                    rows.append((label, oracle, e, r, ref, r["cpu"] / ref if ref else None))
            sys.stderr.write(f"{label} done\n")
    end_load = load()

    lines = [
        "# Oracle cost at equal link counts (issue \"Error control\", item 6)",
        "",
        f"- date: {started:%Y-%m-%d %H:%M} UTC",
        f"- machine: {machine()}",
        f"- load average (1, 5, 15 min) at start: {start_load}; at end: {end_load}",
        "- command: `/usr/bin/python3 bench/oracle_speed.py`"
        + (" --quick" if args.quick else ""),
        "- each run: `hrad --threads 1 solve SCENE --oracle O --eps E [--cluster ...] "
        "--no-images --no-ply`; CPU = user + system seconds of the process; refine = "
        "the solver's refinement seconds (wall, one thread)",
        "- `bfa at equal links`: bfa's CPU seconds interpolated log-log at the run's link "
        "count between the two bfa runs that bracket it (blank: outside bfa's range)",
        "",
        "| scene | oracle | eps | links | CPU s | refine s | bfa at equal links, CPU s | ratio |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, oracle, e, r, ref, ratio in rows:
        lines.append(
            f"| {label} | {oracle} | {e} | {r['links']:,} | {r['cpu']:.2f} | {r['refine']:.2f} | "
            + (f"{ref:.2f} | {ratio:.2f}x |" if ref else "| |"))
    ratios = [x[5] for x in rows if x[5]]
    if ratios:
        lines += ["", f"Largest ratio: {max(ratios):.2f}x; median {sorted(ratios)[len(ratios) // 2]:.2f}x "
                  f"over {len(ratios)} runs with a bracketing bfa curve."]
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
