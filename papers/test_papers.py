#!/usr/bin/python3
"""ctest Papers.TinyStudyFigures: runs a tiny study with hrad, draws every
hradplot figure from its store (SQLite and CSV export), and checks that the
files exist and are non-empty, that the plotted numbers are the store's (the
fitted slope in the legend equals a least-squares slope computed here from
the rows) and that a store lacking a column fails with a message naming it.

    /usr/bin/python3 papers/test_papers.py --hrad build/apps/hrad [--keep DIR]

Exit 0 = pass, 1 = fail, 77 = skipped (no matplotlib/numpy/pandas)."""
import argparse
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))

STUDY = """
name = "tiny"
scenes = [{ scene = "cornell", reference = { "fm.level" = 1 } }]
[solver]
"hr.oracle" = "bfa"
"cluster.model" = "none"
"hr.max_iterations" = 20
"render.width" = 64
"render.height" = 64
[reference]
kind = "full-matrix"
[outputs]
exr = true
error_map = true
history_error = true
[sweep]
"oracle.eps" = [1e-2, 3e-3, 1e-3]
"""

failures = []


def check(cond, msg):
    print(("ok   " if cond else "FAIL ") + msg)
    if not cond:
        failures.append(msg)


def plot(args, expect_rc=0):
    env = dict(os.environ, PYTHONPATH=HERE + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-m", "hradplot"] + args, env=env,
                       capture_output=True, text=True)
    if p.returncode != expect_rc:
        print(p.stdout, p.stderr)
    check(p.returncode == expect_rc, f"hradplot {' '.join(args[:1])} exit {p.returncode} (want {expect_rc})")
    return p


