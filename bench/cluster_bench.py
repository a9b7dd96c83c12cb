#!/usr/bin/env python3
"""Scaling benchmark of volume clustering (issue: volume clustering).

Runs `hrad solve` on office:N over a >100x range of input polygons, without
clustering (where k^2 linking is affordable) and with each cluster builder
(bvh, octree) and transfer model (isotropic, oriented); then on the large
RenderPark scenes and Lost Empire when ../shared/scenes exists. Records wall
time by phase, peak RSS, links by kind, clusters, and fits exponents of links
and time against k (least squares on log-log). Writes a Markdown table.

Usage: /usr/bin/python3 bench/cluster_bench.py [--hrad build/apps/hrad]
       [--out bench/results/cluster_scaling.md] [--quick]
Standard library only.
"""
import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from hr_bench import machine, write_report  # noqa: E402


def solve(hrad, scene, sets, outdir, timeout):
    # --set is a global option: it goes before the subcommand.
    cmd = [hrad, "--log", "quiet"]
    for s in sets:
        cmd += ["--set", s]
    cmd += ["solve", scene, "-o", outdir, "--no-images", "--no-ply", "--no-progress"]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, " ".join(cmd), f"timeout after {timeout} s"
    if p.returncode != 0:
        lines = p.stderr.strip().splitlines()
        return None, " ".join(cmd), lines[-1] if lines else "failed"
    with open(os.path.join(outdir, "summary.json")) as f:
        return json.load(f), " ".join(cmd), None


def fit(xs, ys):
    pts = [(math.log(x), math.log(y)) for x, y in zip(xs, ys) if x > 0 and y > 0]
    if len(pts) < 2:
        return float("nan")
    n = len(pts)
    sx = sum(p[0] for p in pts)
    sy = sum(p[1] for p in pts)
    sxx = sum(p[0] ** 2 for p in pts)
    sxy = sum(p[0] * p[1] for p in pts)
    return (n * sxy - sx * sy) / (n * sxx - sx * sx)


def row(label, s, err):
    if s is None:
        return f"| {label} | failed: {err} |" + " |" * 11
    c, t, m = s["counts"], s["timings"], s["memory"]
    solve_t = t.get("solve_total", 0.0)
    clusters_b = m.get("clusters", 0)
    return (f"| {label} | {s['scene_info']['patches']} | {c.get('iterations')} | {c['links']} | "
            f"{c.get('links_ss', 0)} / {c.get('links_sc', 0)} / {c.get('links_cs', 0)} / "
            f"{c.get('links_cc', 0)} | {c['elements']} | {t.get('cluster_build', 0):.3f} | "
            f"{t.get('linking', 0):.2f} | {t.get('refine', 0):.2f} | "
            f"{t.get('gather', 0) + t.get('push_pull', 0):.2f} | {solve_t:.2f} | "
            f"{m['peak_rss'] / 1048576:.0f} | {clusters_b / 1048576:.1f} |")


HEADER = ("| case | patches k | iters | links | SS / SC / CS / CC | elements | cluster build s |"
          " linking s | refine s | gather+push s | solve s | peak RSS MiB | cluster MiB |\n"
          "|" + "---|" * 13)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hrad", default=os.path.join(ROOT, "build", "apps", "hrad"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "cluster_scaling.md"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--eps", default="1e-3")
    ap.add_argument("--scenes-dir", default=os.environ.get(
        "HRAD_SCENES", os.path.join(ROOT, "..", "shared", "scenes")))
    args = ap.parse_args()

    sizes = [1, 2, 4, 8] if args.quick else [1, 2, 4, 8, 16]
    none_sizes = [1, 2] if args.quick else [1, 2, 4]
    configs = [("none", "bvh")] + [(m, b) for m in ("oriented", "isotropic")
                                   for b in ("bvh", "octree")]
    lines = ["# hrad volume clustering: scaling benchmark\n",
             f"- date: {datetime.date.today().isoformat()}",
             f"- machine: {machine()}",
             f"- command: `/usr/bin/python3 bench/cluster_bench.py{' --quick' if args.quick else ''}`",
             f"- every case: `hrad solve SCENE --set oracle.eps={args.eps} --set cluster.model=M "
             "--set cluster.builder=B --no-images --no-ply` (bfa oracle); times in seconds;"
             " links by kind: receiver-sender, S = surface, C = cluster\n",
             "## office:N\n", HEADER]
    fits = []
    with tempfile.TemporaryDirectory() as tmp:
        for model, builder in configs:
            ks, links, times, first = [], [], [], []
            for n in (none_sizes if model == "none" else sizes):
                label = f"office:{n} {model}" + ("" if model == "none" else f" {builder}")
                print(label, file=sys.stderr, flush=True)
                out = os.path.join(tmp, label.replace(" ", "_").replace(":", "_"))
                s, cmd, err = solve(args.hrad, f"office:{n}",
                                    [f"oracle.eps={args.eps}", f"cluster.model={model}",
                                     f"cluster.builder={builder}"], out, 900)
                lines.append(row(label, s, err))
                if s:
                    ks.append(s["scene_info"]["patches"])
                    links.append(s["counts"]["links"])
                    times.append(s["timings"].get("solve_total", 0.0))
                    hist = s.get("history", [])
                    first.append(hist[0]["links"] if hist else 0)
            name = model if model == "none" else f"{model} {builder}"
            fits.append((name, fit(ks, first), fit(ks, links), fit(ks, times), ks))
        lines.append("\n## Fitted exponents (log-log least squares against k)\n")
        lines.append("| configuration | k range | first-pass links | final links | solve time |")
        lines.append("|---|---|---|---|---|")
        for name, f1, fl, ft, ks in fits:
            rng = f"{min(ks)}..{max(ks)}" if ks else "-"
            lines.append(f"| {name} | {rng} | {f1:.2f} | {fl:.2f} | {ft:.2f} |")

        big = []
        rp = os.path.join(args.scenes_dir, "renderpark-mgf")
        for rel in ["office1/graz.mgf", "hospital/hosp.mgf", "soda.mgf"]:
            if os.path.exists(os.path.join(rp, rel)):
                big.append((rel, os.path.join(rp, rel), []))
        le = os.path.join(args.scenes_dir, "lost-empire", "lost_empire.obj")
        if os.path.exists(le):
            big.append(("lost-empire", le, ["scene.clamp_rho=0.99"]))
        if big:
            lines += ["\n## Large scenes (oriented, bvh)\n", HEADER]
            for label, path, extra in big:
                for eps in ([args.eps] if args.quick else [args.eps, "1e-4"]):
                    print(f"{label} eps={eps}", file=sys.stderr, flush=True)
                    out = os.path.join(tmp, label.replace("/", "_") + eps)
                    s, cmd, err = solve(args.hrad, path,
                                        [f"oracle.eps={eps}", "cluster.model=oriented"] + extra,
                                        out, 1800)
                    lines.append(row(f"{label} eps={eps}", s, err))
        else:
            lines.append("\n(../shared/scenes absent: large scenes skipped)")
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
