// `hrad solve`: one point through experiments::runPoint (the same code a sweep
// runs), writing summary.json, solution.ply and image.exr/png into the output
// folder.
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

}  // namespace

int runSolve(const SolveOptions& opt, Params& params) {
    experiments::PointSpec point;
    point.scene = opt.scene;
    point.sceneLabel = opt.scene;
    // --reference-level N (metrics.reference_level): a full-matrix reference at
    // uniform level N, sharing the fm.* settings with a full-matrix solve.
    int refLevel = [&] {
        Params::Scope scope(params, "hrad solve");
        return readReferenceLevel(params);
    }();
    if (refLevel >= 0) {
        point.reference.set("kind", std::string("full-matrix"), params.where("metrics.reference_level"));
        std::string solver =
            params.has("solver")
                ? params.getString("solver", "hr")  // documented in experiments/runner.cpp
                : "hr";
        for (const auto& [k, e] : params.entries())
            if (k.rfind("fm.", 0) == 0 && k != "fm.level" && k != "fm.max_area")
                point.reference.set(k, e.value, e.where);
        point.reference.set("fm.level", int64_t(refLevel), params.where("metrics.reference_level"));
        point.reference.set("fm.max_area", 0.0, params.where("metrics.reference_level"));
        // fm.* keys belong to the reference only when the solver does not read
        // them (an unknown solver is reported by runPoint, with the names).
        const experiments::SolverInfo* info = experiments::findSolver(solver);
        if (!(info && info->readsKey("fm.")))
            for (const auto& [k, e] : point.reference.entries())
                if (k.rfind("fm.", 0) == 0) params.erase(k);
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

    ensureOutputFolder(opt.outDir, "command line (-o)");
    fs::path out(opt.outDir);
    experiments::RunContext ctx;
    ctx.useCache = false;  // hrad solve computes its reference in memory
    ctx.progress = opt.progress;
    ctx.artefactDir = out;
    // Written after the solve and after the error: nothing computed so far is
    // lost if a later step fails.
    ctx.checkpoint = [&](const json& s) { writeJson(out / "summary.json", s); };
    // Ctrl-C or SIGTERM: the solver stops at its next safe point and what it
    // has is written, marked interrupted (core/interrupt.h); exit 128 + signal.
    catchInterrupts();
    json summary = experiments::runPoint(point, ctx);
    const int sig = interruptSignal();
    if (sig != 0) summary["interrupted"] = true;
    writeJson(out / "summary.json", summary);
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
