"""Discontinuity meshing study (studies/discontinuity.toml): table and figure.

Reads the store of `hrad sweep studies/discontinuity.toml` and each point's
error map (error.png: e = (Y_s - Y_r) / max(Y_r, floor) against the
path-traced image, render/error_map.h) and reference.png. The "shadow-edge
band" of a scene is the set of pixels where the path-traced image of its
mesh.discontinuity = off point changes fast: after two 3 x 3 box blurs,
the 5 x 5 range of luminance exceeds 30 % of the image's mean over the lit
pixels, dilated by 1 pixel. It holds shadow edges and also geometric edges (silhouettes,
creases), which no meshing changes; the band is the same pixels for every
point of a scene.

  /usr/bin/python3 papers/discontinuity_edges.py --store S --out papers/figures/discontinuity
writes OUT.md (the table) and OUT.png (reference | off | emitters error maps).
"""
import argparse
import json
import os
import sqlite3

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402


def srgb_luminance(path):
    a = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64) / 255.0
    lin = np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)
    return lin @ np.array([0.2126, 0.7152, 0.0722])


def error_values(path):
    v = np.asarray(Image.open(path), dtype=np.float64)
    e = 2.0 * (v - 1.0) / 65534.0 - 1.0
    e[v == 0] = np.nan
    return e


def window(a, r, fn):
    pad = np.pad(a, r, mode="edge")
    stack = [pad[i:i + a.shape[0], j:j + a.shape[1]] for i in range(2 * r + 1) for j in range(2 * r + 1)]
    return fn(np.stack(stack), axis=0)


def edge_band(ref_png):
    lum = srgb_luminance(ref_png)
    y = window(window(lum, 1, np.mean), 1, np.mean)  # two 3 x 3 box blurs: path-tracing noise
    rng = window(y, 2, np.max) - window(y, 2, np.min)
    band = rng > 0.3 * y[lum > 0].mean()
    return window(band.astype(np.float64), 1, np.max) > 0


def load(store):
    base = os.path.dirname(os.path.abspath(store))  # artefact paths are relative to it
    con = sqlite3.connect(store)
    rows = []
    for key, scene, summary in con.execute("select key, scene, summary from runs order by point_index"):
        s = json.loads(summary)
        st = s["resolved_settings"] if isinstance(s.get("resolved_settings"), dict) else {}
        mesh = s["settings"].get("mesh.discontinuity", "off")
        eps = s["settings"].get("oracle.eps")
        d = s.get("scene_info", {}).get("discontinuity", {})
        rows.append(dict(key=key, scene=os.path.basename(scene), mesh=mesh, eps=eps, s=s, d=d,
                         dir=os.path.join(base, os.path.dirname(s["artefacts"]["error_map"])), st=st))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--store", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    rows = load(args.store)
    bands = {}
    for r in rows:
        if r["mesh"] == "off" and r["scene"] not in bands:
            bands[r["scene"]] = edge_band(os.path.join(r["dir"], "reference.png"))
    lines = ["| scene | mesh | eps | cut patches | pieces | links | elements | solve s | "
             "region L2 (non-emitters, per source patch) | MC stderr | image L1 | band mean abs e | band pixels |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        s = r["s"]
        e = error_values(os.path.join(r["dir"], "error.png"))
        band = bands[r["scene"]] & np.isfinite(e)
        bsp = s["error"]["by_source_patch"]
        r["band"] = float(np.nanmean(np.abs(e[band])))
        lines.append("| {} | {} | {:g} | {} | {} | {} | {} | {:.2f} | {:.4f} | {:.4f} | {:.4f} | {:.4f} | {} |".format(
            r["scene"], r["mesh"], r["eps"], r["d"].get("cut_patches", 0), r["d"].get("pieces", 0),
            s["counts"]["links"], s["counts"]["elements"], s["timings"]["solve_total"],
            bsp["l2_nonemitter_lum"], bsp.get("mc_stderr_l2_nonemitter_lum", float("nan")),
            s["error_map"]["l1"], r["band"], int(band.sum())))
    with open(args.out + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    # Figure: per scene, the path-traced reference and the two error maps at the smaller eps.
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(len(scenes), 3, figsize=(7.0, 2.4 * len(scenes)), squeeze=False)
    for i, sc in enumerate(scenes):
        pts = [r for r in rows if r["scene"] == sc]
        eps = min(r["eps"] for r in pts)
        off = next(r for r in pts if r["mesh"] == "off" and r["eps"] == eps)
        on = next(r for r in pts if r["mesh"] != "off" and r["eps"] == eps)
        axes[i][0].imshow(Image.open(os.path.join(off["dir"], "reference.png")))
        overlay = np.zeros(bands[sc].shape + (4,))
        overlay[bands[sc]] = (0.9, 0.62, 0.0, 0.45)  # Okabe-Ito orange, half transparent
        axes[i][0].imshow(overlay)
        axes[i][0].set_title(f"{sc}: path traced, band", fontsize=7)
        for j, r in ((1, off), (2, on)):
            axes[i][j].imshow(Image.open(os.path.join(r["dir"], "error_fc.png")))
            axes[i][j].set_title(f"mesh {r['mesh']}, eps {eps:g}: band |e| {r['band']:.3f}", fontsize=7)
    for a in axes.flat:
        a.set_xticks([])
        a.set_yticks([])
    fig.tight_layout()
    fig.savefig(args.out + ".png", dpi=110)


if __name__ == "__main__":
    main()
