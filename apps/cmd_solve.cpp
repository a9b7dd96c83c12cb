// `hrad solve`: one point through experiments::runPoint (the same code a sweep
// runs), writing summary.json, solution.ply and image.exr/png into the output
// folder. With --reference montecarlo (mc.* settings) or --reference-level N
// (a full-matrix reference) the summary's "error" block is a study row's,
// computed by the same runner code, and is printed.
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "core/interrupt.h"
#include "core/safe_file.h"
#include "experiments/runner.h"
#include "experiments/solvers.h"

namespace hrad::app {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

void writeJson(const fs::path& path, const json& j) { writeFileSafely(path, j.dump(2) + "\n"); }

/// The reference of `hrad solve`: --reference-level N (metrics.reference_level,
/// a full-matrix reference at uniform level N) or --reference KIND. The
/// reference's own keys (fm.*, mc.*) move from the solve's settings into the
/// point's reference settings, as a study's [reference] table holds them;
/// fm.* stay with the solve too when its solver reads them.
void moveReferenceKeys(experiments::PointSpec& point, Params& params, const std::string& kind,
                       const SourceLocation& where) {
    point.reference.set("kind", kind, where);
    const std::string prefix = kind == "montecarlo" ? "mc." : "fm.";
    for (const auto& [k, e] : params.entries())
        if (k.rfind(prefix, 0) == 0) point.reference.set(k, e.value, e.where);
    std::string solver = params.has("solver")
                             ? params.getString("solver", "hr")  // documented in experiments/runner.cpp
                             : "hr";
    // fm.* keys belong to the reference only when the solver does not read
    // them (an unknown solver is reported by runPoint, with the names).
    const experiments::SolverInfo* info = experiments::findSolver(solver);
    if (prefix == "mc." || !(info && info->readsKey("fm.")))
        for (const auto& [k, e] : point.reference.entries())
            if (k.rfind(prefix, 0) == 0) params.erase(k);
}

/// The folders of `dir` that do not exist yet, deepest first: what a failed
/// solve removes again when it wrote nothing into them.
std::vector<fs::path> missingFolders(const fs::path& dir) {
    std::vector<fs::path> out;
    std::error_code ec;
    for (fs::path p = fs::absolute(dir, ec).lexically_normal(); !p.empty() && !fs::exists(p, ec);
         p = p.parent_path()) {
        out.push_back(p);
        if (p == p.parent_path()) break;
    }
    return out;
}

/// Removes the folders this run created when they are still empty.
void removeIfEmpty(const std::vector<fs::path>& created) {
    std::error_code ec;
    for (const fs::path& p : created)
        if (!fs::is_directory(p, ec) || !fs::is_empty(p, ec) || !fs::remove(p, ec)) return;
}

/// The error block on stdout, whatever the log level: the numbers a user
/// asked for with --reference (summary.json "error" holds all of them).
void printError(const json& e) {
    if (!e.is_object()) return;
    fmt::print("error vs {}{}:\n", e.value("reference", std::string("reference")),
               e.value("reference_cached", false) ? " (cached)" : "");
    fmt::print("  reflected     L1 {:.4g}  L2 {:.4g}\n", e.value("l1_reflected_lum", 0.0),
               e.value("l2_reflected_lum", 0.0));
    fmt::print("  non-emitters  L1 {:.4g}  L2 {:.4g}  mean ratio {:.4f}\n",
               e.value("l1_nonemitter_lum", 0.0), e.value("l2_nonemitter_lum", 0.0),
               e.value("mean_ratio_nonemitter", 0.0));
    fmt::print("  all regions   L1 {:.4g}  L2 {:.4g}  Linf {:.4g}  ({} regions)\n",
               e.value("l1_lum", 0.0), e.value("l2_lum", 0.0), e.value("linf_lum", 0.0),
               e.value("regions", uint64_t(0)));
    if (e.contains("mc_stderr_l2_lum"))
        fmt::print("  the reference's own standard error (L2): {:.3g}, non-emitters {:.3g}\n",
                   e.value("mc_stderr_l2_lum", 0.0), e.value("mc_stderr_l2_nonemitter_lum", 0.0));
}

}  // namespace

int runSolve(const SolveOptions& opt, Params& params) {
    experiments::PointSpec point;
    point.scene = opt.scene;
    point.sceneLabel = opt.scene;
    int refLevel = [&] {
        Params::Scope scope(params, "hrad solve");
        return readReferenceLevel(params);
    }();
    const SourceLocation refWhere{"command line (--reference)", 0, 0};
    if (refLevel >= 0 && !opt.reference.empty() && opt.reference != "full-matrix")
        throwInputError(refWhere, "--reference {} contradicts --reference-level (a full-matrix "
                                  "reference at that level)", opt.reference);
    if (refLevel >= 0) {
        moveReferenceKeys(point, params, "full-matrix", params.where("metrics.reference_level"));
        point.reference.set("fm.level", int64_t(refLevel), params.where("metrics.reference_level"));
        point.reference.set("fm.max_area", 0.0, params.where("metrics.reference_level"));
    } else if (!opt.reference.empty()) {
        moveReferenceKeys(point, params, opt.reference, refWhere);
    }
    params.erase("metrics.reference_level");
    point.settings = params;
    point.outputs.exr = opt.writeImages;
    point.outputs.ply = opt.writePly;
    point.outputs.glb = opt.writeGlb;
    point.outputs.lightmap = opt.writeLightmap;
    point.outputs.errorMap = opt.errorMap;
    point.outputs.regions = opt.writeRegions;
    point.outputs.regionsWhere = SourceLocation{"command line (--regions)", 0, 0};
    point.outputs.solution = opt.writeSolution;
    point.outputs.errorMapWhere = SourceLocation{"command line (--error-map)", 0, 0};

    // The folder is made now (an unwritable -o fails before the solve) and
    // removed again if the run fails before writing into it (issue 63).
    const std::vector<fs::path> created = missingFolders(opt.outDir);
    ensureOutputFolder(opt.outDir, "command line (-o)");
    fs::path out(opt.outDir);
    experiments::RunContext ctx;
    // A Monte Carlo reference is cached as a sweep's are (reference/cache.h:
    // keyed by the scene's contents and the mc.* settings); a full-matrix
    // reference of `hrad solve` is computed in memory, as before.
    ctx.useCache = opt.reference == "montecarlo";
    ctx.cacheDir = opt.cacheDir;
    ctx.progress = opt.progress;
    ctx.artefactDir = out;
    // Written after the solve and after the error: nothing computed so far is
    // lost if a later step fails.
    ctx.checkpoint = [&](const json& s) { writeJson(out / "summary.json", s); };
    // Ctrl-C or SIGTERM: the solver stops at its next safe point and what it
    // has is written, marked interrupted (core/interrupt.h); exit 128 + signal.
    catchInterrupts();
    json summary;
    try {
        summary = experiments::runPoint(point, ctx);
    } catch (...) {
        removeIfEmpty(created);
        throw;
    }
    const int sig = interruptSignal();
    if (sig != 0) summary["interrupted"] = true;
    writeJson(out / "summary.json", summary);
    if (summary.contains("error")) printError(summary["error"]);
    fmt::print("wrote {}\n", (out / "summary.json").string());
    for (const auto& [k, v] : summary["artefacts"].items())
        fmt::print("wrote {}\n", v.get<std::string>());
    if (sig != 0) {
        fmt::print(stderr, "hrad: interrupted by signal {}: the outputs hold the solution so far "
                           "(summary.json: interrupted = true)\n", sig);
        return 128 + sig;
    }
    return 0;
}

}  // namespace hrad::app
