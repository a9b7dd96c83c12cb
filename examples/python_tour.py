#!/usr/bin/env python3
"""A tour of hrad from Python: load the Cornell box, sweep the error oracle's
eps, plot the L2 error against the number of links, and render the finest
solution. Run by ctest (Python.ExampleTour, with --quick) so it stays working.

    PYTHONPATH=build/python /usr/bin/python3 examples/python_tour.py --out tour/

Without --out everything goes to a temporary folder that is removed at the end.
"""
import argparse
import pathlib
import tempfile

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt
import numpy as np

import hrad


def sweep_eps(scene, epsilons, reference, cache_dir):
    """One hr solve per eps; returns (links, L2 error, solution) per eps."""
    rows = []
    for eps in epsilons:
        sol = hrad.solve(scene, {"hr.oracle": "error", "oracle.eps": eps}, cache_dir=cache_dir)
        err = hrad.error(sol, reference)
        rows.append((sol.summary["counts"]["links"], err["l2_lum"], sol))
        print(f"eps {eps:g}: {rows[-1][0]} links, {sol.num_leaves} leaves, L2 {err['l2_lum']:.4f}")
    return rows


def plot_error(rows, epsilons, path):
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.loglog([r[0] for r in rows], [r[1] for r in rows], "o-")
    for (links, l2, _), eps in zip(rows, epsilons):
        ax.annotate(f"{eps:g}", (links, l2), fontsize=7)
    ax.set_xlabel("links")
    ax.set_ylabel("relative L2 error (luminance)")
    ax.set_title("Cornell box, error oracle")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def save_image(image, path):
    """Linear radiosity to an sRGB-ish PNG: exposure at the 99th percentile."""
    scale = np.percentile(image, 99)
    plt.imsave(path, np.clip(image / scale, 0, 1) ** (1 / 2.2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="folder for the plot and the image (default: temporary)")
    ap.add_argument("--quick", action="store_true", help="fewer eps, a coarser reference")
    args = ap.parse_args()
    epsilons = [1e-2, 3e-3] if args.quick else [3e-2, 1e-2, 3e-3, 1e-3, 3e-4]
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(args.out or tmp)
        out.mkdir(parents=True, exist_ok=True)
        cache = pathlib.Path(tmp) / "cache"  # the reference, cached for the tour only
        scene = hrad.load("cornell")
        print(scene, f"total area {scene.total_area:.4g}")
        reference = hrad.reference(scene, {"fm.level": 2 if args.quick else 4}, cache_dir=cache)
        rows = sweep_eps(scene, epsilons, reference, cache)
        plot_error(rows, epsilons, out / "error_vs_links.png")
        finest = rows[-1][2]
        size = {"render.width": 64, "render.height": 64} if args.quick else {}
        image = hrad.render(finest, size)
        save_image(image, out / "cornell.png")
        for name in ("error_vs_links.png", "cornell.png"):
            assert (out / name).stat().st_size > 0
            print(f"wrote {out / name}" if args.out else f"made {name}")
        # Finer eps, more links, less error: what the plot shows.
        assert rows[-1][0] > rows[0][0] and rows[-1][1] < rows[0][1]


if __name__ == "__main__":
    main()
