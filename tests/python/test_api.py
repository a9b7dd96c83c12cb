"""The Python module through its public API (issue 62): the furnace's exact B,
arrays equal to the CLI's solution.hrsol and summary.json on Cornell, the
reference and its error, render, a results store into pandas, bad input
raised with its location, and a solve stopped by Ctrl-C (SIGINT)."""
import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import hrad

# The settings of the Cornell comparisons: a quick error-oracle solve.
CORNELL = {"hr.oracle": "error", "oracle.eps": 3e-3}


@pytest.mark.parametrize("basis,coefficients", [("constant", 0), ("linear", 2)])
def test_furnace_radiosity_is_exact(basis, coefficients):
    # Closed cube, rho = 0.5, E = 1 everywhere: B = E / (1 - rho) = 2 on every
    # leaf. A uniform mesh (every form factor sum is one; as in
    # tests/hr/basis_solver_test.cpp) for the constant and a linear basis.
    scene = hrad.load("furnace")
    assert scene.num_patches == 6
    np.testing.assert_allclose(scene.rho, 0.5)
    np.testing.assert_allclose(scene.E, 1.0)
    np.testing.assert_allclose(scene.area, 1.0)
    sol = hrad.solve(scene, {"hr.oracle": "uniform", "oracle.level": 2, "hr.tolerance": 1e-7,
                             "hr.max_iterations": 400, "cluster.model": "none",
                             "hr.basis": basis})
    assert sol.summary["converged"] is True
    assert sol.num_leaves == 6 * 16
    # 1e-5: the coupling coefficients of the polynomial bases are floats.
    np.testing.assert_allclose(sol.B, 2.0, rtol=1e-5)
    np.testing.assert_allclose(sol.patch_B, 2.0, rtol=1e-5)
    assert sol.coefficients.shape == (96, coefficients, 3)
    np.testing.assert_allclose(sol.coefficients, 0.0, atol=1e-5)
    assert sol.area.sum() == pytest.approx(6.0, rel=1e-12)
    np.testing.assert_array_equal(sol.level, 2)


