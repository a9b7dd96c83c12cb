"""The figures. Each takes a Store and an output stem (no extension), writes
stem.pdf + stem.png and a stem.json sidecar with the plotted numbers (for
tests and for quoting numbers in text), and returns the sidecar dict."""
import json
import math
import os

import numpy as np

from . import style
from .store import StoreError

LABELS = {
    "l2_lum": "relative $L_2$ error (luminance)",
    "l1_reflected_lum": "relative $L_1$ error of the reflected radiosity $B-E$",
    "l2_reflected_lum": "relative $L_2$ error of the reflected radiosity $B-E$",
    "l2_nonemitter_lum": "relative $L_2$ error over non-emitting surfaces",
    "error_estimate": "estimate: receivers' ranges",
    "error_estimate_leaves": "estimate: leaves' averages",
    "error_estimate_points": "estimate: leaves' points",
    "noise_estimate": "the solve's own ray noise (relative sd of the reflected power)",
    "noise_l2_nonemitter": "the solve's own ray noise per patch (direct, non-emitters)",
    "l1_lum": "relative $L_1$ error (luminance)",
    "linf_lum": r"relative $L_\infty$ error (luminance)",
    "l2_rgb": "relative $L_2$ error (RGB)",
    "wall_s": "wall time per point (s)",
    "compute_s": "solve time (s)",
    "cpu_s": "CPU time per point (s)",
    "bytes_per_link": "bytes per link, all told",
    "basis": "basis",
    "linking_s": "initial linking time (s)",
    "refine_s": "refinement time (s)",
    "peak_rss": "peak RSS (bytes)",
    "peak_rss_mib": "peak RSS (MiB)",
    "solver_mib": "solver data (MiB)",
    "links": "links",
    "elements": "elements",
    "leaves": "leaf elements",
    "patches": "input patches",
    "links_per_patch": "links per patch",
    "cluster_builder": "cluster builder",
    "capped": "stopped by",
    "residual": "residual (rel. unshot power)",
    "iteration": "iteration",
    "scene_short": "scene",
    "l2_nonemitter_denoised": "non-emitter $L_2$, reference noise removed",
    "eps_power": "eps of",
    "mean_ratio_nonemitter": "mean ratio to the reference, non-emitters",
    "dark_reflected_fraction": "reflected light on dark regions",
}

# Derived column -> the store columns it is computed from (store._derive).
SOURCES = {
    "compute_s": ["wall_s"],
    "peak_rss_mib": ["peak_rss"],
    "solver_mib": ["bytes"],
    "method": ["solver", "oracle", "settings"],
    "cluster_model": ["settings"],
    "basis": ["settings"],
    "basis_n": ["settings"],
    "cpu_s": ["summary"],
    "bytes_per_link": ["summary"],
    "fm_level": ["settings"],
    "oracle_level": ["settings"],
    "patches": ["summary"],
    "cluster_builder": ["settings"],
    "clustering": ["settings"],
    "capped": ["summary"],
    "eps_power": ["summary"],
    "dark_reflected_fraction": ["summary"],
    "links_per_patch": ["links", "summary"],
    "scene_short": ["scene"],
    "floor_variant": ["settings"],
    "l2_nonemitter_denoised": ["summary"],
}


def raw_columns(cols):
    out = []
    for c in cols:
        for r in SOURCES.get(c, [c]):
            if r not in out:
                out.append(r)
    return out


def _require_runs(store, cols, what):
    store.require("runs", raw_columns(cols), what)
    for c in cols:  # derived columns exist once their sources do
        if c not in store.runs.columns:
            raise StoreError(f"{store.path}: table 'runs' lacks column {c} needed for {what}")


def _rows(store, cols, what, groups=()):
    _require_runs(store, list(cols) + list(groups), what)
    df = store.runs.copy()
    num = list(cols)
    for c in num:
        df[c] = df[c].astype(float)
    df = df.dropna(subset=num)
    for c in num:
        df = df[df[c] > 0] if c != "iteration" else df
    if df.empty:
        raise StoreError(f"{store.path}: no runs with positive values of {', '.join(num)} "
                         f"for {what}")
    return df


