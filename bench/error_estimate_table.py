#!/usr/bin/python3
"""Calibration table of the residual error estimate (reference/error_estimate.h).

  /usr/bin/python3 bench/error_estimate_table.py STORE.sqlite [STORE ...]

For every run with a Monte Carlo reference: the non-emitter L2 against the
reference, the reference's own noise (mc_stderr_l2_nonemitter_lum), the true
error with that noise removed in quadrature, the estimate and its ratio to
the truth. A run whose reference noise is more than 70 % of the measured
error has no usable truth (the quadrature difference is then dominated by
the noise's own uncertainty) and is listed but not counted. Prints a
markdown table and the share of counted runs in [0.67, 1.5]."""
import json
import sqlite3
import sys


def rows(path):
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    q = ("SELECT scene, eps, links, l2_nonemitter_lum, mean_ratio_nonemitter, solve_s, summary "
         "FROM runs ORDER BY point_index")
    for scene, eps, links, l2, mr, solve_s, summary in db.execute(q):
        s = json.loads(summary)
        err, est = s.get("error", {}), s.get("estimate")
        if est is None or l2 is None:
            continue
        noise = err.get("mc_stderr_l2_nonemitter_lum") or 0.0
        truth = max(0.0, l2 * l2 - noise * noise) ** 0.5
        usable = l2 > 0 and noise <= 0.7 * l2
        yield dict(scene=scene.replace("../../../shared/scenes/", ""), eps=eps, links=links,
                   l2=l2, noise=noise, truth=truth, est=est["l2_nonemitter"],
                   est_noise=est["noise_l2_nonemitter"], mr=mr,
                   mre=est["mean_ratio_nonemitter"], est_s=est["seconds"], solve_s=solve_s,
                   usable=usable)


def main(paths):
    runs = [r for p in paths for r in rows(p)]
    print("| scene | eps | links | L2ne vs MC | MC noise | true L2ne | estimate | "
          "estimate's noise | estimate / true | mean ratio true / estimated | estimate s | solve s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    ratios = []
    for r in runs:
        ratio = r["est"] / r["truth"] if r["usable"] and r["truth"] > 0 else None
        if ratio is not None:
            ratios.append(ratio)
        rs = f"{ratio:.2f}" if ratio is not None else "(reference too noisy)"
        print(f"| {r['scene']} | {r['eps']:g} | {r['links']} | {r['l2']:.4f} | {r['noise']:.4f} | "
              f"{r['truth']:.4f} | {r['est']:.4f} | {r['est_noise']:.4f} | {rs} | "
              f"{r['mr']:.4f} / {r['mre']:.4f} | {r['est_s']:.1f} | {r['solve_s']:.1f} |")
    if ratios:
        inside = sum(1 for x in ratios if 0.67 <= x <= 1.5)
        print(f"\n{len(ratios)} runs with a usable truth: {inside} ({100.0 * inside / len(ratios):.0f} %) "
              f"in [0.67, 1.5]; ratio range {min(ratios):.2f}-{max(ratios):.2f}; "
              f"{sum(1 for x in ratios if x < 0.5)} below 0.5.")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
