// The `hrad` command line. This is the only translation unit that includes
// CLI11 (slow to compile); it turns flags into Params (each remembering the
// flag it came from) and dispatches to apps/cmd_*.cpp.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "apps/commands.h"
#include "core/error.h"
#include "core/log.h"
#include "core/suggest.h"
#include "core/version.h"

using namespace hrad;

namespace {

/// --set key=value (repeatable) into params.
void addSets(Params& params, const std::vector<std::string>& sets) {
    for (const auto& kv : sets) {
        auto eq = kv.find('=');
        if (eq == std::string::npos || eq == 0)
            throwInputError({"command line", 0, 0}, "--set expects key=value, got '{}'", kv);
        params.setFromText(kv.substr(0, eq), kv.substr(eq + 1),
                           {"command line (--set " + kv.substr(0, eq) + ")", 0, 0});
    }
}

// ---- "did you mean": a better message than CLI11's for a malformed line --------
// CLI11 says "A subcommand is required" for `hrad solv cornell`, "The
// following arguments were not expected: 1e-3 --epz" for `--epz 1e-3`, and
// lists the arguments in reverse for `--width 64` before `solve`. On a parse
// error the arguments are walked again against the parser's own tables (its
// subcommands and options, never a typed list) to name what is wrong and the
// nearest known names (core/suggest.h).

bool looksLikeOption(const std::string& t) {
    if (t.size() < 2 || t[0] != '-') return false;
    return !(std::isdigit(static_cast<unsigned char>(t[1])) || t[1] == '.');  // -1, -.5
}

/// "hrad solve", "hrad results export" (the root's own name is argv[0]'s path).
std::string commandPath(const CLI::App* a) {
    std::string path;
    for (; a && a->get_parent(); a = a->get_parent())
        path = a->get_name() + (path.empty() ? "" : " " + path);
    return path.empty() ? "hrad" : "hrad " + path;
}

/// The option named `name` (--x or -x) of `a` or of the commands above it
/// (whose options fall through), or null.
const CLI::Option* findOption(const CLI::App* a, const std::string& name) {
    for (; a; a = a->get_parent())
        for (const CLI::Option* o : a->get_options({})) {
            if (!o->nonpositional()) continue;
            for (const auto& l : o->get_lnames())
                if ("--" + l == name) return o;
            for (const auto& sn : o->get_snames())
                if ("-" + sn == name) return o;
        }
    return nullptr;
}

std::vector<std::string> optionNames(const CLI::App* a) {
    std::vector<std::string> names;
    for (; a; a = a->get_parent())
        for (const CLI::Option* o : a->get_options({}))
            for (const auto& l : o->get_lnames()) names.push_back("--" + l);
    return names;
}

std::vector<std::string> subcommandNames(const CLI::App* a) {
    std::vector<std::string> names;
    for (const CLI::App* s : a->get_subcommands({})) names.push_back(s->get_name());
    return names;
}

/// The subcommands below `a` (at any depth) that have option `name`.
void optionOwners(const CLI::App* a, const std::string& name, std::vector<std::string>& owners) {
    for (const CLI::App* s : a->get_subcommands({})) {
        for (const CLI::Option* o : s->get_options({}))
            for (const auto& l : o->get_lnames())
                if ("--" + l == name) owners.push_back(commandPath(s));
        optionOwners(s, name, owners);
    }
}

/// "'a', 'b' and 'c'" (quote "`": `a` and `b`).
std::string joinNames(const std::vector<std::string>& names, const char* quote = "'") {
    std::string s;
    for (size_t i = 0; i < names.size(); ++i)
        s += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + std::string(quote) +
             names[i] + quote;
    return s;
}

/// An option that is not `cur`'s: one of a subcommand's written before it,
/// or a misspelling.
std::string unknownOption(const CLI::App* cur, const std::string& name) {
    std::vector<std::string> owners;
    if (cur->get_subcommands({}).size() > 0) optionOwners(cur, name, owners);
    if (!owners.empty())
        return fmt::format("'{}' is an option of {}: write it after the subcommand, e.g. `{} "
                           "SCENE {} ...`",
                           name, joinNames(owners, "`"), owners.front(), name);
    const std::string hint = didYouMean(nearestNames(name, optionNames(cur)));
    return fmt::format("unknown option '{}' for `{}`{}{} (see `{} --help`)", name,
                       commandPath(cur), hint.empty() ? "" : "; ", hint, commandPath(cur));
}

/// A value-taking option at args[i] without its value.
std::string missingValue(const CLI::App* cur, const CLI::Option* o, const std::string& name,
                         const std::vector<std::string>& args, size_t i) {
    if (o->get_type_size_max() <= 0 || o->get_items_expected_min() == 0) return "";
    if (i + 1 < args.size()) {
        const std::string& next = args[i + 1];
        const auto subs = subcommandNames(cur);
        const bool isCommand = std::find(subs.begin(), subs.end(), next) != subs.end();
        if (!looksLikeOption(next) && !isCommand) return "";
        return fmt::format("option '{}' needs a value ({}) before '{}'", name,
                           o->get_description(), next);
    }
    return fmt::format("option '{}' needs a value ({})", name, o->get_description());
}

/// What is wrong with the command line, or "" to let CLI11 say it.
std::string diagnose(CLI::App& app, const std::vector<std::string>& args) {
    const CLI::App* cur = &app;
    bool positionalSeen = false;  // of the current command
    for (size_t i = 0; i < args.size(); ++i) {
        const std::string& t = args[i];
        if (t == "--") break;
        if (looksLikeOption(t)) {
            const std::string name = t.substr(0, t.find('='));
            const CLI::Option* o = findOption(cur, name);
            if (!o) return unknownOption(cur, name);
            if (t.find('=') != std::string::npos) continue;
            std::string missing = missingValue(cur, o, name, args, i);
            if (!missing.empty()) return missing;
            if (o->get_type_size_max() > 0 && o->get_items_expected_min() > 0) ++i;  // its value
            continue;
        }
        const auto subs = cur->get_subcommands({});
        auto sub = std::find_if(subs.begin(), subs.end(),
                                [&](const CLI::App* s) { return s->get_name() == t; });
        if (sub != subs.end()) {
            cur = *sub;
            positionalSeen = false;
            continue;
        }
        if (!subs.empty() && !positionalSeen && cur->get_options([](const CLI::Option* o) {
                                                      return !o->nonpositional();
                                                  }).empty()) {
            const std::string hint = didYouMean(nearestNames(t, subcommandNames(cur)));
            return fmt::format("unknown command '{}'{}{} (the commands of `{}` are {})", t,
                               hint.empty() ? "" : "; ", hint, commandPath(cur),
                               joinNames(subcommandNames(cur), ""));
        }
        positionalSeen = true;
    }
    return "";
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"hrad: hierarchical and clustered radiosity"};
    app.require_subcommand(1);
    // Global options (--threads, --set, --log) may also follow the
    // subcommand, as users type them: `hrad solve cornell --threads 1`.
    // Subcommands created below inherit this.
    app.fallthrough();
    app.set_version_flag("--version", std::string(gitDescribe()));
    std::string logLevel = "info";
    app.add_option("--log", logLevel, "log level: quiet, info, debug")
        ->check(CLI::IsMember({"quiet", "info", "debug"}))
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    int threads = 0;
    app.add_option("--threads", threads, "worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
    std::vector<std::string> sets;
    app.add_option("--set", sets, "any setting as key=value (repeatable), e.g. ff.vis_rays=32");

    // info
    auto* info = app.add_subcommand("info", "print scene statistics");
    std::string infoScene;
    const std::string sceneHelp = "built-in name (" + app::registryHelp("builtin") +
                                  ", ...) or file (" + app::registryHelp("format") + ")";
    info->add_option("scene", infoScene, sceneHelp)->required();

    // solve
    auto* solve = app.add_subcommand("solve", "solve a scene and write images, PLY and summary");
    app::SolveOptions so;
    std::string solver, oracle;
    double eps = -1, minArea = -1;
    int refLevel = -1, width = 0, height = 0;
    bool interpolate = false, flat = false, noImages = false, noPly = false, quietProgress = false, errorMap = false;
    solve->add_option("scene", so.scene, sceneHelp)->required();
    solve->add_option("--solver", solver, "solver: " + app::registryHelp("solver"));
    solve->add_option("--oracle", oracle,
                      "refinement oracle (hr.oracle): " + app::registryHelp("oracle"));
    auto* epsOpt = solve->add_option("--eps", eps, "oracle threshold (oracle.eps)");
    auto* minAreaOpt = solve->add_option("--min-area", minArea, "minimum element area (hr.min_area)");
    double targetError = 0;
    auto* targetOpt = solve->add_option(
        "--target-error", targetError,
        "refine until the estimated error is at most this, e.g. 0.05 (hr.target_error; "
        "hr.target_metric: l2_nonemitter or l1_reflected)");
    std::string clusterModel, clusterBuilder;
    solve->add_option("--cluster", clusterModel,
                      "volume clustering (cluster.model): " + app::registryHelp("cluster"));
    solve->add_option("--cluster-builder", clusterBuilder,
                      "cluster tree builder (cluster.builder): " + app::registryHelp("builder"));
    bool faceClusters = false;
    solve->add_flag("--faces", faceClusters,
                    "face clusters of connected, nearly coplanar patches below the bvh "
                    "(cluster.faces; cluster.face_cone, face_planarity, face_separation)");
    solve->add_option("-o,--output", so.outDir, "output folder")->capture_default_str();
    auto* refLevelOpt = solve->add_option("--reference-level", refLevel,
                      "also solve a full-matrix reference at this uniform level and report the error");
    solve->add_option("--reference", so.reference,
                      "also compute a reference and report the error (summary.json \"error\", as "
                      "a study row): montecarlo (mc.* settings, cached as a sweep's) or "
                      "full-matrix (fm.*)")
        ->check(CLI::IsMember({"full-matrix", "montecarlo"}));
    solve->add_option("--cache", so.cacheDir,
                      "with --reference montecarlo: reference cache folder (default $HRAD_CACHE or "
                      "~/.cache/hrad)");
    solve->add_flag("--regions", so.writeRegions,
                    "with a reference: write regions.csv, the solution's average and the "
                    "reference on every reference element (reference/metrics.h)");
    solve->add_flag("--error-map", errorMap,
                    "with a reference: render the reference too and write reference.png, "
                    "error.png (16-bit signed relative error) and error_fc.png (false colour)");
    auto* widthOpt = solve->add_option("--width", width, "image width");
    auto* heightOpt = solve->add_option("--height", height, "image height");
    solve->add_flag("--interpolate", interpolate,
                    "smooth (C0 vertex) reconstruction in the image and exports (the default)");
    solve->add_flag("--flat", flat, "flat elements in the image and exports (render.interpolate = false)");
    solve->add_flag("--no-images", noImages, "do not render image.exr / image.png");
    solve->add_flag("--no-ply", noPly, "do not write solution.ply");
    solve->add_flag("--glb", so.writeGlb,
                    "also write solution.glb (glTF, vertex colours; smooth unless --flat)");
    std::string solveLightmapRes;
    auto* solveLightmapOpt = solve->add_option(
        "--lightmap", solveLightmapRes,
        "also bake lightmap.exr (linear), lightmap.png and lightmap.glb (TEXCOORD_1, unlit "
        "baked texture); RES: the atlas size (render.lightmap_size, default 1024)");
    solveLightmapOpt->expected(0, 1);
    bool noSolution = false;
    solve->add_flag("--no-solution", noSolution,
                    "do not write solution.hrsol (the solution for hrad render)");
    solve->add_flag("--no-progress", quietProgress, "no progress lines on stderr");

    // render
    auto* renderCmd = app.add_subcommand(
        "render", "render a saved solution (solution.hrsol) again: other camera, size, reconstruction");
    app::RenderCliOptions rco;
    int renderWidth = 0, renderHeight = 0;
    bool renderInterpolate = false, renderFlat = false;
    renderCmd->add_option("scene", rco.scene, "the scene the solution was computed on")->required();
    renderCmd->add_option("solution", rco.solution, "solution.hrsol written by hrad solve")->required();
    renderCmd->add_option("-o,--output", rco.outDir, "output folder")->capture_default_str();
    auto* rWidthOpt = renderCmd->add_option("--width", renderWidth, "image width");
    auto* rHeightOpt = renderCmd->add_option("--height", renderHeight, "image height");
    renderCmd->add_flag("--interpolate", renderInterpolate,
                        "smooth (C0 vertex) reconstruction (the default)");
    renderCmd->add_flag("--flat", renderFlat, "flat elements (render.interpolate = false)");
    std::string lightmapRes;
    auto* lightmapOpt = renderCmd->add_option(
        "--lightmap", lightmapRes,
        "also bake lightmap.exr (linear), lightmap.png and lightmap.glb (TEXCOORD_1, unlit "
        "baked texture); RES: the atlas size (render.lightmap_size, default 1024)");
    lightmapOpt->expected(0, 1);
    renderCmd->add_option("--compare", rco.compare,
                          "an image.exr of the same camera and size (e.g. a path-traced one): "
                          "write its mean absolute pixel error (linear) into render.json");
    renderCmd->add_flag("--glb", rco.writeGlb,
                        "also write solution.glb (glTF, vertex colours; smooth unless --flat)");

    // sweep
    auto* sweep = app.add_subcommand("sweep", "run a study (TOML) into a results store (SQLite)");
    app::SweepCliOptions sw;
    sweep->add_option("study", sw.study, "study file (see experiments/studies/README.md)")->required();
    sweep->add_option("--store", sw.store, "results store (default: <study dir>/results/<name>.sqlite)");
    sweep->add_option("-j,--jobs", sw.jobs, "points run at once (child processes)")->check(CLI::PositiveNumber);
    sweep->add_option("--shard", sw.shard, "run only points with index % N == i (i/N, 0 <= i < N)");
    sweep->add_flag("--resume", sw.resume, "continue into an existing store, skipping finished points");
    sweep->add_flag("--retry-failed", sw.retryFailed, "with --resume: rerun points recorded as failed");
    sweep->add_flag("--dry-run", sw.dryRun, "validate and print the expanded points, run nothing");
    sweep->add_option("--max-points", sw.maxPoints,
                      "refuse a study of more points (sweep.max_points; default: the study's "
                      "[limits] max_points, else 1000000)")
        ->check(CLI::PositiveNumber);
    sweep->add_option("--max-seconds", sw.maxSeconds, "wall-time limit per point (0: none)");
    sweep->add_option("--max-memory", sw.maxMemory, "address-space limit per point, e.g. 4G");
    sweep->add_option("--cache", sw.cacheDir, "reference cache folder (default $HRAD_CACHE or ~/.cache/hrad)");
    sweep->add_flag("--no-cache", sw.noCache, "compute references in every point, never cache");
    sweep->add_flag("--progress", sw.progress, "show the children's progress and logs");
    sweep->add_flag("--slurm", sw.slurm,
                    "write the Slurm pipeline (references, points array, merge) and submit it with "
                    "sbatch; with --dry-run only write it; with --resume only the missing points");
    sweep->add_option("--slurm-dir", sw.slurmDir, "folder of the Slurm pipeline (default <store>.slurm)");
    sweep->add_option("--slurm-set", sw.slurmSets, "KEY=VALUE over the study's [slurm] table (repeatable)");
    sweep->add_flag("--references-only", sw.referencesOnly,
                    "compute each distinct reference of the points once into the cache, run no point");
    sweep->add_option("--points-file", sw.pointsFile,
                      "run only the point indices listed in this file (--shard splits the list)");
    sweep->add_flag("--status", sw.status,
                    "report finished, failed and missing points of the store; exit 4 if any is "
                    "missing, 3 if any failed");
    sweep->add_option("--report", sw.report, "with --status: also write the report to this file");

    // results
    auto* results = app.add_subcommand("results", "results-store tools");
    results->require_subcommand(1);
    auto* rexport = results->add_subcommand("export", "write one CSV per table");
    std::string exportStore, exportDir;
    rexport->add_option("store", exportStore, "results store")->required();
    rexport->add_option("--csv", exportDir, "output folder")->required();
    auto* rmerge = results->add_subcommand("merge", "join shard stores without duplicates");
    std::string mergeOut;
    std::vector<std::string> mergeIn;
    rmerge->add_option("out", mergeOut, "store to create or extend")->required();
    rmerge->add_option("inputs", mergeIn, "shard stores")->required();
    bool mergeForce = false;
    rmerge->add_flag("--force", mergeForce, "merge rows of different study texts or hrad versions");

    // reference
    auto* refCmd = app.add_subcommand("reference", "compute (or find) a cached reference solution");
    app::ReferenceCliOptions ro;
    refCmd->add_option("scene", ro.scene, sceneHelp)->required();
    refCmd->add_option("--kind", ro.kind, "full-matrix | montecarlo")
        ->check(CLI::IsMember({"full-matrix", "montecarlo"}));
    refCmd->add_option("--cache", ro.cacheDir, "cache folder (default $HRAD_CACHE or ~/.cache/hrad)");
    bool refQuiet = false;
    refCmd->add_flag("--no-progress", refQuiet, "no progress lines on stderr");

    // settings
    auto* settingsCmd = app.add_subcommand(
        "settings", "list every setting: default, type, range, reader and meaning");
    app::SettingsCliOptions sto;
    settingsCmd->add_option("prefix", sto.prefix,
                            "only keys starting with this (e.g. hr. or cluster)");
    settingsCmd->add_flag("--markdown", sto.markdown, "as Markdown tables (docs/settings.md)");
    settingsCmd->add_flag("--readme", sto.readme, "the README's table of the main settings");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help/--version exit 0; every malformed command line is an input error: exit 2 (issue 16).
        if (e.get_exit_code() == 0) return app.exit(e);
        const std::string better = diagnose(app, std::vector<std::string>(argv + 1, argv + argc));
        if (better.empty()) return app.exit(e) == 0 ? 0 : 2;
        std::fprintf(stderr, "hrad: error: %s\n", better.c_str());
        return 2;
    }