def _logscale(ax, values, axis):
    v = np.asarray([x for x in values if x > 0], dtype=float)
    if len(v) and v.max() / v.min() >= 10:
        (ax.set_xscale if axis == "x" else ax.set_yscale)("log")


def pareto_front(x, y):
    """Indices of the points not dominated (smaller x and smaller y better),
    ordered by x."""
    order = sorted(range(len(x)), key=lambda i: (x[i], y[i]))
    front, best = [], math.inf
    for i in order:
        if y[i] < best:
            front.append(i)
            best = y[i]
    return front


def _groups(df, group):
    keys = group if isinstance(group, list) else [group]
    for k in keys:
        if k not in df.columns:
            raise StoreError(f"group column '{k}' not in runs")
    for name, g in df.groupby(keys if len(keys) > 1 else keys[0], sort=True, dropna=False):
        label = " / ".join(str(n) for n in (name if isinstance(name, tuple) else (name,)))
        yield label, g


def _sidecar(stem, data):
    with open(stem + ".json", "w") as f:
        json.dump(data, f, indent=1, sort_keys=True, default=float)
    return data


def error_vs(store, stem, x="compute_s", y="l2_lum", group="method"):
    """Error vs cost, one curve per method, Pareto front over all points."""
    gcols = group if isinstance(group, list) else [group]
    df = _rows(store, [x, y], f"error vs {x}", gcols)
    fig, ax = style.figure()
    side = {"x": x, "y": y, "curves": {}, "pareto": []}
    for i, (label, g) in enumerate(_groups(df, group)):
        g = g.sort_values(x)
        ax.plot(g[x], g[y], label=label, **style.style_for(i))
        side["curves"][label] = {"x": g[x].tolist(), "y": g[y].tolist()}
    xs, ys = df[x].tolist(), df[y].tolist()
    front = pareto_front(xs, ys)
    fx, fy = [xs[i] for i in front], [ys[i] for i in front]
    ax.step(fx, fy, where="post", color="0.3", lw=0.8, ls="--", zorder=1)
    ax.plot(fx, fy, ls="none", marker="o", ms=8, mfc="none", mec="0.3", mew=0.8,
            label="Pareto front", zorder=1)
    side["pareto"] = [{"x": a, "y": b} for a, b in zip(fx, fy)]
    _logscale(ax, xs, "x")
    _logscale(ax, ys, "y")
    ax.set_xlabel(LABELS.get(x, x))
    ax.set_ylabel(LABELS.get(y, y))
    ax.legend(loc="best")
    style.save(fig, stem)
    return _sidecar(stem, side)


def estimate_vs(store, stem, x="l1_reflected_lum", ys=("error_estimate",), group="scene_short"):
    """An a posteriori estimate against the true error: one panel per
    estimate in ys, one marker set per group, no lines between points (they
    are separate solves), the diagonal y = x solid and y = x / 3, 3 x dotted.
    The side file lists every point and, per panel, the range of y / x."""
    ys = list(ys)
    gcols = group if isinstance(group, list) else [group]
    df = _rows(store, [x] + ys, "estimate figure", gcols)
    df = df[df[x] > 0]
    fig, axes = style.figure(height=2.1 * len(ys) + 0.5, nrows=len(ys), sharex=True)
    axes = np.atleast_1d(axes)
    side = {"x": x, "panels": {}}
    lo, hi = float(df[x].min()), float(df[x].max())
    for ax, y in zip(axes, ys):
        d = df[df[y] > 0]
        panel = {"points": {}, "ratio_min": None, "ratio_max": None}
        for i, (label, g) in enumerate(_groups(d, group)):
            st = dict(style.style_for(i), ls="none")
            ax.plot(g[x], g[y], label=label, **st)
            panel["points"][label] = {"x": g[x].tolist(), "y": g[y].tolist()}
        if len(d):
            r = d[y] / d[x]
            panel["ratio_min"], panel["ratio_max"] = float(r.min()), float(r.max())
        t = np.geomspace(lo / 3, hi * 3, 8)
        ax.plot(t, t, color="0.3", lw=0.8, zorder=1)
        for f in (1 / 3, 3):
            ax.plot(t, f * t, color="0.3", lw=0.6, ls=":", zorder=1)
        values = d[x].tolist() + d[y].tolist() if len(d) else [lo, hi]
        _logscale(ax, values, "x")
        _logscale(ax, values, "y")
        ax.set_ylabel(LABELS.get(y, y))
        side["panels"][y] = panel
    axes[-1].set_xlabel(LABELS.get(x, x))
    axes[0].legend(loc="best")
    style.save(fig, stem)
    return _sidecar(stem, side)