def _cli_solve(hrad_cli, out, settings):
    sets = [a for k, v in settings.items() for a in ("--set", f"{k}={v}")]
    subprocess.run([hrad_cli, "solve", "cornell", "-o", str(out), "--no-images", "--no-ply",
                    "--no-progress", "--threads", "1", *sets], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(out / "summary.json") as f:
        return json.load(f)


def test_cornell_equals_the_cli(hrad_cli, tmp_path):
    cli = _cli_solve(hrad_cli, tmp_path, CORNELL)
    sol = hrad.solve("cornell", CORNELL)
    saved = hrad.read_solution(tmp_path / "solution.hrsol", sol.scene)
    # Leaf by leaf: the same keys on the same patches and the same radiosity,
    # bit for bit (the file stores the leaves' f64 means).
    assert saved.num_leaves == sol.num_leaves == cli["counts"]["leaves"]
    np.testing.assert_array_equal(saved.patch, sol.patch)
    np.testing.assert_array_equal(saved.key, sol.key)
    np.testing.assert_array_equal(saved.B, sol.B)
    np.testing.assert_array_equal(saved.patch_B, sol.patch_B)
    np.testing.assert_allclose(saved.corners, sol.corners, rtol=0, atol=0)
    # The leaves tile the root patches.
    np.testing.assert_allclose(np.bincount(sol.patch, weights=sol.area), sol.scene.area,
                               rtol=1e-9)
    # summary.json's fields, apart from what differs from run to run.
    assert set(cli) - {"artefacts"} == set(sol.summary) - {"artefacts"}
    ours, theirs = _steady(sol.summary), _steady(cli)
    # The CLI also reads its own keys (metrics.reference_level, ...).
    theirs["resolved_settings"] = {k: v for k, v in theirs["resolved_settings"].items()
                                   if k in ours["resolved_settings"]}
    for k in theirs:
        assert ours[k] == theirs[k], k


# Top-level fields of a summary that vary from run to run (when, where, how
# long, how much memory), and the same within any block.
VOLATILE = {"date", "host", "wall_seconds", "timings", "memory", "artefacts", "bytes_per_link"}


def _is_volatile(key):
    return (key.endswith("_s") or "seconds" in key or key in ("peak_rss", "element_bytes",
                                                              "link_bytes"))


def _steady(value, top=True):
    if isinstance(value, dict):
        return {k: _steady(v, False) for k, v in value.items()
                if not _is_volatile(k) and not (top and k in VOLATILE)}
    if isinstance(value, list):
        return [_steady(v, False) for v in value]
    return value


def test_save_and_read_back(tmp_path):
    sol = hrad.solve("cornell", CORNELL)
    sol.save(tmp_path / "s.hrsol")
    back = hrad.read_solution(tmp_path / "s.hrsol", "cornell")
    assert back.summary is None
    np.testing.assert_array_equal(back.B, sol.B)


def test_reference_error_and_render(cache_dir):
    scene = hrad.load("cornell")
    ref = hrad.reference(scene, {"fm.level": 2}, cache_dir=cache_dir)
    assert ref.summary["cached"] is False
    assert ref.num_leaves == 16 * scene.num_patches
    again = hrad.reference(scene, {"fm.level": 2}, cache_dir=cache_dir)
    assert again.summary["cached"] is True
    np.testing.assert_array_equal(again.B, ref.B)
    # hrad.error is the summary's error block: a solve with that reference
    # reports the same numbers.
    sol = hrad.solve(scene, CORNELL, reference={"kind": "full-matrix", "fm.level": 2},
                     cache_dir=cache_dir)
    err = hrad.error(sol, ref)
    for k, v in err.items():
        assert sol.summary["error"][k] == pytest.approx(v, rel=1e-12), k
    assert 0 < err["l2_lum"] < 0.5
    assert hrad.error(ref, ref)["l2_lum"] == 0.0
    # A full-matrix solve through the API is that reference.
    hrad.log_level("quiet")
    fm = hrad.solve(scene, solver="full-matrix", **{"fm.level": 2})
    hrad.log_level("info")
    assert fm.summary["solver"] == "full-matrix"
    assert hrad.error(fm, ref)["l2_lum"] < 1e-6
    image = hrad.render(sol, {"render.width": 40, "render.height": 30})
    assert image.shape == (30, 40, 3) and image.dtype == np.float64
    assert np.isfinite(image).all() and image.max() > 0
    with pytest.raises(hrad.Error, match="uniform field"):
        hrad.error(ref, sol)


def test_bad_input_names_its_location(tmp_path):
    line = sys._getframe().f_lineno + 2
    with pytest.raises(hrad.InputError) as e:
        hrad.solve("cornell", {"oracle.epz": 1e-3})
    assert f"{__file__}:{line}: error:" in str(e.value)
    assert "oracle.epz" in str(e.value)
    assert isinstance(e.value, ValueError)
    with pytest.raises(hrad.InputError, match="oracle.eps"):
        hrad.solve("cornell", {"oracle.eps": -1.0})
    # An error in a scene file names the file and its line.
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    with pytest.raises(hrad.InputError) as e:
        hrad.load(bad)
    assert f"{bad}:3" in str(e.value)


def test_store_into_pandas(hrad_cli, tmp_path):
    study = tmp_path / "tiny.toml"
    study.write_text("""
name = "tiny"
scenes = ["cornell"]
[solver]
"hr.oracle" = "error"
[sweep]
"oracle.eps" = [1e-2, 3e-3]
""")
    store = hrad.sweep(study, tmp_path / "tiny.sqlite", cache_dir=tmp_path / "cache")
    runs = store.runs
    assert len(runs) == 2 and len(store.failures) == 0
    assert sorted(runs["oracle.eps"]) == [3e-3, 1e-2]
    assert (runs["hr.oracle"] == "error").all()
    # Each run's iterations carry its settings; the row counts match the summaries.
    for _, run in runs.iterrows():
        its = store.iterations[store.iterations.run_key == run["key"]]
        assert len(its) == run["iterations"]
        assert (its["oracle.eps"] == run["oracle.eps"]).all()
    # The store's links for eps = 3e-3 are those of the same solve in Python.
    sol = hrad.solve("cornell", CORNELL)
    assert int(runs[runs["oracle.eps"] == 3e-3]["links"].iloc[0]) == sol.summary["counts"]["links"]
    # A bad study is refused before anything runs, at its file:line.
    bad = tmp_path / "bad.toml"
    bad.write_text(study.read_text().replace('"hr.oracle" = "error"', '"hr.oracle" = "error"\n"oracle.epz" = 1'))
    with pytest.raises(hrad.InputError, match=f"{bad}:.*oracle.epz"):
        hrad.sweep(bad, tmp_path / "bad.sqlite")
    assert not (tmp_path / "bad.sqlite").exists()
    # Not a store: hrad's check, with the file's name.
    (tmp_path / "no.sqlite").write_text("not a database")
    with pytest.raises(hrad.InputError, match="no.sqlite"):
        hrad.open_store(tmp_path / "no.sqlite")


def test_ctrl_c_stops_a_solve():
    # A solve of minutes (a fine eps on office:2; with clusters, since the
    # initial linking polls no stop request), interrupted after 0.5 s as
    # Ctrl-C would: SIGINT to this process. hr.max_seconds bounds the test's
    # cost should the interrupt not stop it.
    settings = {"hr.oracle": "error", "oracle.eps": 1e-5, "cluster.model": "oriented",
                "hr.max_seconds": 30}
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    t0 = time.monotonic()
    timer.start()
    # The timer thread runs only because the solve has released the GIL.
    with pytest.raises(KeyboardInterrupt):
        hrad.solve("office:2", settings)
    elapsed = time.monotonic() - t0
    timer.join()
    assert elapsed < 3, f"the solve stopped {elapsed:.1f} s after its start"
    # The module works on afterwards.
    assert hrad.solve("furnace", {"oracle.eps": 1e-2}).summary["converged"]


def test_help_points_to_the_settings():
    assert "hrad settings" in hrad.solve.__doc__
    text = hrad.settings_help("oracle.eps")
    assert "oracle.eps" in text


def test_a_shared_scene_file():
    # The real scenes beside the repository (../shared/scenes), when present.
    scenes = os.environ.get("HRAD_SCENES") or os.path.join(
        os.path.dirname(__file__), "..", "..", "..", "shared", "scenes")
    path = os.path.join(scenes, "cornell-box", "CornellBox-Original.obj")
    if not os.path.exists(path):
        pytest.skip(f"{path} absent")
    scene = hrad.load(path)
    assert scene.num_patches == len(scene.area) > 0
    assert scene.area.sum() == pytest.approx(scene.total_area, rel=1e-9)
    assert (scene.E.max(axis=1) > 0).any()
    np.testing.assert_allclose(np.linalg.norm(scene.normal, axis=1), 1.0, rtol=1e-9)


def test_on_iteration_sees_every_record_and_can_stop():
    seen = []
    sol = hrad.solve("cornell", CORNELL, on_iteration=seen.append)
    assert seen == sol.summary["history"] and len(seen) > 1

    class Enough(Exception):
        pass

    def stop_after_two(record):
        if record["iteration"] >= 2:
            raise Enough(record["links"])

    with pytest.raises(Enough):
        hrad.solve("cornell", {"hr.oracle": "error", "oracle.eps": 1e-4},
                   on_iteration=stop_after_two)
