"""Command line: /usr/bin/python3 -m hradplot KIND --store STORE --out STEM [options]

KIND: error | scaling | eps | estimate | convergence | images | table
Exit status 2 (message on stderr) when the store is missing, unreadable or
lacks the columns a figure needs."""
import argparse
import sys

from . import figures
from .store import StoreError, load_store


def main(argv=None):
    p = argparse.ArgumentParser(prog="hradplot", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("kind", choices=["error", "scaling", "eps", "estimate", "convergence", "images", "table"])
    p.add_argument("--store", required=True, help="SQLite store or CSV folder (hrad results export)")
    p.add_argument("--out", required=True, help="output stem (figures: STEM.pdf/.png/.json) or .tex file")
    p.add_argument("--x", help="x column (error: compute_s; scaling: patches)")
    p.add_argument("--y", help="y column(s), comma-separated (error: l2_lum; scaling: links,compute_s)")
    p.add_argument("--group", default="method", help="group runs into curves by these columns (comma-separated)")
    p.add_argument("--columns", help="table: runs columns, comma-separated")
    p.add_argument("--sort", help="table: sort by these columns")
    p.add_argument("--caption")
    p.add_argument("--label")
    p.add_argument("--fit", help="table: Y,X: add the fitted exponent a of Y ~ X^a per --group "
                                 "(runs stopped by a limit left out)")
    p.add_argument("--where", help="pandas query selecting runs, e.g. \"solver == 'hr'\"")
    p.add_argument("--cols", type=int, default=3, help="images: grid columns")
    p.add_argument("--max-images", type=int, default=9, help="images: at most this many runs")
    p.add_argument("--width", type=float, help="images: figure width in inches (default: one column, 3.4)")
    p.add_argument("--error-range", type=float,
                   help="images: colour scale of the error maps, +-this relative error "
                        "(default: 95th percentile of |e|, rounded up)")
    a = p.parse_args(argv)
    group = a.group.split(",") if "," in a.group else a.group
    try:
        st = load_store(a.store)
        if a.where and a.kind in ("error", "scaling", "eps", "estimate"):
            st.runs = st.runs.query(a.where)
        if a.kind == "error":
            figures.error_vs(st, a.out, x=a.x or "compute_s", y=a.y or "l2_lum", group=group)
        elif a.kind == "scaling":
            figures.scaling(st, a.out, x=a.x or "patches",
                            ys=(a.y or "links,compute_s").split(","), group=group)
        elif a.kind == "eps":
            figures.eps_vs(st, a.out, ys=(a.y or "l2_nonemitter_lum,l1_reflected_lum").split(","),
                           group=group if a.group != "method" else ["scene_short", "oracle"])
        elif a.kind == "estimate":
            figures.estimate_vs(st, a.out, x=a.x or "l1_reflected_lum",
                                ys=(a.y or "error_estimate").split(","),
                                group=group if a.group != "method" else "scene_short")
        elif a.kind == "convergence":
            figures.convergence(st, a.out, where=a.where)
        elif a.kind == "images":
            figures.image_grid(st, a.out, cols=a.cols, max_images=a.max_images, where=a.where,
                               error_range=a.error_range, width=a.width)
        else:
            if not a.columns:
                p.error("table needs --columns")
            figures.latex_table(st, a.out, a.columns.split(","),
                                sort=a.sort.split(",") if a.sort else None,
                                caption=a.caption, label=a.label, where=a.where,
                                fit=tuple(a.fit.split(",")) if a.fit else None, group=group)
    except StoreError as e:
        print(f"hradplot: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
