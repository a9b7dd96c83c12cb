// loadScene: built-in names, else files by extension (see loader.h).
#include "scene/loader.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/error.h"
#include "core/log.h"
#include "core/timer.h"
#include "scene/builtin.h"
#include "scene/gltf_loader.h"
#include "scene/mgf_loader.h"
#include "scene/mitsuba_loader.h"
#include "scene/obj_loader.h"
#include "scene/ply_loader.h"
#include "scene/triangulate.h"

namespace hrad::scene {

bool isBuiltinName(const std::string& spec) {
    std::string head = spec.substr(0, spec.find(':'));
    const auto& names = builtinNames();
    return std::find(names.begin(), names.end(), head) != names.end();
}

namespace {

// Each format's settings, read from Params (with range checks).
MgfOptions mgfOptions(const Params& params) {
    MgfOptions mgf;
    mgf.resolution = int(params.getInt("mgf.resolution", mgf.resolution, 3, 4096));
    mgf.whitePoint = params.getEnum("mgf.white_point", mgf.whitePoint, {"E", "D65"});
    mgf.maxFaces =
        size_t(params.getInt("mgf.max_faces", int64_t(mgf.maxFaces), 1, int64_t(1) << 40));
    mgf.defaultSides = int(params.getInt("mgf.default_sides", mgf.defaultSides, 1, 2));
    return mgf;
}

ObjOptions objOptions(const Params& params) {
    ObjOptions obj;
    obj.defaultRho = params.getDouble("obj.default_rho", obj.defaultRho, 0.0, 1.0);
    if (!(obj.defaultRho < 1.0))
        throwInputError(params.where("obj.default_rho"), "setting 'obj.default_rho' must be < 1");
    obj.clampRho = params.getDouble("obj.clamp_rho", obj.clampRho, 0.0, 0.999999);
    obj.twoSided = params.getBool("obj.two_sided", obj.twoSided);
    return obj;
}

PlyOptions plyOptions(const Params& params) {
    PlyOptions ply;
    ply.emission = params.getDouble("ply.emission", ply.emission, 0.0, 1e30);
    ply.defaultRho = params.getDouble("ply.default_rho", ply.defaultRho, 0.0, 1.0);
    if (!(ply.defaultRho < 1.0))
        throwInputError(params.where("ply.default_rho"), "setting 'ply.default_rho' must be < 1");
    return ply;
}

GltfOptions gltfOptions(const Params& params) {
    GltfOptions gltf;
    gltf.defaultRho = params.getDouble("gltf.default_rho", gltf.defaultRho, 0.0, 1.0);
    if (!(gltf.defaultRho < 1.0))
        throwInputError(params.where("gltf.default_rho"), "setting 'gltf.default_rho' must be < 1");
    gltf.clampRho = params.getDouble("gltf.clamp_rho", gltf.clampRho, 0.0, 0.999999);
    gltf.emissionScale = params.getDouble("gltf.emission_scale", gltf.emissionScale, 0.0, 1e30);
    gltf.maxFaces =
        size_t(params.getInt("gltf.max_faces", int64_t(gltf.maxFaces), 1, int64_t(1) << 40));
    return gltf;
}

MitsubaOptions mitsubaOptions(const Params& params) {
    MitsubaOptions m;
    m.resolution = int(params.getInt("mitsuba.resolution", m.resolution, 3, 4096));
    m.clampRho = params.getDouble("mitsuba.clamp_rho", m.clampRho, 0.0, 0.999999);
    m.defaultRho = params.getDouble("mitsuba.default_rho", m.defaultRho, 0.0, 0.999999);
    m.textureRho = params.getDouble("mitsuba.texture_rho", m.textureRho, 0.0, 0.999999);
    m.maxFaces =
        uint64_t(params.getInt("mitsuba.max_faces", int64_t(m.maxFaces), 1, int64_t(1) << 40));
    Params sub = params.subset("mitsuba.param");
    for (const auto& [key, entry] : sub.entries())
        m.params[key] = Params::valueToString(entry.value);
    params.markUsedPrefix("mitsuba.param");
    return m;
}

}  // namespace

// The format registry: a new loader adds its files in scene/ and one line here.
const std::vector<SceneFormat>& sceneFormats() {
    static const std::vector<SceneFormat> formats = {
        {"obj",
         {".obj"},
         [](const Params& p) { (void)objOptions(p); },
         [](const std::string& path, const Params& p) { return loadObj(path, objOptions(p)); }},
        {"mgf",
         {".mgf"},
         [](const Params& p) { (void)mgfOptions(p); },
         [](const std::string& path, const Params& p) { return loadMgf(path, mgfOptions(p)); }},
        {"ply",
         {".ply"},
         [](const Params& p) { (void)plyOptions(p); },
         [](const std::string& path, const Params& p) { return loadPly(path, plyOptions(p)); }},
        {"gltf",
         {".gltf", ".glb"},
         [](const Params& p) { (void)gltfOptions(p); },
         [](const std::string& path, const Params& p) { return loadGltf(path, gltfOptions(p)); }},
        {"mitsuba",
         {".xml"},
         [](const Params& p) { (void)mitsubaOptions(p); },
         [](const std::string& path, const Params& p) {
             return loadMitsuba(path, mitsubaOptions(p));
         }},
    };
    return formats;
}

Scene loadScene(const std::string& spec, const Params& params) {
    Timer timer;
    // Every key is read up front, whether or not it applies to this format,
    // so that the caller's reportUnused() only flags misspellings.
    for (const SceneFormat& f : sceneFormats()) f.readSettings(params);
    const std::string twoSided = params.getEnum("two_sided", "auto", {"auto", "all", "none"});
    bool validate = params.getBool("validate", true);
    const bool split = params.getBool("split_intersections", false);
    const double uniformRho =
        params.has("uniform_rho") ? params.getDouble("uniform_rho", 0.5, 0.0, 0.999999) : -1.0;

    Scene scene;
    if (isBuiltinName(spec)) {
        scene = makeBuiltin(spec);
    } else {
        std::filesystem::path path(spec);
        std::string ext = path.extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(),
                       [](unsigned char c) { return char(std::tolower(c)); });
        const SceneFormat* format = nullptr;
        std::string known;
        for (const SceneFormat& f : sceneFormats())
            for (const std::string& e : f.extensions) {
                if (e == ext) format = &f;
                known += (known.empty() ? "" : ", ") + e;
            }
        if (!format)
            throwInputError(SourceLocation{spec, 0, 0},
                            "unknown scene file extension '{}' (expected one of {}, or a "
                            "built-in name: cornell, furnace, plates:..., office:N)",
                            ext, known);
        // error_code forms: a name the system refuses (too long, ...) is an
        // input error, not a std::filesystem exception.
        std::error_code ec;
        if (!std::filesystem::exists(path, ec))
            throwInputError(SourceLocation{spec, 0, 0}, "scene file not found{}",
                            ec ? " (" + ec.message() + ")" : std::string());
        if (!std::filesystem::is_regular_file(path, ec))
            throwInputError(SourceLocation{spec, 0, 0},
                            "scene path is not a regular file (a folder or device)");
        scene = format->load(spec, params);
        scene.name = spec;
    }
    // Patches that pass through one another are cut along the intersection
    // (before back sides are made, so both sides get the same pieces).
    if (split) {
        Timer ts;
        SplitStats st = splitIntersections(scene);
        scene.stats.splitPatches = st.splitPatches;
        scene.stats.splitPieces = st.pieces;
        if (st.splitPatches > 0)
            spdlog::info(
                "split {} patches that pass through others into {} triangles ({} "
                "crossings, {} pieces thinner than the tolerance left out, {:.3g} in area; "
                "{:.2f} s)",
                st.splitPatches, st.pieces, st.crossings, st.thinPieces, st.thinArea,
                ts.seconds());
    }
    // Two-sided materials become front/back patch pairs (scene.h, Patch::twin).
    if (twoSided == "none") {
        for (Material& m : scene.materials) m.twoSided = false;
    } else {
        scene.addBackSides(twoSided == "all");
    }
    if (uniformRho >= 0.0) {
        for (Material& m : scene.materials) m.rho = RGB(uniformRho);
        for (Patch& p : scene.patches) p.rho = RGB(uniformRho);
    }
    if (validate) scene.validate();
    // The loaders grow the array by doubling; it lives as long as the solve.
    scene.patches.shrink_to_fit();
    scene.stats.loadSeconds = timer.seconds();
    return scene;
}

}  // namespace hrad::scene