def loglog_slope(x, y):
    """Least-squares slope of log10 y on log10 x."""
    lx, ly = np.log10(np.asarray(x, float)), np.log10(np.asarray(y, float))
    return float(np.polyfit(lx, ly, 1)[0])


def scaling(store, stem, x="patches", ys=("links", "compute_s"), group="method"):
    """ys vs input size on log-log axes, one panel per y, fitted slopes in
    the legends."""
    ys = list(ys)
    gcols = group if isinstance(group, list) else [group]
    df = _rows(store, [x] + ys, f"scaling vs {x}", gcols)
    # Runs that a limit stopped (hr.max_seconds, hr.max_links, memory budget;
    # column `capped`) are drawn hollow and left out of the fit: their counts
    # are the limit's, not the method's.
    capped = (df["capped"].fillna("") != "") if "capped" in df.columns else None
    fig, axes = style.figure(height=2.0 * len(ys), nrows=len(ys), sharex=True)
    axes = np.atleast_1d(axes)
    side = {"x": x, "panels": {}}
    for ax, y in zip(axes, ys):
        side["panels"][y] = {}
        for i, (label, g) in enumerate(_groups(df, group)):
            cut = None
            if capped is not None and capped.loc[g.index].any():
                cut = g[capped.loc[g.index]].groupby(x, as_index=False)[y].mean().sort_values(x)
                g = g[~capped.loc[g.index]]
                st = dict(style.style_for(i))
                st.update(ls="none", markerfacecolor="none")
                ax.plot(cut[x], cut[y], **st)
            g = g.groupby(x, as_index=False)[y].mean().sort_values(x)
            entry = {"x": g[x].tolist(), "y": g[y].tolist(), "slope": None}
            if cut is not None:
                entry["capped_x"], entry["capped_y"] = cut[x].tolist(), cut[y].tolist()
            lab = label
            if g[x].nunique() >= 2:
                entry["slope"] = loglog_slope(g[x], g[y])
                lab = f"{label} (slope {entry['slope']:.2f})"
                if cut is not None:
                    lab += f"; {len(cut)} capped, hollow"
                fx = np.array([g[x].min(), g[x].max()], float)
                c = np.polyfit(np.log10(g[x]), np.log10(g[y]), 1)
                ax.plot(fx, 10 ** np.polyval(c, np.log10(fx)), color=style.style_for(i)["color"],
                        lw=0.6, ls=":")
            entry["label"] = lab
            ax.plot(g[x], g[y], label=lab, **style.style_for(i))
            side["panels"][y][label] = entry
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylabel(LABELS.get(y, y))
        ax.legend(loc="upper left")
    axes[-1].set_xlabel(LABELS.get(x, x))
    style.save(fig, stem)
    return _sidecar(stem, side)


LINESTYLES = ["-", "--", ":", "-."]
SHORT = {"l2_nonemitter_lum": "non-emitter $L_2$ (rel.)",
         "l2_nonemitter_denoised": "non-emitter $L_2$, noise removed",
         "l1_reflected_lum": "$L_1$ of $B-E$ (rel.)",
         "cpu_s": "CPU s per point", "links": "links", "links_ss": "surface-surface links"}


