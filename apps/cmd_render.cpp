// `hrad render SCENE SOLUTION`: a saved solution rendered again, with any
// render.* settings (size, spp, reconstruction, explicit camera), without
// solving. Writes image.exr, image.png and render.json (the tone map, its
// clipped share and, with --compare REF.exr, the mean absolute difference
// to REF per pixel in linear units: luminance and RGB channels averaged).
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "apps/commands.h"
#include "core/safe_file.h"
#include "core/timer.h"
#include "reference/cache.h"
#include "render/gltf_export.h"
#include "render/image.h"
#include "render/lightmap.h"
#include "render/render.h"
#include "scene/loader.h"
#include "transport/reachability.h"
#include "transport/visibility.h"

namespace hrad::app {

namespace fs = std::filesystem;

namespace {

/// Mean |I - R| over the pixels: of the luminance, and of the RGB channels.
nlohmann::json compareImages(const render::Image& img, const std::string& refPath) {
    render::Image ref = render::readExr(refPath);
    if (ref.width != img.width || ref.height != img.height)
        throwInputError(SourceLocation{refPath, 0, 0}, "--compare: {}x{} pixels, the render has {}x{}",
                        ref.width, ref.height, img.width, img.height);
    // Against the EXR's half floats, the render is rounded the same way.
    // Half floats overflow above 65504 (bright lamps in W/m^2): pixels
    // where either image is not finite in half precision are left out and
    // counted.
    double lum = 0.0, rgb = 0.0, refLum = 0.0;
    size_t skipped = 0;
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        RGB a = img.pixels[i], b = ref.pixels[i];
        if (!(std::isfinite(luminance(b)) && std::max({a.r, a.g, a.b}) <= 65504.0)) {
            ++skipped;
            continue;
        }
        lum += std::abs(luminance(a) - luminance(b));
        rgb += (std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b)) / 3.0;
        refLum += luminance(b);
    }
    const double n = std::max(1.0, double(img.pixels.size() - skipped));
    return {{"reference", refPath},
            {"pixels_left_out", skipped},
            {"mean_abs_lum", lum / n},
            {"mean_abs_rgb", rgb / n},
            {"reference_mean_lum", refLum / n}};
}

/// lightmap.exr/png/glb (render/lightmap.h) with the PNG's tone map.
nlohmann::json writeLightmap(const scene::RadiosityField& field, const render::RenderSettings& rs,
                             const render::LightmapSettings& ls, const render::ToneMap& tone,
                             const std::string& outDir) {
    Timer t;
    std::unique_ptr<render::VertexInterpolation> smooth;
    if (rs.interpolate) smooth = std::make_unique<render::VertexInterpolation>(field, rs.smooth);
    render::Lightmap lm = render::writeLightmapFiles(field, ls, smooth.get(), tone, outDir);
    fmt::print("lightmap {} x {} texels, {:.4g} texels per unit, {:.1f} % filled, {} charts, {:.2f} s\n",
               lm.size, lm.size, lm.density, 100.0 * lm.fill(), lm.charts.size(), t.seconds());
    for (const char* f : {"lightmap.exr", "lightmap.png", "lightmap.glb"})
        fmt::print("wrote {}\n", (fs::path(outDir) / f).string());
    return {{"size", lm.size},
            {"texels_per_unit", lm.density},
            {"gutter", lm.gutter},
            {"fill", lm.fill()},
            {"charts", lm.charts.size()},
            {"smooth", rs.interpolate}};
}

}  // namespace

int runRender(const RenderCliOptions& opt, Params& params) {
    Timer t;
    scene::Scene sc = transport::loadScene(opt.scene, params);
    render::RenderSettings rs = render::RenderSettings::fromParams(params, "render");
    rs.adoptFilm(sc);  // the scene's film size where --width/--height are unset
    rs.showProgress = true;  // final gather / path tracing take a while
    render::ToneSettings ts = render::ToneSettings::fromParams(params, "render");
    render::LightmapSettings ls = render::LightmapSettings::fromParams(params, "render");
    params.reportUnused();
    std::unique_ptr<scene::LeafField> field = reference::loadSolution(opt.solution, sc);
    transport::Visibility vis(sc);
    scene::Camera cam = render::chooseCamera(sc, vis, rs);
    render::Image img = render::renderField(sc, vis, *field, cam, rs);
    ensureOutputFolder(opt.outDir, "command line (-o)");
    fs::path exr = fs::path(opt.outDir) / "image.exr", png = fs::path(opt.outDir) / "image.png";
    render::writeExr(img, exr.string());
    // One tone map for the PNG and the glTF colours (issue 60).
    render::ToneMap tone = ts.choose(img);
    render::writePng(img, png.string(), tone);
    spdlog::info("rendered {} leaves of {} at {}x{} in {:.2f} s", field->numLeaves(), sc.name,
                 rs.width, rs.height, t.seconds());
    fmt::print("camera eye ({}, {}, {}) target ({}, {}, {}) up ({}, {}, {}) fov {}\n", cam.eye.x,
               cam.eye.y, cam.eye.z, cam.target.x, cam.target.y, cam.target.z, cam.up.x, cam.up.y,
               cam.up.z, cam.fovYDegreesFor(rs.width, rs.height));
    fmt::print("tone map {} exposure {:.6g}, {:.2f} % of the pixels clipped\n", tone.curveName(),
               tone.exposure, 100.0 * render::clippedShare(img.pixels, tone));
    fmt::print("wrote {}\nwrote {}\n", exr.string(), png.string());
    nlohmann::json info{{"reconstruction", rs.describe()},
                        {"tone_map",
                         {{"curve", tone.curveName()},
                          {"exposure", tone.exposure},
                          {"clipped_share", render::clippedShare(img.pixels, tone)}}}};
    if (!opt.compare.empty()) {
        info["compare"] = compareImages(img, opt.compare);
        fmt::print("mean |I - R| = {:.6g} (luminance, linear; reference mean {:.6g})\n",
                   info["compare"]["mean_abs_lum"].get<double>(),
                   info["compare"]["reference_mean_lum"].get<double>());
    }
    if (opt.lightmap) info["lightmap"] = writeLightmap(*field, rs, ls, tone, opt.outDir);
    {
        fs::path js = fs::path(opt.outDir) / "render.json";
        writeFileSafely(js, info.dump(2) + "\n");
        fmt::print("wrote {}\n", js.string());
    }
    if (opt.writeGlb) {
        fs::path glb = fs::path(opt.outDir) / "solution.glb";
        // The PNG's tone map, as hrad solve does: both commands write the
        // same file. Interpolated when the render is (render.interpolate).
        render::GltfExportOptions go;
        go.interpolate = rs.interpolate;
        go.smooth = rs.smooth;
        go.tone = tone;
        render::writeGlb(*field, glb.string(), go);
        fmt::print("wrote {}\n", glb.string());
    }
    return 0;
}

}  // namespace hrad::app