    initLogging(logLevel);
    std::unique_ptr<tbb::global_control> threadLimit;
    if (threads > 0 && !*sweep)
        threadLimit = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, size_t(threads));

    try {
        Params params;
        addSets(params, sets);
        if (*info) return app::runInfo(infoScene, params);
        if (*solve) {
            auto flag = [&](const char* name) { return SourceLocation{std::string("command line (") + name + ")", 0, 0}; };
            if (!solver.empty()) params.set("solver", solver, flag("--solver"));
            if (!oracle.empty()) params.set("hr.oracle", oracle, flag("--oracle"));
            if (*epsOpt) params.set("oracle.eps", eps, flag("--eps"));
            if (*minAreaOpt) params.set("hr.min_area", minArea, flag("--min-area"));
            if (*targetOpt) params.set("hr.target_error", targetError, flag("--target-error"));
            if (!clusterModel.empty()) params.set("cluster.model", clusterModel, flag("--cluster"));
            if (!clusterBuilder.empty())
                params.set("cluster.builder", clusterBuilder, flag("--cluster-builder"));
            if (faceClusters) params.set("cluster.faces", true, flag("--faces"));
            if (*refLevelOpt) params.set("metrics.reference_level", int64_t(refLevel), flag("--reference-level"));
            if (*widthOpt) params.set("render.width", int64_t(width), flag("--width"));
            if (*heightOpt) params.set("render.height", int64_t(height), flag("--height"));
            if (interpolate && flat)
                throwInputError(flag("--flat"), "--flat contradicts --interpolate");
            if (interpolate) params.set("render.interpolate", true, flag("--interpolate"));
            if (flat) params.set("render.interpolate", false, flag("--flat"));
            so.writeLightmap = solveLightmapOpt->count() > 0;
            if (so.writeLightmap && !solveLightmapRes.empty())
                params.setFromText("render.lightmap_size", solveLightmapRes, flag("--lightmap"));
            so.threads = threads;
            so.writeImages = !noImages;
            so.writePly = !noPly;
            so.errorMap = errorMap;
            so.writeSolution = !noSolution;
            so.progress = !quietProgress;
            return app::runSolve(so, params);
        }
        if (*renderCmd) {
            auto flag = [&](const char* name) { return SourceLocation{std::string("command line (") + name + ")", 0, 0}; };
            if (*rWidthOpt) params.set("render.width", int64_t(renderWidth), flag("--width"));
            if (*rHeightOpt) params.set("render.height", int64_t(renderHeight), flag("--height"));
            if (renderInterpolate && renderFlat)
                throwInputError(flag("--flat"), "--flat contradicts --interpolate");
            if (renderInterpolate) params.set("render.interpolate", true, flag("--interpolate"));
            if (renderFlat) params.set("render.interpolate", false, flag("--flat"));
            rco.lightmap = lightmapOpt->count() > 0;
            if (rco.lightmap && !lightmapRes.empty())
                params.setFromText("render.lightmap_size", lightmapRes, flag("--lightmap"));
            return app::runRender(rco, params);
        }
        if (*sweep) {
            if (!sets.empty())
                throwInputError({"command line (--set)", 0, 0},
                                "hrad sweep takes its settings from the study file, not --set");
            sw.threads = threads;
            return app::runSweepCommand(sw);
        }
        if (*settingsCmd) return app::runSettings(sto);
        if (*rexport) return app::runResultsExport(exportStore, exportDir);
        if (*rmerge) return app::runResultsMerge(mergeOut, mergeIn, mergeForce);
        if (*refCmd) {
            ro.progress = !refQuiet;
            return app::runReference(ro, params);
        }
    } catch (const InputError& e) {
        std::fprintf(stderr, "hrad: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "hrad: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