def eps_vs(store, stem, ys=("l2_nonemitter_lum", "l1_reflected_lum"), group=("scene_short", "oracle")):
    """ys against the oracle's eps on log-log axes, one panel per y: colour
    and marker by the first group column (the scene), line style by the
    second (the oracle). Runs a limit stopped (column `capped`) are hollow.
    No fit and no Pareto front: eps is a setting, not a cost."""
    ys = list(ys)
    gcols = list(group) if isinstance(group, (list, tuple)) else [group]
    # Rows are filtered per panel: a run without a value of one y (e.g. a
    # noise-removed L2 the reference cannot resolve) still shows in the others.
    _require_runs(store, ys, "eps figure")
    df = _rows(store, ["eps"], "eps figure", gcols)
    for y in ys:
        df[y] = df[y].astype(float)
    first = sorted(df[gcols[0]].astype(str).unique(), key=lambda v: (
        df[df[gcols[0]].astype(str) == v]["patches"].min() if "patches" in df.columns else 0, v))
    second = sorted(df[gcols[1]].astype(str).unique()) if len(gcols) > 1 else [""]
    capped = (df["capped"].fillna("") != "") if "capped" in df.columns else None
    fig, axes = style.figure(height=2.1 * len(ys) + 0.5, nrows=len(ys), sharex=True)
    axes = np.atleast_1d(axes)
    side = {"x": "eps", "panels": {}}
    for ax, y in zip(axes, ys):
        side["panels"][y] = {}
        for i, a in enumerate(first):
            for j, b in enumerate(second):
                g = df[df[gcols[0]].astype(str) == a]
                if len(gcols) > 1:
                    g = g[g[gcols[1]].astype(str) == b]
                g = g.dropna(subset=[y])
                g = g[g[y] > 0].sort_values("eps")
                if g.empty:
                    continue
                st = dict(style.style_for(i), ls=LINESTYLES[j % len(LINESTYLES)])
                cap = capped.loc[g.index] if capped is not None else np.zeros(len(g), bool)
                ax.plot(g["eps"], g[y], **st)
                if np.any(cap):
                    ax.plot(g["eps"][cap], g[y][cap], ls="none", marker=st["marker"], color="white",
                            markeredgecolor=st["color"], zorder=3)
                label = f"{a} / {b}" if b else a
                side["panels"][y][label] = {"x": g["eps"].tolist(), "y": g[y].tolist(),
                                            "capped": [bool(c) for c in np.asarray(cap)]}
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylabel(SHORT.get(y, LABELS.get(y, y)))
    axes[0].invert_xaxis()  # tighter eps to the right
    axes[-1].set_xlabel(r"oracle threshold $\varepsilon$ (tighter to the right)")
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], **dict(style.style_for(i), ls="-")) for i in range(len(first))]
    labels = list(first)
    if len(second) > 1:
        handles += [Line2D([], [], color="0.3", ls=LINESTYLES[j % len(LINESTYLES)]) for j in range(len(second))]
        labels += list(second)
    ncol = min(4 if max(len(lb) for lb in labels) <= 12 else 2, len(labels))
    rows = -(-len(labels) // ncol)
    fig.tight_layout(rect=(0, (0.16 + 0.09 * rows) / (2.1 * len(ys) + 0.5), 1, 1))
    fig.legend(handles, labels, loc="lower center", ncol=ncol, bbox_to_anchor=(0.5, 0.0))
    style.save(fig, stem)
    return _sidecar(stem, side)


def _run_label(r):
    parts = [str(r.get("method", r.get("solver", "")))]
    if isinstance(r.get("eps"), (int, float)) and not math.isnan(r["eps"]):
        parts.append(f"eps={r['eps']:g}")
    for k, name in (("oracle_level", "level"), ("fm_level", "fm.level")):
        v = r.get(k)
        if isinstance(v, (int, float)) and not math.isnan(v):
            parts.append(f"{name}={int(v)}")
    if "scene" in r and isinstance(r["scene"], str):
        parts.insert(0, r["scene"])
    return " ".join(parts)


def convergence(store, stem, max_runs=8, where=None):
    """Per-iteration links, error and residual, one line per run. The error
    panel (L2 of luminance after every iteration) is drawn when the study
    recorded it ([outputs] history_error = true); otherwise links and
    residual only."""
    it = store.require("iterations", ["run_key", "iteration", "links", "residual"],
                       "the convergence plot")
    _require_runs(store, ["key", "method"], "the convergence plot")
    runs = store.runs
    if where is not None:
        runs = runs.query(where)
    runs = runs[runs["key"].isin(set(it["run_key"]))]
    if runs.empty:
        raise StoreError(f"{store.path}: no runs with iterations rows for the convergence plot")
    if len(runs) > max_runs:  # evenly spread over the store's order
        idx = np.linspace(0, len(runs) - 1, max_runs).round().astype(int)
        runs = runs.iloc[sorted(set(idx))]
    has_error = "l2_lum" in it.columns and it[it["run_key"].isin(set(runs["key"]))]["l2_lum"].notna().any()
    panels = ["links", "l2_lum", "residual"] if has_error else ["links", "residual"]
    fig, axes = style.figure(height=1.8 * len(panels), nrows=len(panels), sharex=True)
    side = {"panels": panels, "runs": {}}
    for i, (_, r) in enumerate(runs.iterrows()):
        g = it[it["run_key"] == r["key"]].sort_values("iteration")
        lab = _run_label(r)
        st = style.style_for(i)
        entry = {"label": lab, "iteration": g["iteration"].tolist()}
        for ax, col in zip(axes, panels):
            ax.plot(g["iteration"], g[col], label=lab if col == "links" else None, ms=2.5, **st)
            entry[col] = [None if (isinstance(v, float) and math.isnan(v)) else v
                          for v in g[col].tolist()]
        side["runs"][r["key"]] = entry
    _logscale(axes[0], it["links"].dropna(), "y")
    for ax, col in zip(axes, panels):
        if col != "links":
            ax.set_yscale("log")
        ax.set_ylabel(LABELS[col] if col != "l2_lum" else "$L_2$ error (lum.)")
    axes[-1].set_xlabel(LABELS["iteration"])
    # Below the last panel (the curves fill every panel's width).
    handles, labels = axes[0].get_legend_handles_labels()
    axes[-1].legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.32), ncol=2,
                    fontsize=5)
    style.save(fig, stem)
    return _sidecar(stem, side)