def nonempty(stem, exts=("pdf", "png", "json")):
    for e in exts:
        f = f"{stem}.{e}"
        ok = os.path.exists(f) and os.path.getsize(f) > 100
        if ok and e == "png":
            ok = open(f, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
        if ok and e == "pdf":
            ok = open(f, "rb").read(5) == b"%PDF-"
        check(ok, f"{os.path.basename(f)} exists, non-empty, right format")


def check_committed_stores():
    """The stores under papers/results and bench/results are committed: they
    name their study files and run files relative to themselves, never by a
    machine's absolute path, and the study files they name exist."""
    bad = []
    stores = 0
    for root in (os.path.join(HERE, "results"), os.path.join(HERE, "..", "bench", "results")):
        if not os.path.isdir(root):
            continue
        for name in sorted(os.listdir(root)):
            if not name.endswith(".sqlite"):
                continue
            stores += 1
            store = os.path.join(root, name)
            con = sqlite3.connect(f"file:{store}?mode=ro&immutable=1", uri=True)
            try:
                for (path,) in con.execute("select path from studies"):
                    if not path or os.path.isabs(path):
                        bad.append(f"{name}: study path {path!r} is not relative")
                    elif not os.path.exists(os.path.join(root, path)):
                        bad.append(f"{name}: study file {path} not found")
                for scene, summary in con.execute("select scene, summary from runs"):
                    if os.path.isabs(scene):
                        bad.append(f"{name}: scene {scene!r} is an absolute path")
                    arts = (json.loads(summary) if summary else {}).get("artefacts") or {}
                    bad += [f"{name}: artefact {k} {v!r} is an absolute path"
                            for k, v in arts.items() if isinstance(v, str) and os.path.isabs(v)]
            finally:
                con.close()
    check(not bad, f"{stores} committed stores name files relative to themselves: {bad[:5]}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hrad", required=True)
    ap.add_argument("--keep", help="work in this folder and keep it")
    a = ap.parse_args()
    try:
        import matplotlib  # noqa: F401
        import numpy as np
        import pandas  # noqa: F401
    except ImportError as e:
        print(f"SKIP: {sys.executable} lacks {e.name} (apt-get install python3-matplotlib python3-pandas)")
        return SKIP

    check_committed_stores()
    work = a.keep or tempfile.mkdtemp(prefix="hrad-papers-")
    os.makedirs(work, exist_ok=True)
    try:
        study = os.path.join(work, "tiny.toml")
        open(study, "w").write(STUDY)
        store = os.path.join(work, "tiny.sqlite")
        for f in (store, store + "-wal", store + "-shm"):
            if os.path.exists(f):
                os.remove(f)
        r = subprocess.run([a.hrad, "--log", "quiet", "sweep", study, "--store", store,
                            "--cache", os.path.join(work, "cache")], capture_output=True, text=True)
        check(r.returncode == 0, f"hrad sweep tiny study (exit {r.returncode}) {r.stderr[-500:]}")
        if r.returncode != 0:
            return 1
        con = sqlite3.connect(store)
        rows = con.execute("select elements, links, l2_lum, eps from runs order by eps").fetchall()
        con.close()
        check(len(rows) == 3, f"3 runs in the store (got {len(rows)})")

        out = os.path.join(work, "fig")
        plot(["scaling", "--store", store, "--out", out + "_scal", "--x", "elements", "--y", "links"])
        nonempty(out + "_scal")
        side = json.load(open(out + "_scal.json"))
        entry = side["panels"]["links"]["HR bfa"]
        x = np.log10([r[0] for r in rows])
        y = np.log10([r[1] for r in rows])
        slope = float(np.polyfit(x, y, 1)[0])
        check(abs(entry["slope"] - slope) < 1e-9, f"fitted slope {entry['slope']:.6f} == slope from rows {slope:.6f}")
        check(f"(slope {slope:.2f})" in entry["label"], f"legend '{entry['label']}' shows slope {slope:.2f}")

        plot(["error", "--store", store, "--out", out + "_err", "--x", "links"])
        nonempty(out + "_err")
        c = json.load(open(out + "_err.json"))["curves"]["HR bfa"]
        want = sorted((r[1], r[2]) for r in rows)
        check(list(zip(c["x"], c["y"])) == want, "error-vs-links curve is the store's (links, l2_lum)")
        plot(["error", "--store", store, "--out", out + "_mem", "--x", "peak_rss_mib"])
        nonempty(out + "_mem")
        # estimate: the store's (true error, estimate) pairs, and the ratio
        # range the side file states.
        plot(["estimate", "--store", store, "--out", out + "_est",
              "--y", "error_estimate,error_estimate_points"])
        nonempty(out + "_est")
        con = sqlite3.connect(store)
        est = con.execute("select l1_reflected_lum, error_estimate_points from runs "
                          "where l1_reflected_lum > 0 and error_estimate_points > 0").fetchall()
        con.close()
        panel = json.load(open(out + "_est.json"))["panels"]["error_estimate_points"]
        got = sorted(zip(panel["points"]["cornell"]["x"], panel["points"]["cornell"]["y"]))
        check(got == sorted(est) and len(est) == 3, "estimate figure holds the store's pairs")
        ratios = [b / a for a, b in est]
        check(abs(panel["ratio_min"] - min(ratios)) < 1e-12 and abs(panel["ratio_max"] - max(ratios)) < 1e-12,
              "estimate figure states the ratio range")
        # eps: the store's (eps, links) per scene / oracle, and with the full
        # matrix's noiseless reference the denoised L2 is the plain one.
        plot(["eps", "--store", store, "--out", out + "_eps", "--y", "links,l2_nonemitter_denoised"])
        nonempty(out + "_eps")
        side = json.load(open(out + "_eps.json"))["panels"]
        c = side["links"]["cornell / bfa"]
        check(list(zip(c["x"], c["y"])) == sorted((r[3], r[1]) for r in rows),
              "links-vs-eps curve is the store's (eps, links)")
        check(len(side["l2_nonemitter_denoised"]["cornell / bfa"]["y"]) == 3,
              "denoised non-emitter L2 present for a full-matrix reference")
        # solver_mib: the solver's memory counters without visibility and RSS.
        plot(["scaling", "--store", store, "--out", out + "_smem", "--x", "elements", "--y", "solver_mib"])
        side = json.load(open(out + "_smem.json"))["panels"]["solver_mib"]["HR bfa"]
        con = sqlite3.connect(store)
        want = []
        for el, b in con.execute("select elements, bytes from runs order by elements"):
            d = json.loads(b)
            want.append(sum(v for k, v in d.items()
                            if k != "visibility" and not k.startswith("peak_rss")) / 2**20)
        con.close()
        check("links" in json.loads(b) and all(w > 0 for w in want), "stores carry link and element bytes")
        check(np.allclose(side["y"], want, rtol=1e-12), f"solver_mib {side['y']} == counters {want}")
        plot(["convergence", "--store", store, "--out", out + "_conv"])
        nonempty(out + "_conv")
        conv = json.load(open(out + "_conv.json"))
        check(conv["panels"] == ["links", "l2_lum", "residual"], f"convergence panels {conv['panels']}")
        con = sqlite3.connect(store)
        final = dict(con.execute("select key, l2_lum from runs"))
        con.close()
        check(all(abs(r["l2_lum"][-1] - final[k]) < 1e-12 for k, r in conv["runs"].items()),
              "last per-iteration error == the run's error")
        plot(["images", "--store", store, "--out", out + "_img"])
        nonempty(out + "_img")
        grid = json.load(open(out + "_img.json"))
        check(len(grid["images"]) == 3, "image grid shows 3 renders")
        check(grid.get("reference_png") is not None and grid.get("error_range", 0) > 0,
              f"grid has the reference and an error scale ({grid.get('error_range')})")
        con = sqlite3.connect(store)
        summ = {k: json.loads(v) for k, v in con.execute("select key, summary from runs")}
        con.close()
        for im in grid["images"]:
            em = summ[im["key"]]["error_map"]
            # The data PNG holds what the run's summary describes (16-bit
            # quantisation: half a step of 2/65534, unless clipped at +-1).
            ok = im["pixels"] == em["pixels"] and (
                em["max_abs"] > 1 or abs(im["mean_abs_error"] - em["mean_abs"]) < 2e-5)
            check(ok, f"error map of {im['key'][:8]}: {im['pixels']} px, mean |e| "
                      f"{im['mean_abs_error']:.6f} == summary {em['mean_abs']:.6f}")
        plot(["images", "--store", store, "--out", out + "_img2", "--error-range", "0.2"])
        check(json.load(open(out + "_img2.json"))["error_range"] == 0.2, "--error-range sets the scale")
        # The documented encoding: 0 = no data, 1 -> -1, 32768 -> 0, 65535 -> +1.
        sys.path.insert(0, HERE)
        from hradplot.figures import read_error_map
        from PIL import Image
        enc = os.path.join(work, "enc.png")
        Image.fromarray(np.array([[0, 1, 32768, 65535]], dtype=np.uint16)).save(enc)
        e = read_error_map(enc)
        check(np.isnan(e[0, 0]) and np.allclose(e[0, 1:], [-1.0, 0.0, 1.0]),
              f"error.png decoding {e.tolist()}")
        tex = out + ".tex"
        plot(["table", "--store", store, "--out", tex, "--columns", "eps,links,l2_lum"])
        t = open(tex).read() if os.path.exists(tex) else ""
        check(r"\toprule" in t and r"\bottomrule" in t and t.count(r" \\") == 4, "booktabs table with 3 rows")
        # --fit: the exponent a of links ~ elements^a per group, as the rows give it.
        plot(["table", "--store", store, "--out", out + "_fit.tex", "--columns", "elements,links,capped",
              "--group", "clustering", "--fit", "links,elements"])
        fit = json.load(open(out + "_fit.json")) if os.path.exists(out + "_fit.json") else {}
        fa = fit.get("exponents", {}).get("bvh", {}).get("a")
        check(fa is not None and abs(fa - slope) < 1e-9, f"table --fit exponent {fa} == slope from rows {slope:.6f}")
        check(f"$a$ = {slope:.3f} (3 points)" in open(out + "_fit.tex").read(), "table --fit row")

        # CSV folder from `hrad results export` gives the same slope.
        csv = os.path.join(work, "csv")
        shutil.rmtree(csv, ignore_errors=True)
        r = subprocess.run([a.hrad, "results", "export", store, "--csv", csv], capture_output=True, text=True)
        check(r.returncode == 0, "hrad results export")
        plot(["scaling", "--store", csv, "--out", out + "_csv", "--x", "elements", "--y", "links"])
        e2 = json.load(open(out + "_csv.json"))["panels"]["links"]["HR bfa"]
        check(abs(e2["slope"] - slope) < 1e-9, "CSV store: same slope")

        # A store without l2_lum: exit 2, message names the column and file.
        bad = os.path.join(work, "bad.sqlite")
        shutil.copy(store, bad)
        con = sqlite3.connect(bad)
        con.execute("alter table runs drop column l2_lum")
        con.commit()
        con.close()
        p = plot(["error", "--store", bad, "--out", out + "_bad"], expect_rc=2)
        check("l2_lum" in p.stderr and bad in p.stderr, f"message names column and file: {p.stderr.strip()}")
        check(not os.path.exists(out + "_bad.pdf"), "no figure written for a bad store")
        p = plot(["error", "--store", os.path.join(work, "none.sqlite"), "--out", out + "_x"], expect_rc=2)
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} failure(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())


