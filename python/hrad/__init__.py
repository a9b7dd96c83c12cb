"""hrad: hierarchical and clustered radiosity, from Python.

Thin over hrad's C++ (the code the `hrad` command line runs):

    import hrad
    scene = hrad.load("cornell")
    sol = hrad.solve(scene, {"hr.oracle": "error", "oracle.eps": 3e-4})
    sol.summary["counts"]["links"], sol.B, sol.patch_B
    ref = hrad.reference(scene, {"fm.level": 3})
    hrad.error(sol, ref)["l2_lum"]
    image = hrad.render(sol, {"render.width": 256, "render.height": 256})  # H x W x 3
    store = hrad.open_store("results/study.sqlite"); store.runs  # pandas

Settings are the keys of `hrad settings` (docs/settings.md), given as a dict
and/or keyword arguments (`**{"oracle.eps": 3e-4}`); an unknown key or a bad
value raises hrad.InputError naming the caller's file:line. Errors in input
files (scenes, studies) name that file's line. Long calls release the GIL;
Ctrl-C stops an hr solve (KeyboardInterrupt).
"""

import os
import sqlite3
import subprocess
import sys

from . import _hrad
from ._hrad import Error, InputError, Scene, Solution, log_level, settings_help

__all__ = ["load", "solve", "reference", "error", "render", "read_solution", "open_store",
           "sweep", "settings_help", "log_level", "Scene", "Solution", "Store", "Error", "InputError"]


def _caller():
    """The file and line of the user's call (the location an input error names)."""
    frame = sys._getframe(2)
    return frame.f_code.co_filename, frame.f_lineno


def _merge(settings, more):
    out = dict(settings or {})
    out.update(more)
    return out


def _scene(scene, where):
    return scene if isinstance(scene, Scene) else _hrad._load(os.fspath(scene), {}, *where)


def load(scene, settings=None, **more):
    """Loads a scene: a built-in name ("cornell", "furnace", "plates:...",
    "office:N") or a file of any supported format (OBJ, MGF, PLY, Mitsuba XML,
    glTF). `settings`: the loader's keys (obj.*, mgf.*, ply.*, validate, ...;
    `hrad settings` lists them). Returns an hrad.Scene with patch arrays.
    """
    return _hrad._load(os.fspath(scene), _merge(settings, more), *_caller())


def solve(scene, settings=None, *, solver=None, reference=None, history_error=False,
          on_iteration=None, progress=False, cache=True, cache_dir=None, **more):
    """Solves `scene` (an hrad.Scene, or what hrad.load takes) and returns an
    hrad.Solution: summary (the dict `hrad solve` writes as summary.json),
    per-leaf arrays (patch, key, level, corners, area, B, coefficients) and
    per-patch averages (patch_B).

    settings: every key of `hrad settings` (hr.*, oracle.*, cluster.*, ff.*,
      fm.*, pr.*, ...; print(hrad.settings_help("oracle."))), e.g.
      {"hr.oracle": "error", "oracle.eps": 3e-4}; keyword arguments add to it.
      The scene's loader settings (hrad.load) are passed on.
    solver: "hr" (the default), "full-matrix" or "progressive" (the `solver`
      key; None leaves it unset, as `hrad solve` without --solver).
    reference: a reference to compare with, e.g. {"kind": "full-matrix",
      "fm.level": 3}: the summary then has an "error" block (the CLI's metrics);
      history_error=True adds the L2 error after every iteration.
    cache, cache_dir: the reference cache (hrad reference's; default
      $HRAD_CACHE or ~/.cache/hrad).
    on_iteration: called with every history record as it is made (the dict
      of summary["history"][i]: iteration, links, residual, ...; hr and
      progressive); an exception it raises stops the solve and is raised.
    progress: progress bars on stderr (the log always goes there).

    The scene is loaded again from its spec by the solve (as `hrad solve`
    does), so the summary equals the CLI's. The GIL is released; Ctrl-C stops
    an hr solve with KeyboardInterrupt (full-matrix and progressive finish
    first). Bad settings raise hrad.InputError with the caller's file:line.
    """
    where = _caller()
    scene = _scene(scene, where)
    s = dict(scene.settings)
    s.update(_merge(settings, more))
    if solver is not None:
        s["solver"] = solver
    return _hrad._solve(scene, s, dict(reference or {}), history_error, on_iteration, progress,
                        cache, os.fspath(cache_dir or ""), *where)


def reference(scene, settings=None, *, kind="full-matrix", progress=False, cache=True,
              cache_dir=None, **more):
    """A reference solution of `scene`, as `hrad reference` computes it (and
    caches it): kind "full-matrix" (fm.* settings, e.g. {"fm.level": 3}) or
    "montecarlo" (mc.*). Returns an hrad.Solution whose summary describes the
    reference (cache file, stats, reflected power) and, for Monte Carlo,
    whose std_error holds the standard error per region.
    """
    where = _caller()
    scene = _scene(scene, where)
    ref = {"kind": kind}
    ref.update(_merge(settings, more))
    return _hrad._reference(scene, dict(scene.settings), ref, progress, cache,
                            os.fspath(cache_dir or ""), *where)