def run_images(store):
    """(row, {name: path}) for every run with an image.png under
    <store dir>/runs/<study name>/<key>/; the dict also holds "reference"
    (reference.png) and "error" (error.png, 16-bit data) when the study had
    [outputs] error_map = true."""
    _require_runs(store, ["key", "study"], "the image grid")
    out = []
    for _, r in store.runs.iterrows():
        d = os.path.join(store.dir, "runs", store.study_name(r["study"]), r["key"])
        files = {"image": os.path.join(d, "image.png")}
        if not os.path.exists(files["image"]):
            continue
        for name, f in (("reference", "reference.png"), ("error", "error.png")):
            if os.path.exists(os.path.join(d, f)):
                files[name] = os.path.join(d, f)
        out.append((r, files))
    return out


def read_error_map(path):
    """The signed relative luminance error of an hrad error.png (16-bit gray,
    render/error_map.h): 0 = no data (NaN), v in 1..65535 is
    e = 2 (v - 1) / 65534 - 1."""
    from PIL import Image
    with Image.open(path) as im:
        if im.mode not in ("I", "I;16", "I;16B"):
            raise StoreError(f"{path}: not an hrad error map (16-bit gray PNG), mode {im.mode}")
        v = np.asarray(im, dtype=np.float64)
    e = 2.0 * (v - 1.0) / 65534.0 - 1.0
    e[v == 0] = np.nan
    return e