# pytest: the docs' layout (issue 58). `/usr/bin/python3 -m pytest papers/test_papers.py -q`
ROOT = os.path.dirname(HERE)
GENERATED = {os.path.join(ROOT, "docs", "settings.md")}  # written by the settings generator


def markdown_files():
    yield os.path.join(ROOT, "README.md")
    for d, _, names in os.walk(HERE):
        yield from (os.path.join(d, n) for n in sorted(names) if n.endswith(".md"))


def test_markdown_links_resolve():
    """Every relative link in README.md and papers/**/*.md names a file or
    folder that exists (docs/settings.md is generated elsewhere)."""
    import re
    bad = []
    for md in markdown_files():
        text = open(md, encoding="utf-8").read()
        text = re.sub(r"```.*?```", "", text, flags=re.S)
        for target in re.findall(r"\]\(<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\)", text):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            path = os.path.normpath(os.path.join(os.path.dirname(md), target.split("#")[0]))
            if path not in GENERATED and not os.path.exists(path):
                bad.append(f"{os.path.relpath(md, ROOT)}: {target}")
    assert not bad, bad


def test_index_names_every_study_and_page():
    """papers/README.md is the index: it names every study file of
    papers/studies/ and links every dated page of papers/notes/."""
    index = open(os.path.join(HERE, "README.md"), encoding="utf-8").read()
    studies = [n for n in os.listdir(os.path.join(HERE, "studies")) if n.endswith(".toml")]
    assert [n for n in studies if n not in index] == []
    notes = sorted(os.listdir(os.path.join(HERE, "notes")))
    assert notes and [n for n in notes if f"notes/{n}" not in index] == []