def error(solution, reference):
    """The error of `solution` against `reference` (an hrad.reference result or
    a full-matrix solve of the same scene): the dict of the summary's error
    block (l1_lum, l2_lum, linf_lum, l1_rgb, l2_rgb, linf_rgb, reflected,
    non-emitter, ... ; reference/metrics.h)."""
    return _hrad._error(solution, reference)


def render(solution, settings=None, **more):
    """Renders `solution` from the scene's camera (or render.camera) with the
    render.* settings (render.width, render.height, render.spp,
    render.reconstruction, ...): an H x W x 3 float64 array of linear
    radiosity, row 0 at the top (what `hrad render` writes to image.exr)."""
    return _hrad._render(solution, _merge(settings, more), *_caller())


def read_solution(path, scene):
    """Reads a solution.hrsol (written by `hrad solve` or Solution.save) on
    `scene` (an hrad.Scene or what hrad.load takes; the file's content hash
    must match it). Returns an hrad.Solution without summary."""
    return _hrad._read_solution(os.fspath(path), _scene(scene, _caller()))


class Store:
    """A results store (hrad sweep's SQLite file) as pandas DataFrames.

    runs: one row per finished point, the store's columns plus one column per
      resolved setting (the summary's resolved_settings: every key the run
      read, with the value it used; reference keys as "reference.KEY").
    iterations: one row per iteration of every run, with the run's settings.
    failures, studies: the store's tables as they are.
    """

    def __init__(self, path):
        import json
        import pandas as pd

        self.path = os.fspath(path)
        self.schema_version = _hrad._check_store(self.path)  # hrad's checks, InputError
        uri = "file:" + os.path.abspath(self.path) + "?mode=ro"
        with sqlite3.connect(uri, uri=True) as db:
            tables = {t: pd.read_sql_query(f"SELECT * FROM {t}", db)
                      for t in ("runs", "iterations", "failures", "studies")}
        runs = tables["runs"]
        settings = pd.DataFrame(
            [json.loads(s).get("resolved_settings", {}) if s else {} for s in runs["summary"]],
            index=runs.index)
        settings = settings[[c for c in settings.columns if c not in runs.columns]]
        self.runs = pd.concat([runs, settings], axis=1)
        per_run = self.runs[["key"] + list(settings.columns)].rename(columns={"key": "run_key"})
        self.iterations = tables["iterations"].merge(per_run, on="run_key", how="left")
        self.failures = tables["failures"]
        self.studies = tables["studies"]

    def __repr__(self):
        return f"<hrad.Store '{self.path}': {len(self.runs)} runs, {len(self.failures)} failures>"


def open_store(path):
    """Opens a results store read-only (hrad's checks first: hrad.InputError
    naming the file when it is not a valid store) as an hrad.Store of pandas
    DataFrames (runs, iterations, failures, studies)."""
    return Store(path)


def sweep(study, store=None, *, jobs=1, resume=False, retry_failed=False, progress=False,
          cache_dir=None, no_cache=False, extra_args=()):
    """Runs a study (TOML, docs in experiments/study.h) with `hrad sweep` and
    returns the store (hrad.open_store). The study is validated here first
    (hrad.InputError with the study's file:line); the sweep itself runs in a
    child process, the command line's, which forks a process per point.
    store: default <study folder>/results/<study name>.sqlite. Ctrl-C stops
    the sweep (finished points stay in the store; resume=True goes on)."""
    from ._build import HRAD_CLI

    study = os.fspath(study)
    _hrad._validate_study(study)
    cmd = [HRAD_CLI, "sweep", study, "--jobs", str(jobs)]
    if store is not None:
        cmd += ["--store", os.fspath(store)]
    if resume:
        cmd.append("--resume")
    if retry_failed:
        cmd.append("--retry-failed")
    if progress:
        cmd.append("--progress")
    if cache_dir is not None:
        cmd += ["--cache", os.fspath(cache_dir)]
    if no_cache:
        cmd.append("--no-cache")
    cmd += list(extra_args)
    run = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    sys.stderr.write(run.stderr)
    if run.returncode not in (0, 3):  # 3: some points failed (in store.failures)
        cls = InputError if run.returncode == 2 else Error
        raise cls(run.stderr.strip() or f"hrad sweep exited with {run.returncode}")
    path = [ln[len("store: "):] for ln in run.stdout.splitlines() if ln.startswith("store: ")]
    return open_store(path[-1] if path else store)