def error_colormap():
    """The diverging map of hrad's error_fc.png: Okabe & Ito blue (too dark),
    white (exact), vermillion (too bright); no data in dark grey."""
    from matplotlib.colors import LinearSegmentedColormap
    cmap = LinearSegmentedColormap.from_list("hrad_error", ["#0072B2", "#FFFFFF", "#D55E00"])
    cmap.set_bad("#404040")
    return cmap


def _nice_ceiling(x):
    """Smallest of 1, 2, 5 x 10^k that is >= x (x > 0)."""
    k = math.floor(math.log10(x))
    for m in (1, 2, 5, 10):
        if m * 10 ** k >= x * (1 - 1e-9):
            return m * 10 ** k
    return 10 ** (k + 1)


def _caption(r):
    """Two short lines for a grid panel: the method, then its parameter and
    L2 error (narrow enough for 4 panels across one column)."""
    label = _run_label(r).replace(str(r.get("scene", "")) + " ", "", 1)
    method = str(r.get("method", r.get("solver", "")))
    params = label[len(method):].strip() if label.startswith(method) else label
    short = (method.replace(" + clusters", "+cl").replace("full matrix", "FM")
             .replace("progressive (Southwell)", "prog.")
             .replace("progressive refinement", "PR").replace(" + substructuring", "+sub"))
    rec = r.get("reconstruction")
    if isinstance(rec, str) and rec:
        short += ", " + rec
        rays = r.get("gather_rays")
        if rec == "final-gather" and isinstance(rays, (int, float)) and not math.isnan(rays):
            short += f" {int(rays)}"
    # The polynomial basis where the study sets it (bases_rooms): named in
    # place of the steps (the iterations to convergence there), and the
    # error over non-emitting surfaces beside the all-patch one.
    basis_set = isinstance(r.get("settings"), str) and '"hr.basis"' in r["settings"]
    steps = r.get("steps")
    if basis_set:
        short += ", " + str(r.get("basis", ""))
    elif isinstance(steps, (int, float)) and not math.isnan(steps):
        short += f", {int(steps)} steps"
    eps = r.get("eps")
    if isinstance(eps, (int, float)) and not math.isnan(eps) and eps > 0:
        # 0.0002 -> 2e-4: short enough for narrow panels
        mant, ex = f"{eps:.1e}".split("e")
        short_eps = f"{float(mant):g}e{int(ex)}"
        params = params.replace(f"eps={eps:g}", f"eps={short_eps}")
    line2 = params.replace("eps=", r"$\varepsilon$=").replace("fm.level=", "level ")
    if isinstance(r.get("l2_lum"), float) and not math.isnan(r["l2_lum"]):
        line2 += (", " if line2 else "") + f"$L_2$ {r['l2_lum']:.2g}"
        ne = r.get("l2_nonemitter_lum")
        if basis_set and isinstance(ne, float) and not math.isnan(ne):
            line2 += f" (n.e. {ne:.2g})"
    elif isinstance(r.get("error_map_l1"), float) and not math.isnan(r["error_map_l1"]):
        # no reference solution: the image L1 of the error map (e.g. against
        # a path-traced image, render.error_reference)
        line2 += (", " if line2 else "") + f"image $L_1$ {r['error_map_l1']:.2g}"
    return short + "\n" + line2


