"""One paper style: single-column figures, Okabe-Ito colours, PDF + PNG."""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# Okabe & Ito (2008), colour-blind safe; black last.
OKABE_ITO = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00",
             "#56B4E9", "#F0E442", "#000000"]
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]
COLUMN_WIDTH = 3.4  # inches

RC = {
    "figure.figsize": (COLUMN_WIDTH, 2.5),
    "figure.dpi": 150,
    "savefig.dpi": 200,
    "savefig.bbox": "tight",
    "savefig.pad_inches": 0.02,
    "font.size": 8,
    "axes.labelsize": 8,
    "axes.titlesize": 8,
    "legend.fontsize": 6.5,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "lines.linewidth": 1.2,
    "lines.markersize": 4,
    "axes.grid": True,
    "grid.linewidth": 0.4,
    "grid.alpha": 0.4,
    "axes.prop_cycle": matplotlib.cycler(color=OKABE_ITO),
    "legend.frameon": False,
    "pdf.fonttype": 42,  # TrueType in the PDF (editable, no Type 3)
    # Fixed metadata: the same data give the same bytes.
    "svg.hashsalt": "hrad",
}


def apply():
    plt.rcParams.update(RC)


def figure(height=2.5, width=COLUMN_WIDTH, **kw):
    apply()
    return plt.subplots(figsize=(width, height), **kw)


def style_for(i):
    return dict(color=OKABE_ITO[i % len(OKABE_ITO)], marker=MARKERS[i % len(MARKERS)])


def save(fig, stem):
    """Write stem.pdf and stem.png; returns both paths."""
    os.makedirs(os.path.dirname(os.path.abspath(stem)), exist_ok=True)
    out = []
    for ext, meta in (("pdf", {"CreationDate": None, "ModDate": None}), ("png", {"Software": None})):
        p = f"{stem}.{ext}"
        fig.savefig(p, metadata=meta)
        out.append(p)
    plt.close(fig)
    return out
