#include "experiments/runner.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <optional>

#include "core/cpu_time.h"
#include "core/interrupt.h"
#include "core/memory.h"
#include "core/phase_progress.h"
#include "core/safe_file.h"
#include "core/timer.h"
#include "core/version.h"
#include "experiments/settings_reference.h"
#include "experiments/solvers.h"
#include "reference/cache.h"
#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "reference/montecarlo.h"
#include "render/camera.h"
#include "render/error_map.h"
#include "render/gltf_export.h"
#include "render/image.h"
#include "render/lightmap.h"
#include "render/ply_export.h"
#include "render/render.h"
#include "render/residual.h"
#include "experiments/estimate_report.h"
#include "experiments/target_error.h"
#include "scene/loader.h"
#include "transport/reachability.h"
#include "transport/visibility.h"

namespace hrad::experiments {

namespace fs = std::filesystem;
using nlohmann::json;

std::string buildType() { return HRAD_BUILD_TYPE; }
std::string codeVersion() { return gitDescribe(); }

std::string hostName() {
    char buf[256] = {};
    if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
    return buf;
}

std::string isoDateUtc() {
    std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

namespace {

json rgbJson(const RGB& c) { return json::array({c.r, c.g, c.b}); }

/// The tone map every output used; clipped: share of the image's pixels that
/// clip (< 0: no image was rendered).
json toneJson(const render::ToneMap& t, double clipped) {
    json j{{"exposure", t.exposure}, {"curve", t.curveName()}};
    if (t.curve == render::ToneCurve::Reinhard) j["white"] = t.white;
    if (clipped >= 0) j["clipped_share"] = clipped;
    return j;
}

json paramsJson(const Params& p) {
    json j = json::object();
    for (const auto& entry : p.entries())  // no structured binding: clang 14 cannot capture one
        std::visit([&](const auto& v) { j[entry.first] = v; }, entry.second.value);
    return j;
}

}  // namespace

json errorMetricsJson(const reference::ErrorMetrics& m) {
    return json{{"l1_lum", m.l1Lum},
                {"l2_lum", m.l2Lum},
                {"linf_lum", m.linfLum},
                {"l1_rgb", m.l1Rgb},
                {"l2_rgb", m.l2Rgb},
                {"linf_rgb", m.linfRgb},
                {"l1_reflected_lum", m.l1ReflLum},
                {"l2_reflected_lum", m.l2ReflLum},
                {"l1_nonemitter_lum", m.l1NonEmitLum},
                {"l2_nonemitter_lum", m.l2NonEmitLum},
                {"mean_ratio_nonemitter", m.meanRatioNonEmit},
                {"dark_reflected_fraction", m.darkReflectedFraction},
                {"dark_regions", m.darkRegions},
                {"regions", m.regions}};
}

namespace {

/// Every setting of a point, read once and validated (shared by validatePoint
/// and runPoint so that a dry run checks exactly what a run reads).
struct Resolved {
    std::string solver;
    std::shared_ptr<const Solver> solverImpl;  ///< from the registry (experiments/solvers.h)
    render::RenderSettings render;
    render::ToneSettings tone;  // render.exposure, tone_curve, key, max_clipped
    render::LightmapSettings lightmap;  // render.lightmap_size, _density, _gutter
    double errorFloor = 0.01, errorRange = 0.25;       // render.error_floor, render.error_range
    bool errorOnRegions = true;                        // render.error_mode = regions | pixels
    std::optional<render::ResidualSettings> residual;  // metrics.residual = true
    std::optional<reference::ErrorEstimateSettings> estimate;  // metrics.error_estimate
    std::optional<TargetSettings> target;                      // hr.target_error
    // render.error_reference = path-traced: the error map compares the
    // solution's image with a path-traced image of the same camera
    // (render.reference_spp samples per pixel) instead of the reference
    // solution's image: the pixel reference for final gather (issue 14).
    bool errorVsPathTraced = false;
    int pathTracedSpp = 256;
    SourceLocation pathTracedWhere;

    std::string refKind = "none";
    std::optional<reference::FullMatrixSettings> refFm;
    std::optional<reference::MonteCarloSettings> refMc;
};

/// The path-traced reference image costs width x height x reference_spp
/// samples; checked when the settings are read and again once the scene's
/// film has set the image size (RenderSettings::adoptFilm).
void checkPathTracedBudget(const Resolved& r) {
    if (!r.errorVsPathTraced) return;
    int64_t samples = int64_t(r.render.width) * r.render.height * r.pathTracedSpp;
    if (samples > r.render.maxSamples)
        throwInputError(r.pathTracedWhere,
                        "path-traced reference: {}x{} pixels x {} spp = {} samples, more than "
                        "render.max_samples = {}",
                        r.render.width, r.render.height, r.pathTracedSpp, samples,
                        r.render.maxSamples);
}

Resolved resolve(const PointSpec& p) {
    Resolved r;
    const Params& s = p.settings;
    Params::Scope scope(s, "experiments");
    r.solver =
        s.getString({"solver", "solver: hr (hierarchical), full-matrix, or progressive"}, "hr");
    r.solverImpl = createSolver(r.solver, s, s.where("solver"));
    r.render = render::RenderSettings::fromParams(s, "render");
    r.tone = render::ToneSettings::fromParams(s, "render");
    r.lightmap = render::LightmapSettings::fromParams(s, "render");
    r.errorFloor =
        s.getDouble({"render.error_floor", "error maps: luminance floor as a fraction of the mean"},
                    0.01, 1e-9, 1.0);
    r.errorRange = s.getDouble(
        {"render.error_range", "error maps: relative error at the top of the false-colour range"},
        0.25, 1e-6, 1.0);
    r.errorOnRegions =
        s.getEnum({"render.error_mode", "error maps per region of the reference, or per pixel"},
                  "regions", {"regions", "pixels"}) == "regions";
    if (s.getBool({"metrics.residual",
                   "compute the transport residual of the solution (render/residual.h)"},
                  false))
        r.residual = render::ResidualSettings::fromParams(s);
    r.estimate = estimateSettings(s);
    r.target = TargetSettings::fromParams(s);
    if (r.target && r.solver != "hr")
        throwInputError(s.where("hr.target_error"),
                        "hr.target_error needs the hr solver (solver = \"{}\")", r.solver);
    if (r.target && !r.estimate)
        throwInputError(s.where("hr.target_error"),
                        "hr.target_error needs the error estimate (metrics.error_estimate = "
                        "true)");
    r.errorVsPathTraced =
        s.getEnum({"render.error_reference",
                   "error maps against the reference solution's image, or a path-traced image"},
                  "solution", {"solution", "path-traced"}) == "path-traced";
    if (r.errorVsPathTraced) {
        if (s.has("render.error_mode") && r.errorOnRegions)
            throwInputError(s.where("render.error_mode"),
                            "render.error_mode = \"regions\" needs a reference solution; with "
                            "render.error_reference = \"path-traced\" the error is per pixel");
        r.errorOnRegions = false;
        r.pathTracedSpp =
            int(s.getInt({"render.reference_spp", "path-traced reference image: samples per pixel"},
                         256, 1, 65536));
        r.pathTracedWhere = s.where("render.reference_spp");
        checkPathTracedBudget(r);
    }

    const Params& ref = p.reference;
    Params::Scope refScope(ref, "reference");
    r.refKind = ref.getEnum({"kind", "reference: none, full-matrix or montecarlo"}, "none",
                            {"none", "full-matrix", "montecarlo"});
    if (p.outputs.errorMap && r.refKind == "none" && !r.errorVsPathTraced)
        throw InputError(
            p.outputs.errorMapWhere,
            "an error map needs a reference ([reference] kind = \"full-matrix\" or "
            "\"montecarlo\"; hrad solve: --reference-level; or render.error_reference = "
            "\"path-traced\")");
    if (p.outputs.regions && r.refKind == "none")
        throw InputError(p.outputs.regionsWhere,
                         "regions.csv needs a reference ([reference] kind = \"full-matrix\" or "
                         "\"montecarlo\"; hrad solve: --reference-level)");
    if (r.refKind == "full-matrix") r.refFm = reference::FullMatrixSettings::fromParams(ref, "fm");
    if (r.refKind == "montecarlo") r.refMc = reference::MonteCarloSettings::fromParams(ref, "mc");
    ref.reportUnused();
    return r;
}

/// Reads the loader's keys without loading anything: loadScene reads every
/// key before it looks at the spec, and a spec with an unknown extension is
/// then rejected with the spec as its location, which we recognise.
void probeLoaderKeys(const Params& params) {
    static const char* kProbe = "<hrad settings probe>.none";
    try {
        scene::loadScene(kProbe, params);
    } catch (const InputError& e) {
        if (e.where().file != kProbe) throw;
    }
}

/// A solve or reference needs a sound scene whatever `validate` says: with
/// validate = false a scene without faces, with NaN reflectance or without an
/// emitter loaded, and the solve then exited 0 with an empty, NaN or all-zero
/// solution. `validate = false` skips the checks at loading only (hrad info).
void requireSolvable(const scene::Scene& sc, const Params& settings) {
    if (settings.getBool("validate", true))  // documented where scene/loader.cpp reads it
        return;  // loadScene has checked
    try {
        sc.validate();
    } catch (const InputError& e) {
        throw InputError(e.where(), e.message() +
                                        " (validate = false skips this check when loading, "
                                        "but a solve or reference needs it)");
    }
}

/// The loader's warnings on the log, one line per distinct warning with its
/// count (core/warning_log.h); a long list is cut, `hrad info` shows it whole.
void logLoadWarnings(const scene::Scene& sc) {
    constexpr size_t kShown = 20;
    const WarningLog& w = sc.stats.warnings;
    for (size_t i = 0; i < w.size() && i < kShown; ++i) spdlog::warn("{}", w[i]);
    if (w.size() > kShown)
        spdlog::warn("... {} more kinds of loader warning ({} in all); `hrad info {}` lists them",
                     w.size() - kShown, w.total(), sc.name);
}

std::string referenceDescription(const Resolved& r) {
    if (r.refFm) return "full-matrix " + r.refFm->describe();
    if (r.refMc) return "montecarlo " + r.refMc->describe();
    return "none";
}

/// A reference field (and, for Monte Carlo, its standard errors).
struct Reference {
    std::unique_ptr<scene::UniformField> field;
    std::vector<RGB> stdError;
    bool cached = false;
    bool interrupted = false;  ///< stopped by a signal: not a reference to measure against
    json stats = json::object();
};

std::string cacheDirFor(const RunContext& ctx) {
    if (!ctx.cacheDir.empty()) return ctx.cacheDir;
    return fs::path(reference::defaultCacheDir()).string();
}

Reference computeReference(const scene::Scene& sc, const transport::Visibility& vis,
                           const Resolved& r, const RunContext& ctx) {
    Reference out;
    bool useCache = ctx.useCache;
    if (r.refFm) {
        reference::FullMatrixResult res;
        if (useCache)
            res = reference::cachedFullMatrix(sc, vis, *r.refFm, cacheDirFor(ctx), &out.cached,
                                              ctx.progress, StopPoll{ctx.cancel});
        else
            res = reference::solveFullMatrix(sc, vis, *r.refFm, ctx.progress, StopPoll{ctx.cancel});
        out.interrupted = res.stats.interrupted;
        out.field = std::move(res.field);
        out.stats = json{{"elements", res.stats.elements},
                         {"form_factors", res.stats.formFactors},
                         {"residual", res.stats.residual},
                         {"converged", res.stats.converged}};
    } else if (r.refMc) {
        reference::MonteCarloResult res;
        if (useCache)
            res = reference::cachedMonteCarlo(sc, vis, *r.refMc, cacheDirFor(ctx), &out.cached,
                                              ctx.progress, StopPoll{ctx.cancel});
        else
            res = reference::solveMonteCarlo(sc, vis, *r.refMc, ctx.progress, StopPoll{ctx.cancel});
        out.interrupted = res.stats.interrupted;
        out.field = std::move(res.field);
        out.stdError = std::move(res.stdError);
        out.stats = json{{"regions", res.stats.regions},
                         {"paths", res.stats.paths},
                         {"rounds", res.stats.rounds},
                         {"estimated_regions", res.stats.estimated}};
        // The walk's own cost (0 when the reference came from the cache).
        if (!out.cached) {
            out.stats["rays"] = res.stats.rays;
            out.stats["seconds"] = res.stats.seconds;
        }
    }
    return out;
}

/// Relative L2 norm of the Monte Carlo standard errors (see runner.h).
std::pair<double, double> mcUncertainty(const Reference& ref) {
    double numL = 0, denL = 0, numC = 0, denC = 0;
    const scene::UniformField& f = *ref.field;
    for (size_t k = 0; k < f.numElements() && k < ref.stdError.size(); ++k) {
        double a = f.area(k);
        const RGB& s = ref.stdError[k];
        const RGB& v = f.value(k);
        numL += a * luminance(s) * luminance(s);
        denL += a * luminance(v) * luminance(v);
        numC += a * double(glm::dot(s, s));
        denC += a * double(glm::dot(v, v));
    }
    auto ratio = [](double n, double d) {
        return d > 0 ? std::sqrt(n / d) : (n > 0 ? INFINITY : 0.0);
    };
    return {ratio(numL, denL), ratio(numC, denC)};
}

/// mcUncertainty's luminance norm over the regions of non-emitting patches
/// only (the norm of the "non-emitters" error family): there the emitters'
/// exact E no longer fills the denominator, so the noise is larger.
double mcUncertaintyNonEmitters(const Reference& ref, const scene::Scene& sc) {
    double num = 0, den = 0;
    const scene::UniformField& f = *ref.field;
    for (uint32_t p = 0; p < sc.patches.size(); ++p) {
        if (sc.patches[p].isEmitter()) continue;
        for (size_t k = f.offset(p); k < f.offset(p) + f.count(p) && k < ref.stdError.size(); ++k) {
            double a = f.area(k), s = luminance(ref.stdError[k]), v = luminance(f.value(k));
            num += a * s * s;
            den += a * v * v;
        }
    }
    return den > 0 ? std::sqrt(num / den) : (num > 0 ? INFINITY : 0.0);
}

}  // namespace

void validatePoint(const PointSpec& p) {
    resolve(p);
    probeLoaderKeys(p.settings);
    p.settings.reportUnused();
}

std::string referenceId(const PointSpec& p) {
    Resolved r = resolve(p);
    if (r.refKind == "none") return "";
    return p.sceneLabel + "|" + referenceDescription(r);
}

/// solution.ply, solution.glb and the lightmap files, with the tone map of
/// the PNG (issue 60: one tone map for every output).
static void writeExports(const PointSpec& p, const Resolved& r, const scene::RadiosityField& field,
                  const render::ToneMap& tone, const fs::path& dir, json& artefacts, json& summary) {
    if (p.outputs.ply) {
        fs::path ply = dir / "solution.ply";
        render::writePly(field, ply.string(), tone, r.render.interpolate, r.render.smooth);
        artefacts["ply"] = ply.string();
    }
    if (p.outputs.glb) {
        fs::path glb = dir / "solution.glb";
        render::GltfExportOptions go;
        go.interpolate = r.render.interpolate;
        go.smooth = r.render.smooth;
        go.tone = tone;
        render::writeGlb(field, glb.string(), go);
        artefacts["glb"] = glb.string();
    }
    if (p.outputs.lightmap) {
        std::unique_ptr<render::VertexInterpolation> smooth;
        if (r.render.interpolate)
            smooth = std::make_unique<render::VertexInterpolation>(field, r.render.smooth);
        render::Lightmap lm =
            render::writeLightmapFiles(field, r.lightmap, smooth.get(), tone, dir.string());
        for (const char* f : {"lightmap.exr", "lightmap.png", "lightmap.glb"})
            artefacts[std::string(f).replace(8, 1, "_")] = (dir / f).string();
        summary["lightmap"] = json{{"size", lm.size},          {"texels_per_unit", lm.density},
                                   {"gutter", lm.gutter},      {"fill", lm.fill()},
                                   {"charts", lm.charts.size()}, {"smooth", r.render.interpolate}};
    }
}

json prepareReference(const PointSpec& p, const RunContext& ctx) {
    Resolved r = resolve(p);
    json out = json::object();
    if (r.refKind == "none") return out;
    Timer t;
    auto scene = std::make_shared<scene::Scene>(transport::loadScene(p.scene, p.settings));
    const scene::Scene& sc = *scene;
    requireSolvable(sc, p.settings);
    auto visibility = std::make_shared<transport::Visibility>(sc);
    const transport::Visibility& vis = *visibility;
    Reference ref = computeReference(sc, vis, r, ctx);
    out["reference"] = referenceDescription(r);
    out["cached"] = ref.cached;
    out["cache_dir"] = cacheDirFor(ctx);
    std::string key =
        r.refFm ? reference::referenceCacheKey(sc, reference::kFullMatrixKind, r.refFm->describe())
                : reference::referenceCacheKey(sc, reference::kMonteCarloKind, r.refMc->describe());
    // Null when the cache could not be written (full, read-only: the save
    // warned): never a file name that does not exist (issue 64).
    const fs::path cacheFile =
        reference::referenceCacheFile(cacheDirFor(ctx), r.refFm ? "fullmatrix" : "montecarlo", key);
    std::error_code ec;
    out["cache_file"] = fs::is_regular_file(cacheFile, ec) ? json(cacheFile.string()) : json(nullptr);
    out["seconds"] = t.seconds();
    out["stats"] = ref.stats;
    out["interrupted"] = ref.interrupted;
    if (r.refMc && !ref.interrupted) {
        auto [uLum, uRgb] = mcUncertainty(ref);
        out["mc_stderr_l2_lum"] = uLum;
        out["mc_stderr_l2_rgb"] = uRgb;
        out["mc_stderr_l2_nonemitter_lum"] = mcUncertaintyNonEmitters(ref, sc);
    }
    // The reference's reflected power, sum over regions of A (B - E), and
    // (Monte Carlo) its standard error from the regions' independent errors:
    // a total any solve of the same geometry can be held to, however its
    // patches are cut. Not for an interrupted reference (regions missing).
    if (!ref.interrupted) {
        const scene::UniformField& f = *ref.field;
        RGB power(0.0), var(0.0);
        for (uint32_t q = 0; q < sc.patches.size(); ++q) {
            for (size_t k = f.offset(q); k < f.offset(q) + f.count(q); ++k) {
                const double a = f.area(k);
                power += a * (f.value(k) - sc.patches[q].emission);
                if (k < ref.stdError.size()) var += a * a * ref.stdError[k] * ref.stdError[k];
            }
        }
        out["reflected_power"] = json::array({power.r, power.g, power.b});
        if (r.refMc)
            out["reflected_power_stderr"] =
                json::array({std::sqrt(var.r), std::sqrt(var.g), std::sqrt(var.b)});
    }
    if (ctx.keep) {
        RunOutput kept{scene, visibility, {}, ref.stdError};
        std::shared_ptr<const scene::UniformField> field = std::move(ref.field);
        kept.solved.field = field.get();
        kept.solved.owner = field;
        kept.solved.summary = out;
        ctx.keep(kept);
    }
    return out;
}

json runPoint(const PointSpec& p, const RunContext& ctx) {
    Timer total;
    json summary;
    summary["hrad_version"] = codeVersion();
    summary["build_type"] = buildType();
    summary["host"] = hostName();
    summary["date"] = isoDateUtc();
    summary["scene"] = p.scene;
    summary["scene_label"] = p.sceneLabel;

    // ---- settings: read and validate everything before any work ----------------
    Resolved r = resolve(p);
    Timer tLoad;
    PhaseProgress loading("loading " + p.sceneLabel, ctx.progress);  // core/phase_progress.h
    auto scene = std::make_shared<scene::Scene>(transport::loadScene(p.scene, p.settings));
    loading.done();
    const scene::Scene& sc = *scene;
    logLoadWarnings(sc);
    requireSolvable(sc, p.settings);
    double loadSeconds = tLoad.seconds();
    // The scene's film (Mitsuba sensor) sets the image size the user left
    // unset; checked now, before solving.
    r.render.adoptFilm(sc);
    checkPathTracedBudget(r);
    p.settings.reportUnused();
    summary["settings"] = paramsJson(p.settings);
    summary["reference_settings"] = paramsJson(p.reference);
    summary["scene_info"] = json{{"name", sc.name},
                                 {"patches", sc.patches.size()},
                                 {"triangles", sc.count(scene::PatchKind::Triangle)},
                                 {"quads", sc.count(scene::PatchKind::Quad)},
                                 {"emitters", sc.numEmitters()},
                                 {"total_area", sc.totalArea()},
                                 {"emitted_power", rgbJson(sc.emittedPower())},
                                 {"dropped_degenerate", sc.stats.droppedDegenerate},
                                 {"warnings", sc.stats.warnings.total()}};
    if (sc.stats.discontinuity.sources > 0) {
        // What discontinuity meshing cut (transport/discontinuity.h).
        const scene::DiscontinuityStats& d = sc.stats.discontinuity;
        summary["scene_info"]["discontinuity"] =
            json{{"sources", d.sources},       {"pairs", d.pairs},
                 {"occluders", d.occluders},   {"occluders_dropped", d.occludersDropped},
                 {"events", d.events},         {"hidden", d.hidden},
                 {"curves", d.curves},         {"curves_dropped", d.curvesDropped},
                 {"cut_patches", d.cutPatches}, {"pieces", d.pieces},
                 {"faces", d.faces},           {"slivers", d.thin},
                 {"sliver_area", d.thinArea},  {"source_patches", sc.numSourcePatches()},
                 {"seconds", d.seconds}};
    }
    spdlog::info("loaded {}: {} patches in {:.2f} s", sc.name, sc.patches.size(), loadSeconds);
    if ((p.outputs.exr || p.outputs.ply || p.outputs.glb || p.outputs.errorMap ||
         p.outputs.solution || p.outputs.regions) &&
        ctx.artefactDir.empty())
        throw Error("outputs requested but no artefact folder given");

    Timer tVis;
    PhaseProgress building("ray-tracing structure", ctx.progress);
    auto visibility = std::make_shared<transport::Visibility>(sc);
    building.done();
    const transport::Visibility& vis = *visibility;
    double visSeconds = tVis.seconds();

    json timings = {{"load", loadSeconds}, {"visibility_build", visSeconds}};
    MemoryCounters memory;
    memory.set("visibility", vis.memoryBytes());

    const scene::RadiosityField* field = nullptr;
    std::optional<Reference> earlyRef;
    double earlyRefSeconds = 0.0;
    double historyErrorSeconds = 0.0;  // the iteration hook's error evaluations
    const SolverInfo& info = solverInfo(r.solver);
    Timer tSolve;
    summary["solver"] = r.solver;
    SolveContext solveCtx;
    solveCtx.progress = ctx.progress;
    if (info.keepsHistory && p.outputs.historyError && r.refKind != "none") {
        // The reference is needed during the solve: compute (or load) it
        // first; the error block below reuses it.
        Timer tRef;
        earlyRef = computeReference(sc, vis, r, ctx);
        earlyRefSeconds = tRef.seconds();
        solveCtx.historyError = [&](const scene::RadiosityField& f) {
            Timer tHook;
            double l2 = reference::computeError(f, *earlyRef->field).l2Lum;
            historyErrorSeconds += tHook.seconds();
            return l2;
        };
    }
    solveCtx.cancel = ctx.cancel;
    solveCtx.camera = [&] { return render::chooseCamera(sc, vis, r.render); };
    solveCtx.imageWidth = r.render.width;
    solveCtx.imageHeight = r.render.height;
    solveCtx.onRecord = ctx.onRecord;
    std::optional<TargetErrorDriver> target;
    if (r.target) {
        target.emplace(sc, vis, *r.target, *r.estimate, ctx.progress);
        solveCtx.afterStage = [&](const scene::RadiosityField& f, double eps) {
            return target->afterStage(f, eps);
        };
    }
    SolveOutput solved = r.solverImpl->solve(sc, vis, solveCtx);
    if (target) summary["target"] = target->summary();
    field = solved.field;
    if (ctx.keep) ctx.keep(RunOutput{scene, visibility, solved, {}});
    // cluster.model = auto is resolved by the solve (hr/solver.cpp solveOnce).
    if (solved.summary.contains("cluster_model") && solved.summary["cluster_model"].is_string())
        p.settings.recordResolved("cluster.model",
                                  solved.summary["cluster_model"].get<std::string>());
    // Every key read, with the value the run used: the record of what ran.
    summary["resolved_settings"] = resolvedSettingsJson(p.settings, p.reference);
    for (const auto& [k, v] : solved.summary.items()) summary[k] = v;
    for (const auto& [k, v] : solved.timings.items()) timings[k] = v;
    for (const auto& [k, v] : solved.memory.all()) memory.set(k, v);
    if (summary.contains("bytes_per_link") && summary.contains("counts") &&
        summary["counts"].value("links", uint64_t(0)) > 0) {
        // Every counted structure (the solver's links, elements, clusters,
        // kernel samples..., and the visibility structure) over the links.
        double total = 0;
        for (const auto& [k, v] : memory.all()) total += double(v);
        summary["bytes_per_link"]["all_told"] =
            total / double(summary["counts"]["links"].get<uint64_t>());
    }
    timings["solve_total"] = tSolve.seconds();
    summary["radiosity_power"] = rgbJson(field->totalPower());
    summary["timings"] = timings;
    auto memoryJson = [&] {
        json mem = json::object();
        for (const auto& [k, v] : memory.all()) mem[k] = v;
        mem["peak_rss"] = peakRssBytes();
        return mem;
    };
    summary["memory"] = memoryJson();
    // The solution itself first: nothing computed is lost if a later step fails.
    if (p.outputs.solution) {
        ensureOutputFolder(ctx.artefactDir, "the point's output folder");
        fs::path sol = ctx.artefactDir / "solution.hrsol";
        reference::saveSolution(sol.string(), *field);
        summary["artefacts"]["solution"] = sol.string();
    }
    if (ctx.checkpoint) ctx.checkpoint(summary);

    // ---- the solution's transport residual (render/residual.h) ----------------
    if (r.residual) {
        render::ResidualSummary res =
            render::computeResidual(sc, vis, *field, *r.residual, ctx.progress);
        summary["transport_residual"] = json{{"l1", res.l1},         {"l1_noise", res.l1Noise},
                                             {"ratio", res.ratio()}, {"leaves", res.leaves.size()},
                                             {"rays", res.rays},     {"seconds", res.seconds}};
        timings["residual"] = res.seconds;
        summary["timings"] = timings;
        spdlog::info(
            "transport residual: L1 = {:.4g} (noise {:.2g}), solution / gathered reflected = "
            "{:.4f}",
            res.l1, res.l1Noise, res.ratio());
        if (!ctx.artefactDir.empty()) {
            ensureOutputFolder(ctx.artefactDir, "the point's output folder");
            fs::path csv = ctx.artefactDir / "residual.csv";
            render::writeResidualCsv(csv.string(), res);
            summary["artefacts"]["residual"] = csv.string();
        }
        if (ctx.checkpoint) ctx.checkpoint(summary);
    }

    // ---- the error estimate (reference/error_estimate.h) ---------------------------
    std::optional<reference::ErrorEstimate> estimate;
    if (r.estimate && interruptSignal() == 0) {
        const reference::ErrorEstimate* known = target ? target->finalEstimate() : nullptr;
        estimate = known ? *known
                         : reference::estimateError(sc, vis, *field, *r.estimate, ctx.progress);
        summary["estimate"] = estimateJson(*estimate);
        timings["estimate"] = estimate->seconds;
        summary["timings"] = timings;
        reportEstimate(*estimate);
        if (ctx.checkpoint) ctx.checkpoint(summary);
    }

    // ---- error against the reference --------------------------------------------
    if (ctx.cancel) ctx.cancel->throwIfRequested();
    std::optional<Reference> ref;
    // After SIGINT/SIGTERM no reference is computed (it would stop at once,
    // and an error against a partial reference measures nothing).
    const bool skipReference = interruptSignal() != 0 || (earlyRef && earlyRef->interrupted);
    if (skipReference && r.refKind != "none") {
        summary["error"] = nullptr;
        summary["error_skipped"] = "interrupted: no complete reference";
    }
    if (r.refKind != "none" && !skipReference) {
        Timer tRef;
        ref = earlyRef ? std::move(earlyRef) : computeReference(sc, vis, r, ctx);
        timings["reference"] = earlyRef ? earlyRefSeconds : tRef.seconds();
        if (ref->interrupted) {
            // Stopped by a signal while the reference ran: its unestimated
            // regions are NaN, and an error against the rest would read as
            // a (false) small error. None is reported, nor an error map.
            summary["error"] = nullptr;
            summary["error_skipped"] = fmt::format(
                "interrupted while computing the reference ({} of {} regions estimated): "
                "no error against a partial reference",
                ref->stats.value("estimated_regions", uint64_t(0)), ref->stats.value("regions", uint64_t(0)));
            spdlog::warn("{}", summary["error_skipped"].get<std::string>());
            ref.reset();
        }
    }
    if (ref) {
        Timer tErr;
        reference::ErrorMetrics err = reference::computeError(*field, *ref->field);
        json e = errorMetricsJson(err);
        e["reference"] = referenceDescription(r);
        e["reference_seconds"] = timings["reference"];
        e["reference_cached"] = ref->cached;
        e["reference_stats"] = ref->stats;
        // Where the light is missing or extra: the ten materials whose
        // reflected power differs most from the reference's.
        json byMaterial = json::array();
        for (size_t i = 0; i < err.byMaterial.size() && i < 10; ++i) {
            const reference::MaterialPower& mp = err.byMaterial[i];
            byMaterial.push_back(json{{"material", sc.materials[mp.material].name},
                                      {"area", mp.area},
                                      {"reflected", mp.solution},
                                      {"reference_reflected", mp.reference}});
        }
        e["reflected_by_material"] = byMaterial;
        {
            // Merged per original patch (discontinuity meshing's pieces as one).
            const reference::SourcePatchError sp =
                reference::computeSourcePatchError(*field, *ref->field, ref->stdError);
            e["by_source_patch"] = json{{"l1_nonemitter_lum", sp.l1NonEmitLum},
                                        {"l2_nonemitter_lum", sp.l2NonEmitLum},
                                        {"patches", sp.patches}};
            if (r.refMc) e["by_source_patch"]["mc_stderr_l2_nonemitter_lum"] = sp.stderrL2NonEmitLum;
        }
        if (p.outputs.regions) {
            ensureOutputFolder(ctx.artefactDir, "the point's output folder");
            fs::path csv = ctx.artefactDir / "regions.csv";
            reference::writeRegionsCsv(csv.string(), *field, *ref->field, ref->stdError);
            summary["artefacts"]["regions"] = csv.string();
        }
        if (r.refMc) {
            auto [uLum, uRgb] = mcUncertainty(*ref);
            e["mc_stderr_l2_lum"] = uLum;
            e["mc_stderr_l2_rgb"] = uRgb;
            e["mc_stderr_l2_nonemitter_lum"] = mcUncertaintyNonEmitters(*ref, sc);
        }
        if (estimate)
            e["estimate"] = estimateAgainstTruth(
                *estimate, err, r.refMc ? e["mc_stderr_l2_nonemitter_lum"].get<double>() : 0.0);
        // Error work, including the per-iteration errors (history_error), so
        // that wall - reference - error - render is the solver's own time.
        timings["error"] = tErr.seconds() + historyErrorSeconds;
        if (historyErrorSeconds > 0) timings["history_error"] = historyErrorSeconds;
        summary["error"] = e;
        spdlog::info(
            "error vs {}: reflected L1 = {:.4g}, L2 = {:.4g}; non-emitters L1 = {:.4g}, "
            "L2 = {:.4g}, mean ratio {:.4f}; all regions L1 = {:.4g}, L2 = {:.4g}",
            referenceDescription(r), err.l1ReflLum, err.l2ReflLum, err.l1NonEmitLum,
            err.l2NonEmitLum, err.meanRatioNonEmit, err.l1Lum, err.l2Lum);
    }
    if (p.outputs.historyError)
        summary["history_error"] =
            !info.keepsHistory
                ? fmt::format("not computed: the {} solver keeps no history", r.solver)
            : r.refKind == "none" ? "not computed: the study has no reference"
                                  : "history[].l2_lum: L2 (luminance) after every iteration "
                                    "(progressive: every pr.history_every shots)";
    summary["timings"] = timings;
    if (ctx.checkpoint) ctx.checkpoint(summary);

    // ---- artefacts -------------------------------------------------------------------
    json artefacts = summary.contains("artefacts") ? summary["artefacts"] : json::object();
    const bool errorMap = p.outputs.errorMap && (ref || r.errorVsPathTraced);
    bool images = p.outputs.exr || errorMap;
    std::optional<render::ToneMap> tone;  // one for the PNGs, the PLY and the glTF
    if (images || p.outputs.ply || p.outputs.glb || p.outputs.lightmap) {
        ensureOutputFolder(ctx.artefactDir, "the point's output folder");
        if (images) {
            Timer tr;
            scene::Camera cam = render::chooseCamera(sc, vis, r.render);
            summary["camera"] =
                json{{"eye", json::array({cam.eye.x, cam.eye.y, cam.eye.z})},
                     {"target", json::array({cam.target.x, cam.target.y, cam.target.z})},
                     {"up", json::array({cam.up.x, cam.up.y, cam.up.z})},
                     {"fov_y_degrees", cam.fovYDegreesFor(r.render.width, r.render.height)},
                     {"image_size", json::array({r.render.width, r.render.height})},
                     {"explicit", r.render.camera.has_value()}};
            // With an error map, the reference (and, for regions, the
            // solution's averages over the reference's regions: what the
            // L1/L2 metrics compare) go through the same camera in the same
            // ray cast; pixels mode compares the two reconstructions.
            std::vector<const scene::RadiosityField*> fields{field};
            std::unique_ptr<scene::UniformField> onRegions;
            if (errorMap && !r.errorVsPathTraced) {
                fields.push_back(ref->field.get());
                if (r.errorOnRegions) {
                    onRegions = reference::averageOnRegions(*field, *ref->field);
                    fields.push_back(onRegions.get());
                }
            }
            render::RenderSettings rs = r.render;
            rs.showProgress = ctx.progress;  // final gather / path tracing take a while
            std::vector<render::Image> imgs = render::renderFields(sc, vis, fields, cam, rs);
            const render::Image& img = imgs[0];
            render::Image pathTraced;  // render.error_reference = path-traced
            if (errorMap) {
                if (r.errorVsPathTraced) {
                    render::RenderSettings ps = rs;
                    ps.reconstruction = render::RenderSettings::Reconstruction::PathTraced;
                    ps.interpolate = false;
                    ps.spp = r.pathTracedSpp;
                    Timer tp;
                    pathTraced = std::move(render::renderFields(sc, vis, {field}, cam, ps)[0]);
                    timings["render_path_traced"] = tp.seconds();
                }
                // The reference's exposure is used for both PNGs, so every
                // run of a scene shares one exposure.
                const render::Image& refImg = r.errorVsPathTraced ? pathTraced : imgs[1];
                tone = r.tone.choose(refImg);
                render::ErrorMap em =
                    render::computeErrorMap(imgs[onRegions ? 2 : 0], refImg, r.errorFloor);
                fs::path refPng = ctx.artefactDir / "reference.png",
                         data = ctx.artefactDir / "error.png",
                         fc = ctx.artefactDir / "error_fc.png";
                render::writePng(refImg, refPng.string(), *tone);
                render::writeErrorData(em, data.string());
                render::writeErrorFalseColour(em, fc.string(), r.errorRange);
                artefacts["reference_png"] = refPng.string();
                artefacts["error_map"] = data.string();
                artefacts["error_false_colour"] = fc.string();
                summary["error_map"] =
                    json{{"mode", r.errorOnRegions ? "regions" : "pixels"},
                         {"reference", r.errorVsPathTraced
                                           ? fmt::format("path-traced, {} spp", r.pathTracedSpp)
                                           : std::string("solution")},
                         {"pixels", em.pixels},
                         {"floor", em.floor},
                         {"floor_fraction", r.errorFloor},
                         {"mean_abs", em.meanAbs},
                         {"p95_abs", em.p95Abs},
                         {"max_abs", em.maxAbs},
                         {"l1", em.l1},
                         {"l2", em.l2},
                         {"false_colour_range", r.errorRange},
                         {"exposure", tone->exposure}};
                spdlog::info(
                    "error map: mean |e| = {:.4g}, 95th percentile {:.4g}, image L1 {:.4g}",
                    em.meanAbs, em.p95Abs, em.l1);
            }
            fs::path exr = ctx.artefactDir / "image.exr", png = ctx.artefactDir / "image.png";
            render::writeExr(img, exr.string());
            if (!tone) tone = r.tone.choose(img);
            render::writePng(img, png.string(), *tone);
            summary["tone_map"] = toneJson(*tone, render::clippedShare(img.pixels, *tone));
            artefacts["exr"] = exr.string();
            artefacts["png"] = png.string();
            timings["render"] = tr.seconds();
            summary["timings"] = timings;
        }
        // The PLY and glTF colours use the PNG's tone map (issue 60); without
        // an image, the same rule over the leaves (area-weighted).
        if (!tone) tone = render::leafToneMap(*field, r.tone);
        if (!summary.contains("tone_map")) summary["tone_map"] = toneJson(*tone, -1.0);
        writeExports(p, r, *field, *tone, ctx.artefactDir, artefacts, summary);
    }
    summary["artefacts"] = artefacts;
    summary["memory"] = memoryJson();
    summary["wall_seconds"] = total.seconds();
    // CPU time of the whole process (all threads, core/cpu_time.h), not wall
    // time summed over threads.
    summary["cpu_seconds"] = processCpuSeconds();
    return summary;
}

}  // namespace hrad::experiments