def image_grid(store, stem, cols=3, max_images=9, where=None, error_range=None, width=None):
    """Renders in a grid, each captioned with method, parameter and error.

    When the runs have error maps ([outputs] error_map = true), each run is a
    column pair of panels: its render above its false-colour error map (signed
    relative luminance error against the reference, one colour scale for the
    whole figure: +-error_range, default the 95th percentile of |e| over the
    maps shown, rounded up to 1, 2 or 5 x 10^k), with the reference render as
    the first column and one colour bar. The renders are hrad's PNGs, which
    share the reference's exposure when error maps were written."""
    import matplotlib.image as mpimg
    ims = run_images(store)
    if where is not None:
        keep = set(store.runs.query(where)["key"])
        ims = [(r, f) for r, f in ims if r["key"] in keep]
    if not ims:
        raise StoreError(f"{store.path}: no run images found under "
                         f"{os.path.join(store.dir, 'runs')} (study needs [outputs] exr = true)")
    ims = ims[:max_images]
    with_maps = all("error" in f for _, f in ims)
    if not with_maps:
        return _render_grid(store, stem, ims, cols, width)

    maps = [read_error_map(f["error"]) for _, f in ims]
    finite = np.concatenate([np.abs(m[np.isfinite(m)]) for m in maps])
    if error_range is None:
        p95 = float(np.percentile(finite, 95)) if finite.size else 0.0
        error_range = min(1.0, _nice_ceiling(p95)) if p95 > 0 else 0.01
    ncell = len(ims) + 1  # the reference first
    rows = math.ceil(ncell / cols)
    w = width or style.COLUMN_WIDTH
    fig, axes = style.figure(width=w, height=w / cols * rows * 2.25 + 0.35, nrows=2 * rows,
                             ncols=cols, squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    cmap = error_colormap()
    side = {"images": [], "error_range": error_range, "error": "signed relative luminance error",
            "reference_png": os.path.relpath(ims[0][1].get("reference", ""), store.dir)
            if "reference" in ims[0][1] else None}
    ref = ims[0][1].get("reference")
    if ref:
        axes[0][0].imshow(mpimg.imread(ref))
        axes[0][0].set_title("reference", fontsize=5, pad=2)
    im = None
    for i, ((r, f), e) in enumerate(zip(ims, maps), start=1):
        row, col = divmod(i, cols)
        top, bottom = axes[2 * row][col], axes[2 * row + 1][col]
        top.imshow(mpimg.imread(f["image"]))
        cap = _caption(r)
        top.set_title(cap, fontsize=5, pad=2)
        im = bottom.imshow(e, cmap=cmap, vmin=-error_range, vmax=error_range,
                           interpolation="nearest")
        fin = e[np.isfinite(e)]
        mean_abs = float(np.mean(np.abs(fin))) if fin.size else float("nan")
        bottom.set_title(f"mean $|e|$ {100 * mean_abs:.2g} %", fontsize=5, pad=2)
        side["images"].append({"key": r["key"], "caption": cap,
                               "png": os.path.relpath(f["image"], store.dir),
                               "error_png": os.path.relpath(f["error"], store.dir),
                               "pixels": int(fin.size), "mean_abs_error": mean_abs,
                               "p95_abs_error": float(np.percentile(np.abs(fin), 95)) if fin.size
                               else float("nan")})
    fig.subplots_adjust(wspace=0.04, hspace=0.25, bottom=0.09)
    cax = fig.add_axes([0.2, 0.035, 0.6, 0.018])
    cb = fig.colorbar(im, cax=cax, orientation="horizontal")
    cb.set_label("relative luminance error vs reference (%): blue too dark, orange too bright",
                 fontsize=5)
    cb.ax.tick_params(labelsize=5)
    ticks = np.linspace(-error_range, error_range, 5)
    cb.set_ticks(ticks)
    cb.set_ticklabels([f"{100 * t:+.3g}" if t else "0" for t in ticks])
    style.save(fig, stem)
    return _sidecar(stem, side)


def _render_grid(store, stem, ims, cols, width=None):
    """Renders only (runs without error maps)."""
    import matplotlib.image as mpimg
    rows = math.ceil(len(ims) / cols)
    w = width or style.COLUMN_WIDTH
    fig, axes = style.figure(width=w, height=w / cols * rows * 1.12, nrows=rows, ncols=cols,
                             squeeze=False)
    side = {"images": []}
    for ax in axes.flat:
        ax.axis("off")
    for ax, (r, f) in zip(axes.flat, ims):
        ax.imshow(mpimg.imread(f["image"]))
        cap = _caption(r)
        ax.set_title(cap, fontsize=5, pad=2)
        side["images"].append({"key": r["key"], "png": os.path.relpath(f["image"], store.dir),
                               "caption": cap})
    fig.subplots_adjust(wspace=0.04, hspace=0.3)
    style.save(fig, stem)
    return _sidecar(stem, side)


def _tex_escape(s):
    rep = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
           "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\^{}"}
    return "".join(rep.get(ch, ch) for ch in str(s))


