#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "apps/commands.h"
#include "core/log.h"
#include "core/memory.h"
#include "core/timer.h"
#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "render/camera.h"
#include "render/image.h"
#include "render/ply_export.h"
#include "render/render.h"
#include "scene/loader.h"
#include "transport/visibility.h"

namespace hrad::app {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json rgbJson(const RGB& c) { return json::array({c.r, c.g, c.b}); }

json paramsJson(const Params& p) {
    json j = json::object();
    for (const auto& [k, e] : p.entries()) {
        std::visit([&](const auto& v) { j[k] = v; }, e.value);
    }
    return j;
}

json metricsJson(const reference::ErrorMetrics& m) {
    return json{{"l1_lum", m.l1Lum},   {"l2_lum", m.l2Lum},   {"linf_lum", m.linfLum},
                {"l1_rgb", m.l1Rgb},   {"l2_rgb", m.l2Rgb},   {"linf_rgb", m.linfRgb},
                {"regions", m.regions}};
}

void writeJson(const fs::path& path, const json& j) {
    std::ofstream out(path);
    if (!out) throw Error(fmt::format("cannot write {}", path.string()));
    out << j.dump(2) << "\n";
}

}  // namespace

int runSolve(const SolveOptions& opt, Params& params) {
    Timer total;
    json summary;
    summary["hrad_version"] = HRAD_VERSION;
    summary["scene"] = opt.scene;

    // ---- settings: read and validate everything before any work ----------------
    std::string solver = params.getEnum("solver", "hr", {"hr", "full-matrix"});
    int refLevel = int(params.getInt("metrics.reference_level", -1, -1, 12));
    std::optional<hr::HrSettings> hrSettings;
    std::optional<reference::FullMatrixSettings> fmSettings;
    if (solver == "hr") hrSettings = hr::HrSettings::fromParams(params);
    if (solver == "full-matrix" || refLevel >= 0)
        fmSettings = reference::FullMatrixSettings::fromParams(params, "fm");
    render::RenderSettings renderSettings = render::RenderSettings::fromParams(params, "render");
    double exposure = params.getDouble("render.exposure", 0.0, 0.0, 1e300);

    Timer tLoad;
    scene::Scene sc = scene::loadScene(opt.scene, params);
    double loadSeconds = tLoad.seconds();
    params.reportUnused();
    summary["settings"] = paramsJson(params);
    summary["scene_info"] = json{{"name", sc.name},
                                 {"patches", sc.patches.size()},
                                 {"triangles", sc.count(scene::PatchKind::Triangle)},
                                 {"quads", sc.count(scene::PatchKind::Quad)},
                                 {"emitters", sc.numEmitters()},
                                 {"total_area", sc.totalArea()},
                                 {"emitted_power", rgbJson(sc.emittedPower())},
                                 {"dropped_degenerate", sc.stats.droppedDegenerate}};
    spdlog::info("loaded {}: {} patches in {:.2f} s", sc.name, sc.patches.size(), loadSeconds);

    fs::create_directories(opt.outDir);
    fs::path out(opt.outDir);

    Timer tVis;
    transport::Visibility vis(sc);
    double visSeconds = tVis.seconds();

    json timings = {{"load", loadSeconds}, {"visibility_build", visSeconds}};
    MemoryCounters memory;
    memory.set("visibility", vis.memoryBytes());

    std::unique_ptr<scene::RadiosityField> fieldOwner;
    const scene::RadiosityField* field = nullptr;
    hr::HrResult hrRes;
    reference::FullMatrixResult fmRes;

    if (solver == "hr") {
        summary["solver"] = "hr";
        summary["solver_settings"] = hrSettings->describe();
        hr::HrSolver s(sc, vis, *hrSettings);
        hrRes = s.solve(opt.progress);
        field = hrRes.field.get();
        const hr::Hierarchy& h = *hrRes.hierarchy;
        summary["oracle"] = hrRes.oracleDescription;
        summary["converged"] = hrRes.converged;
        summary["link_cap_hit"] = hrRes.linkCapHit;
        summary["min_area"] = hrRes.minArea;
        summary["counts"] = json{{"elements", h.numElements()},
                                 {"leaves", h.numLeaves()},
                                 {"links", h.numLinks()},
                                 {"initial_links", hrRes.initialLinks},
                                 {"rays", hrRes.totalRays},
                                 {"form_factors", hrRes.totalFormFactors},
                                 {"iterations", hrRes.history.size()}};
        timings["linking"] = hrRes.linkingSeconds;
        timings["refine"] = hrRes.refineSeconds;
        timings["gather"] = hrRes.gatherSeconds;
        timings["push_pull"] = hrRes.pushPullSeconds;
        for (const auto& [k, v] : hrRes.memory.all()) memory.set(k, v);
        json hist = json::array();
        for (const auto& r : hrRes.history)
            hist.push_back(json{{"iteration", r.iteration},
                                {"stage", r.stage},
                                {"eps", std::isnan(r.eps) ? json(nullptr) : json(r.eps)},
                                {"links", r.links},
                                {"elements", r.elements},
                                {"leaves", r.leaves},
                                {"refined_links", r.refinedLinks},
                                {"rays", r.rays},
                                {"form_factors", r.formFactors},
                                {"residual", r.residual},
                                {"reflected_power", rgbJson(r.reflectedPower)},
                                {"refine_s", r.refineSeconds},
                                {"gather_s", r.gatherSeconds},
                                {"push_pull_s", r.pushPullSeconds},
                                {"element_bytes", r.elementBytes},
                                {"link_bytes", r.linkBytes}});
        summary["history"] = hist;
        if (h.numLinks())
            summary["bytes_per_link"] = json{
                {"link_storage", double(h.linkBytes()) / double(h.numLinks())},
                {"all", double(h.linkBytes() + h.elementBytes()) / double(h.numLinks())}};
    } else {
        summary["solver"] = "full-matrix";
        summary["solver_settings"] = fmSettings->describe();
        fmRes = reference::solveFullMatrix(sc, vis, *fmSettings, opt.progress);
        field = fmRes.field.get();
        const auto& st = fmRes.stats;
        summary["counts"] = json{{"elements", st.elements},
                                 {"form_factors", st.formFactors},
                                 {"rays", st.rays},
                                 {"iterations", st.iterations}};
        summary["residual"] = st.residual;
        timings["form_factors"] = st.ffSeconds;
        timings["solve"] = st.solveSeconds;
        memory.set("matrix", st.matrixBytes);
    }
    timings["solve_total"] = total.seconds() - loadSeconds - visSeconds;
    summary["radiosity_power"] = rgbJson(field->totalPower());
    summary["timings"] = timings;
    memory.set("peak_rss", 0);
    json mem = json::object();
    for (const auto& [k, v] : memory.all())
        if (k != "peak_rss") mem[k] = v;
    mem["peak_rss"] = peakRssBytes();
    summary["memory"] = mem;
    // Write the summary now: nothing computed so far is lost if an artefact
    // below fails.
    writeJson(out / "summary.json", summary);

    if (refLevel >= 0) {
        reference::FullMatrixSettings rs = *fmSettings;
        rs.level = refLevel;
        rs.maxArea = 0.0;
        Timer tRef;
        auto ref = reference::solveFullMatrix(sc, vis, rs, opt.progress);
        auto err = reference::computeError(*field, *ref.field);
        json e = metricsJson(err);
        e["reference"] = fmt::format("full-matrix level {} ({} elements)", refLevel,
                                     ref.stats.elements);
        e["reference_seconds"] = tRef.seconds();
        summary["error"] = e;
        spdlog::info("error vs full-matrix level {}: L2(lum) = {:.4g}, L1(lum) = {:.4g}", refLevel,
                     err.l2Lum, err.l1Lum);
        writeJson(out / "summary.json", summary);
    }

    json artefacts = json::object();
    if (opt.writePly) {
        render::writePly(*field, (out / "solution.ply").string(), exposure);
        artefacts["ply"] = (out / "solution.ply").string();
    }
    if (opt.writeImages) {
        Timer tr;
        scene::Camera cam = render::cameraFor(sc);
        render::Image img = render::renderField(sc, vis, *field, cam, renderSettings);
        render::writeExr(img, (out / "image.exr").string());
        render::writePng(img, (out / "image.png").string(), exposure);
        artefacts["exr"] = (out / "image.exr").string();
        artefacts["png"] = (out / "image.png").string();
        timings["render"] = tr.seconds();
        summary["timings"] = timings;
    }
    summary["artefacts"] = artefacts;
    summary["memory"]["peak_rss"] = peakRssBytes();
    summary["wall_seconds"] = total.seconds();
    writeJson(out / "summary.json", summary);
    fmt::print("wrote {}\n", (out / "summary.json").string());
    for (const auto& [k, v] : artefacts.items()) fmt::print("wrote {}\n", v.get<std::string>());
    return 0;
}

}  // namespace hrad::app
