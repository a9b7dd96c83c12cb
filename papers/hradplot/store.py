"""Loading a results store (SQLite or CSV folder) into pandas DataFrames."""
import json
import os
import sqlite3

import numpy as np
import pandas as pd


class StoreError(Exception):
    """A store that cannot be read or lacks what a figure needs."""


class Store:
    """The tables of one store: runs, iterations, studies (DataFrames)."""

    def __init__(self, path, runs, iterations, studies):
        self.path = path
        self.runs = runs
        self.iterations = iterations
        self.studies = studies
        self.dir = path if os.path.isdir(path) else os.path.dirname(os.path.abspath(path))

    def require(self, table, columns, what):
        """Raise StoreError naming the missing columns and the file."""
        df = getattr(self, table)
        missing = [c for c in columns if c not in df.columns]
        if missing:
            raise StoreError(
                f"{self.path}: table '{table}' lacks column(s) {', '.join(missing)} "
                f"needed for {what}")
        return df

    def study_name(self, study_hash):
        if self.studies is not None and "hash" in self.studies.columns:
            m = self.studies[self.studies["hash"].astype(str) == str(study_hash)]
            if len(m):
                return str(m["name"].iloc[0])
        return str(study_hash)


def _read_sqlite(path):
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    except sqlite3.Error as e:
        raise StoreError(f"{path}: cannot open SQLite store: {e}") from e
    try:
        tables = {r[0] for r in con.execute("select name from sqlite_master where type='table'")}
        if "runs" not in tables:
            raise StoreError(f"{path}: not a results store (no table 'runs')")
        out = {}
        for t in ("runs", "iterations", "studies"):
            out[t] = pd.read_sql(f"select * from {t}", con) if t in tables else pd.DataFrame()
        return out
    except sqlite3.DatabaseError as e:
        raise StoreError(f"{path}: cannot read SQLite store: {e}") from e
    finally:
        con.close()


def _read_csv_dir(path):
    f = os.path.join(path, "runs.csv")
    if not os.path.exists(f):
        raise StoreError(f"{path}: not a results folder (no runs.csv)")
    out = {}
    for t in ("runs", "iterations", "studies"):
        p = os.path.join(path, t + ".csv")
        out[t] = pd.read_csv(p) if os.path.exists(p) else pd.DataFrame()
    return out