def _fmt(v):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "--"
    if isinstance(v, (int, np.integer)):
        return f"{v:,}".replace(",", "\\,")
    if isinstance(v, (float, np.floating)):
        if float(v).is_integer() and abs(v) < 1e15:
            return _fmt(int(v))
        return f"{v:.3g}"
    return _tex_escape(v)


def fitted_exponents(df, x, y, group):
    """Least-squares a of y ~ x^a per group, over the rows no limit stopped
    (column `capped` empty, where present): {label: (a, points used, points
    left out)}; a is None with fewer than two points."""
    out = {}
    for label, g in _groups(df, group):
        ok = g[g["capped"].fillna("") == ""] if "capped" in g.columns else g
        ok = ok[(ok[x] > 0) & (ok[y] > 0)]
        a = loglog_slope(ok[x], ok[y]) if ok[x].nunique() >= 2 else None
        out[label] = (a, len(ok), len(g) - len(ok))
    return out


def latex_table(store, path, columns, sort=None, caption=None, label=None, where=None,
                fit=None, group="method"):
    """A booktabs table of the chosen runs columns. fit = (y, x): one more
    row per group with the fitted exponent a of y ~ x^a (fitted_exponents;
    points stopped by a limit left out), also written to PATH.json."""
    _require_runs(store, list(columns) + (list(fit) if fit else []), "the LaTeX table")
    df = store.runs
    if where is not None:
        df = df.query(where)
    if sort:
        df = df.sort_values(sort)
    num = [c for c in columns if np.issubdtype(df[c].dtype, np.number)]
    spec = "".join("r" if c in num else "l" for c in columns)
    lines = [r"% generated by hradplot from " + os.path.basename(store.path) + "; do not edit",
             r"\begin{table}", r"\centering"]
    if caption:
        lines.append(r"\caption{" + _tex_escape(caption) + "}")
    if label:
        lines.append(r"\label{" + label + "}")
    lines += [r"\begin{tabular}{" + spec + "}", r"\toprule",
              " & ".join(_tex_escape(LABELS.get(c, c)).replace(r"\$", "$").replace(r"\_", "_")
                         if c in LABELS else _tex_escape(c) for c in columns) + r" \\",
              r"\midrule"]
    for _, r in df.iterrows():
        lines.append(" & ".join(_fmt(r[c]) for c in columns) + r" \\")
    if fit:
        fy, fx = fit
        fits = fitted_exponents(df, fx, fy, group)
        lines.append(r"\midrule")
        for g, (a, n, left) in fits.items():
            txt = (f"{g}: {fy} $\\propto$ {fx}$^a$, $a$ = " + ("--" if a is None else f"{a:.3f}") +
                   f" ({n} points" + (f"; {left} stopped by a limit left out" if left else "") + ")")
            lines.append(r"\multicolumn{" + str(len(columns)) + "}{l}{" +
                         txt.replace("_", r"\_") + r"} \\")
        with open(os.path.splitext(path)[0] + ".json", "w") as f:
            json.dump({"fit": {"y": fy, "x": fx},
                       "exponents": {str(g): {"a": a, "points": n, "left_out": left}
                                     for g, (a, n, left) in fits.items()}}, f, indent=1)
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}", ""]
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write("\n".join(lines))
    return path
