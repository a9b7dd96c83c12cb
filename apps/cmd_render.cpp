// `hrad render SCENE SOLUTION`: a saved solution rendered again, with any
// render.* settings (size, spp, reconstruction, explicit camera), without
// solving.
#include <filesystem>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "apps/commands.h"
#include "core/safe_file.h"
#include "core/timer.h"
#include "reference/cache.h"
#include "render/gltf_export.h"
#include "render/image.h"
#include "render/render.h"
#include "scene/loader.h"
#include "transport/reachability.h"
#include "transport/visibility.h"

namespace hrad::app {

namespace fs = std::filesystem;

int runRender(const RenderCliOptions& opt, Params& params) {
    Timer t;
    scene::Scene sc = transport::loadScene(opt.scene, params);
    render::RenderSettings rs = render::RenderSettings::fromParams(params, "render");
    rs.adoptFilm(sc);  // the scene's film size where --width/--height are unset
    rs.showProgress = true;  // final gather / path tracing take a while
    double exposure = params.getDouble("render.exposure", 0.0, 0.0,
                                       1e300);  // documented in experiments/runner.cpp
    params.reportUnused();
    std::unique_ptr<scene::LeafField> field = reference::loadSolution(opt.solution, sc);
    transport::Visibility vis(sc);
    scene::Camera cam = render::chooseCamera(sc, vis, rs);
    render::Image img = render::renderField(sc, vis, *field, cam, rs);
    ensureOutputFolder(opt.outDir, "command line (-o)");
    fs::path exr = fs::path(opt.outDir) / "image.exr", png = fs::path(opt.outDir) / "image.png";
    render::writeExr(img, exr.string());
    render::writePng(img, png.string(), exposure);
    spdlog::info("rendered {} leaves of {} at {}x{} in {:.2f} s", field->numLeaves(), sc.name,
                 rs.width, rs.height, t.seconds());
    fmt::print("camera eye ({}, {}, {}) target ({}, {}, {}) up ({}, {}, {}) fov {}\n", cam.eye.x,
               cam.eye.y, cam.eye.z, cam.target.x, cam.target.y, cam.target.z, cam.up.x, cam.up.y,
               cam.up.z, cam.fovYDegreesFor(rs.width, rs.height));
    fmt::print("wrote {}\nwrote {}\n", exr.string(), png.string());
    if (opt.writeGlb) {
        fs::path glb = fs::path(opt.outDir) / "solution.glb";
        // render.exposure when set, else automatic over the leaves, as the
        // PLY/glTF export of hrad solve: both commands write the same file.
        // Interpolated when the render is (render.interpolate).
        render::writeGlb(*field, glb.string(), {exposure, rs.interpolate});
        fmt::print("wrote {}\n", glb.string());
    }
    return 0;
}

}  // namespace hrad::app