def _derive(runs):
    """Columns computed from others (only where their inputs exist)."""
    if "settings" in runs.columns:
        st = runs["settings"].map(lambda s: json.loads(s) if isinstance(s, str) and s else {})
        runs["cluster_model"] = st.map(lambda d: d.get("cluster.model", "")) if len(runs) else []
        runs["fm_level"] = st.map(lambda d: d.get("fm.level", np.nan)) if len(runs) else []
        runs["oracle_level"] = st.map(lambda d: d.get("oracle.level", np.nan)) if len(runs) else []
        runs["fm_solver"] = st.map(lambda d: d.get("fm.solver", "gauss-seidel")) if len(runs) else []
        runs["hemicube_res"] = st.map(lambda d: d.get("fm.ff.hemicube_res", np.nan)) if len(runs) else []
        runs["hemicube_points"] = (st.map(lambda d: d.get("fm.ff.hemicube_points", np.nan))
                                   if len(runs) else [])
        # Shooting / gathering steps when a study caps them (classics_steps).
        runs["steps"] = (st.map(lambda d: d.get("pr.max_shots", d.get("fm.max_iterations",
                                                                        d.get("hr.max_iterations", np.nan))))
                         if len(runs) else [])
        if "iterations" in runs.columns and len(runs):
            # A solver that converges before the cap stops there (Gauss-Seidel
            # reaching fm.tolerance): the steps it took, not the cap.
            runs["steps"] = np.fmin(runs["steps"].astype(float), runs["iterations"].astype(float))
        # Reconstruction of the image where a study sets it (classics_gather).
        runs["reconstruction"] = (st.map(lambda d: d.get("render.reconstruction", ""))
                                  if len(runs) else [])
        runs["gather_rays"] = (st.map(lambda d: d.get("render.gather_rays", np.nan))
                               if len(runs) else [])
        runs["pr_max_subdivision"] = (st.map(lambda d: d.get("pr.max_subdivision", 2))
                                      if len(runs) else [])
        # The cluster tree builder (cluster/tree.h; "bvh" when unset) and
        # whether face clusters sit below it (cluster.faces): the row sets of
        # the face_scaling study, as one label.
        runs["cluster_builder"] = (st.map(lambda d: d.get("cluster.builder", "bvh"))
                                   if len(runs) else [])
        # The polynomial basis of an hr solve (hr.basis; "constant" when
        # unset), with its number of functions n (1, 3, 6, 10) for sorting.
        runs["basis"] = st.map(lambda d: d.get("hr.basis", "constant")) if len(runs) else []
        runs["basis_n"] = (runs["basis"].map({"constant": 1, "linear": 3, "quadratic": 6,
                                              "cubic": 10}).astype(float) if len(runs) else [])

        def clustering(d):
            faces = d.get("cluster.faces", False)
            faces = faces if isinstance(faces, bool) else str(faces).lower() in ("true", "1")
            return d.get("cluster.builder", "bvh") + (" + face clusters" if faces else "")
        runs["clustering"] = st.map(clustering) if len(runs) else []

        def floor_variant(d):
            # The cluster validity rule of a run (cluster/link.h; defaults
            # separation 1.5, surface_separation 1, near open): the row sets
            # of the eps_scenes_floor study, as one label.
            faces = d.get("cluster.faces", False)
            faces = faces if isinstance(faces, bool) else str(faces).lower() in ("true", "1")
            return (f"sep {float(d.get('cluster.separation', 1.5)):g}, "
                    f"surf {float(d.get('cluster.surface_separation', 1.0)):g}, "
                    f"near {d.get('cluster.near', 'open')}" + (", faces" if faces else ""))
        runs["floor_variant"] = st.map(floor_variant) if len(runs) else []
    if "summary" in runs.columns and "patches" not in runs.columns:
        def patches(s):
            try:
                return json.loads(s)["scene_info"]["patches"]
            except (TypeError, ValueError, KeyError):
                return np.nan
        runs["patches"] = runs["summary"].map(patches).astype(float) if len(runs) else []
    if "summary" in runs.columns and len(runs):
        # Error families recorded in the summary (reference/metrics.h): the
        # reflected part and the non-emitting surfaces, the mean ratio of
        # the solution to the reference on them, and the solver's a
        # posteriori estimate. NaN where a run did not record them.
        def from_summary(path):
            def get(s):
                try:
                    v = json.loads(s)
                    for k in path:
                        v = v[k]
                    return float(v)
                except (TypeError, ValueError, KeyError):
                    return np.nan
            return get
        for col, path in (("l1_reflected_lum", ("error", "l1_reflected_lum")),
                          ("l2_reflected_lum", ("error", "l2_reflected_lum")),
                          ("l1_nonemitter_lum", ("error", "l1_nonemitter_lum")),
                          ("l2_nonemitter_lum", ("error", "l2_nonemitter_lum")),
                          ("mean_ratio_nonemitter", ("error", "mean_ratio_nonemitter")),
                          # The share of the reflected light on regions the
                          # reference has dark (issue 10, item 8).
                          ("dark_reflected_fraction", ("error", "dark_reflected_fraction")),
                          ("error_estimate", ("error_estimate",)),
                          ("error_estimate_leaves", ("error_estimate_leaves",)),
                          ("error_estimate_points", ("error_estimate_points",)),
                          # The solve's own ray noise (hr/noise.h).
                          ("noise_estimate", ("noise_estimate",)),
                          ("noise_l2_nonemitter", ("noise", "l2_nonemitter_direct")),
                          # The point's CPU seconds (user + system) from the
                          # sweep's wait4 (experiments/sweep.cpp), and the
                          # bytes per link all told (every memory counter of
                          # the run over its links; stores written before it
                          # existed give NaN).
                          ("cpu_s", ("cpu_s",)),
                          ("bytes_per_link", ("bytes_per_link", "all_told")),
                          ("error_map_l1", ("error_map", "l1"))):
            if col not in runs.columns:
                runs[col] = runs["summary"].map(from_summary(path)).astype(float)
    if "summary" in runs.columns and len(runs):
        # Which limit stopped the solve (hr.max_seconds, hr.max_links,
        # memory.budget_mb): "time", "links", "memory" or "" (none).
        def capped(s):
            try:
                v = json.loads(s)
            except (TypeError, ValueError):
                return ""
            return ",".join(name for key, name in (("time_limit_hit", "time"),
                                                    ("link_cap_hit", "links"),
                                                    ("memory_budget_hit", "memory"))
                            if v.get(key))
        runs["capped"] = runs["summary"].map(capped)

        # What eps was a fraction of (hr.eps_power, as the summary records
        # it; "emitted" for stores written before the summary named it).
        def eps_power(s):
            try:
                return str(json.loads(s)["eps_power"]["of"])
            except (TypeError, ValueError, KeyError):
                return "emitted"
        runs["eps_power"] = runs["summary"].map(eps_power)
    if "scene" in runs.columns and len(runs):
        # A file scene by its file name without folder and extension
        # ("../../../shared/scenes/renderpark-mgf/corridor.mgf" -> "corridor").
        runs["scene_short"] = runs["scene"].map(
            lambda s: os.path.splitext(os.path.basename(s))[0] if isinstance(s, str) and "/" in s else s)
    if "summary" in runs.columns and len(runs):
        # Non-emitter L2 with a Monte Carlo reference's own noise taken out in
        # quadrature, sqrt(L2^2 - se^2) (se: the reference's relative L2
        # standard error over the non-emitting regions); the plain L2 where
        # the reference has no noise (full matrix); NaN where L2 < 1.5 se:
        # there the reference's noise dominates and the difference of two
        # squares does not resolve the solve's own error (it is then only
        # known to be below about L2).
        def denoised(s):
            try:
                e = json.loads(s)["error"]
                l2 = float(e["l2_nonemitter_lum"])
            except (TypeError, ValueError, KeyError):
                return np.nan
            se = e.get("mc_stderr_l2_nonemitter_lum")
            if se is None:
                return l2
            if l2 < 1.5 * float(se):
                return np.nan
            return float(np.sqrt(l2 * l2 - float(se) ** 2))
        runs["l2_nonemitter_denoised"] = runs["summary"].map(denoised).astype(float)
    if "links" in runs.columns and "patches" in runs.columns and len(runs):
        runs["links_per_patch"] = runs["links"] / runs["patches"]
    if "wall_s" in runs.columns:
        # Solve time: the point's wall clock without reference, error and
        # render phases (which a sweep adds and a solver would not pay).
        sub = sum(runs[c].fillna(0) for c in ("reference_s", "error_s", "render_s")
                  if c in runs.columns)
        runs["compute_s"] = runs["wall_s"] - sub
    if "peak_rss" in runs.columns:
        runs["peak_rss_mib"] = runs["peak_rss"] / 2**20
    if "bytes" in runs.columns and len(runs):
        # The solver's own data (matrix; patches and elements; elements,
        # links and clusters), from its memory counters: without the
        # visibility structure and the process baseline that peak RSS holds.
        def solver_mib(s):
            try:
                b = json.loads(s)
            except (TypeError, ValueError):
                return np.nan
            return sum(v for k, v in b.items()
                       if k != "visibility" and not k.startswith("peak_rss")) / 2**20
        runs["solver_mib"] = runs["bytes"].map(solver_mib).astype(float)
    if {"solver", "oracle"} <= set(runs.columns):
        def method(r):
            if r["solver"] == "progressive":
                sub = r.get("pr_max_subdivision", 2)
                sub = 2 if sub is None or sub != sub else int(sub)  # unset (NaN): the default
                return "progressive refinement" + (" + substructuring" if sub > 0 else "")
            if r["solver"] == "full-matrix":
                # Progressive (Southwell) runs form their own curve.
                return ("progressive (Southwell)" if r.get("fm_solver", "") == "southwell"
                        else "full matrix")
            m = f"HR {r['oracle']}" if isinstance(r["oracle"], str) and r["oracle"] else "HR"
            cm = r.get("cluster_model", "")
            if isinstance(cm, str) and cm and cm != "auto":
                m += " + clusters" if cm != "none" else ""
                if cm not in ("none", "oriented"):
                    m += f" ({cm})"
            return m
        runs["method"] = runs.apply(method, axis=1) if len(runs) else []
    return runs


def load_store(path):
    if not os.path.exists(path):
        raise StoreError(f"{path}: no such store")
    t = _read_csv_dir(path) if os.path.isdir(path) else _read_sqlite(path)
    return Store(path, _derive(t["runs"]), t["iterations"], t["studies"])
