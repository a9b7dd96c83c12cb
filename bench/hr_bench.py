#!/usr/bin/env python3
"""End-to-end benchmark of `hrad solve` (issue: hierarchical radiosity core).

Runs the solver on the built-in Cornell box, office:N for several N and, where
../shared/scenes exists, RenderPark's corridor.mgf and salon/classroom.mgf, at a
few eps values, and writes a Markdown table (wall time by phase, peak RSS,
elements, links, bytes per link, rays per second, error against a full-matrix
reference where n^2 is affordable) with the machine and the command.

Usage: /usr/bin/python3 bench/hr_bench.py [--hrad build/apps/hrad] [--quick]
       [--out bench/results/hr_core.md]
Standard library only.
"""
import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def machine():
    cpu = "unknown cpu"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = f"{kb / 1048576:.0f} GiB"
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {mem}, {platform.system()} {platform.release()}"


def run(hrad, scene, extra, outdir):
    cmd = [hrad, "--log", "quiet", "solve", scene, "-o", outdir, "--no-images", "--no-ply",
           "--no-progress"] + extra
    t0 = datetime.datetime.now()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = (datetime.datetime.now() - t0).total_seconds()
    if p.returncode != 0:
        return None, " ".join(cmd), p.stderr.strip().splitlines()[-1:] or ["failed"]
    with open(os.path.join(outdir, "summary.json")) as f:
        s = json.load(f)
    s["_process_wall"] = wall
    return s, " ".join(cmd), None


def write_report(lines, out):
    """Writes the Markdown lines to `out` (creating its folder) and prints them."""
    text = "\n".join(lines) + "\n"
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        f.write(text)
    print(text)


def loadavg():
    """The 1-minute load average, or '?' where /proc/loadavg is absent."""
    try:
        with open("/proc/loadavg") as f:
            return f.read().split()[0]
    except OSError:
        return "?"


def per_link(bpl, key):
    """A bytes-per-link figure from the summary, or '-' where it lacks it."""
    v = bpl.get(key)
    return f"{v:.1f}" if isinstance(v, (int, float)) else "-"


def fmt_bytes(b):
    return f"{b / 1048576:.1f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hrad", default=os.path.join(ROOT, "build", "apps", "hrad"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "hr_core.md"))
    ap.add_argument("--quick", action="store_true", help="fewer cases")
    ap.add_argument("--scenes-dir", default=os.environ.get(
        "HRAD_SCENES", os.path.join(ROOT, "..", "shared", "scenes")))
    args = ap.parse_args()

    cases = []  # (label, scene, extra args)
    for eps in (["1e-3", "1e-4"] if args.quick else ["1e-2", "1e-3", "1e-4"]):
        cases.append((f"cornell eps={eps}", "cornell",
                      ["--eps", eps, "--reference-level", "3"]))
    for n in ([1, 2] if args.quick else [1, 2, 4]):
        # cluster.model defaults to auto (oriented above 2,000 patches): the
        # unclustered core is measured with clustering off explicitly.
        cases.append((f"office:{n} eps=1e-3", f"office:{n}", ["--eps", "1e-3", "--cluster", "none"]))
    rp = os.path.join(args.scenes_dir, "renderpark-mgf")
    if os.path.isdir(rp):
        for rel in ["corridor.mgf", "salon/classroom.mgf"]:
            path = os.path.join(rp, rel)
            if os.path.exists(path):
                for eps in (["1e-3"] if args.quick else ["1e-3", "1e-4"]):
                    cases.append((f"{rel} eps={eps}", path, ["--eps", eps, "--cluster", "none"]))
                    cases.append((f"{rel} eps={eps} oriented clusters", path,
                                  ["--eps", eps, "--cluster", "oriented"]))
    else:
        print(f"note: {rp} absent; RenderPark cases skipped", file=sys.stderr)

    load_start = loadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, (label, scene, extra) in enumerate(cases):
            out = os.path.join(tmp, str(i))
            print(f"[{i + 1}/{len(cases)}] {label}", file=sys.stderr, flush=True)
            s, cmd, err = run(args.hrad, scene, extra, out)
            rows.append((label, s, cmd, err))

    lines = []
    lines.append("# hrad hierarchical radiosity benchmark\n")
    lines.append(f"- date: {datetime.date.today().isoformat()}")
    lines.append(f"- machine: {machine()}")
    lines.append(f"- load (1-minute average, start / end): {load_start} / {loadavg()}")
    lines.append(f"- command: `/usr/bin/python3 bench/hr_bench.py{' --quick' if args.quick else ''}`")
    lines.append("- each case: `hrad solve SCENE --eps EPS --no-images --no-ply` (bfa oracle,"
                 " default settings); times in seconds, memory in MiB\n")
    lines.append("| case | patches | iters | elements | links | link B/link | all B/link |"
                 " linking s | refine s | gather s | push-pull s | solve s | peak RSS MiB |"
                 " Mrays/s | L2 lum vs FM |")
    lines.append("|" + "---|" * 15)
    for label, s, cmd, err in rows:
        if s is None:
            lines.append(f"| {label} | failed: {' '.join(err)} |" + " |" * 13)
            continue
        c, t, m = s["counts"], s["timings"], s["memory"]
        bpl = s.get("bytes_per_link", {})
        solve_t = t.get("solve_total", 0.0)
        rays = c.get("rays", 0)
        mrays = rays / solve_t / 1e6 if solve_t > 0 else 0.0
        err_s = f"{s['error']['l2_lum']:.4f}" if "error" in s else "-"
        lines.append(
            f"| {label} | {s['scene_info']['patches']} | {c.get('iterations', '-')} | "
            f"{c['elements']} | {c['links']} | {per_link(bpl, 'link_storage')} | "
            f"{per_link(bpl, 'links_and_elements')} | {t.get('linking', 0):.2f} | "
            f"{t.get('refine', 0):.2f} | "
            f"{t.get('gather', 0):.3f} | {t.get('push_pull', 0):.3f} | {solve_t:.2f} | "
            f"{fmt_bytes(m['peak_rss'])} | {mrays:.2f} | {err_s} |")
    lines.append("")
    lines.append("`link B/link`: bytes of link storage per link (records, CSR offsets and"
                 " what links keep besides, summary `bytes_per_link.link_storage`);"
                 " `all B/link`: links plus elements per link (`links_and_elements`)."
                 " `L2 lum vs FM`: area-weighted"
                 " relative L2 error of luminance against a full-matrix solve at uniform level 3"
                 " (Cornell only). `solve s`: linking + refinement + gather + push-pull, without"
                 " loading, the Embree build and the reference solve. Peak RSS is the process's,"
                 " so for Cornell it includes the full-matrix reference.")
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
