// loadScene: built-in names, else files by extension (see loader.h).
#include "scene/loader.h"
#include "scene/texture.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>
#include <variant>

#include "core/error.h"
#include "core/log.h"
#include "core/suggest.h"
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

/// scene.clamp_rho, the reflectance rule of every format (scene.h
/// clampReflectance). The per-format keys it replaced are refused with its name.
double clampRho(const Params& params) {
    for (const char* old : {"obj.clamp_rho", "gltf.clamp_rho", "mitsuba.clamp_rho"})
        if (params.has(old)) {
            params.markUsed(old);
            throwInputError(params.where(old),
                            "setting '{}' is now 'scene.clamp_rho' (one rule for every format)",
                            old);
        }
    return params.getDouble(
        {"scene.clamp_rho",
         "every format: reflectance channels >= 1 (Kd 1, a white base colour) become this, "
         "with a warning per material (0: an error)"},
        0.99, 0.0, 0.999999);
}

// Each format's settings, read from Params (with range checks).
MgfOptions mgfOptions(const Params& params) {
    MgfOptions mgf;
    mgf.resolution = int(params.getInt(
        {"mgf.resolution", "MGF: segments around curved primitives (rings, cones, spheres)"},
        mgf.resolution, 3, 4096));
    mgf.whitePoint =
        params.getEnum({"mgf.white_point", "MGF: white point of colour conversion (E or D65)"},
                       mgf.whitePoint, {"E", "D65"});
    mgf.maxFaces = size_t(params.getInt(
        {"mgf.max_faces", "MGF: faces after xf/include expansion at most (a resource bound)"},
        int64_t(mgf.maxFaces), 1, int64_t(1) << 40));
    mgf.maxIncludes = size_t(params.getInt(
        {"mgf.max_includes", "MGF: include statements executed at most, repeats counted (a resource bound)"},
        int64_t(mgf.maxIncludes), 1, int64_t(1) << 40));
    mgf.defaultSides = int(params.getInt(
        {"mgf.default_sides", "MGF: sides of a material without a sides statement (1 or 2)"},
        mgf.defaultSides, 1, 2));
    mgf.clampRho = clampRho(params);
    return mgf;
}

/// texture.max_mb, read by every format that decodes textures.
uint64_t textureBudget(const Params& params) {
    return uint64_t(params.getInt({"texture.max_mb",
                                   "MiB the scene's decoded textures may take (12 bytes per "
                                   "texel; a resource bound, checked before decoding)"},
                                  2048, 1, int64_t(1) << 24))
           << 20;
}

ObjOptions objOptions(const Params& params) {
    ObjOptions obj;
    obj.textureBudget = textureBudget(params);
    obj.defaultRho =
        params.getDouble({"obj.default_rho", "OBJ: reflectance of faces without a material"},
                         obj.defaultRho, 0.0, 1.0);
    if (!(obj.defaultRho < 1.0))
        throwInputError(params.where("obj.default_rho"), "setting 'obj.default_rho' must be < 1");
    obj.clampRho = clampRho(params);
    obj.twoSided = params.getBool({"obj.two_sided", "OBJ: every face two-sided"}, obj.twoSided);
    obj.textureReplacesKd =
        params.getEnum({"obj.texture_kd",
                        "OBJ: reflectance of a map_Kd material: multiply (Kd x texel, the MTL "
                        "spec) or replace (the texel alone)"},
                       "multiply", {"multiply", "replace"}) == "replace";
    return obj;
}

PlyOptions plyOptions(const Params& params) {
    PlyOptions ply;
    ply.emission = params.getDouble({"ply.emission", "PLY: emission of faces marked emitting"},
                                    ply.emission, 0.0, 1e30);
    ply.defaultRho = params.getDouble(
        {"ply.default_rho", "PLY: reflectance of faces without colour"}, ply.defaultRho, 0.0, 1.0);
    if (!(ply.defaultRho < 1.0))
        throwInputError(params.where("ply.default_rho"), "setting 'ply.default_rho' must be < 1");
    ply.clampRho = clampRho(params);
    return ply;
}

GltfOptions gltfOptions(const Params& params) {
    GltfOptions gltf;
    gltf.textureBudget = textureBudget(params);
    gltf.defaultRho =
        params.getDouble({"gltf.default_rho", "glTF: reflectance of primitives without a material"},
                         gltf.defaultRho, 0.0, 1.0);
    if (!(gltf.defaultRho < 1.0))
        throwInputError(params.where("gltf.default_rho"), "setting 'gltf.default_rho' must be < 1");
    gltf.clampRho = clampRho(params);
    gltf.emissionScale = params.getDouble(
        {"gltf.emission_scale", "glTF: factor on emissive colours (radiosity units)"},
        gltf.emissionScale, 0.0, 1e30);
    gltf.maxFaces =
        size_t(params.getInt({"gltf.max_faces", "glTF: faces at most (a resource bound)"},
                             int64_t(gltf.maxFaces), 1, int64_t(1) << 40));
    return gltf;
}

MitsubaOptions mitsubaOptions(const Params& params) {
    MitsubaOptions m;
    m.textureBudget = textureBudget(params);
    m.resolution = int(params.getInt(
        {"mitsuba.resolution", "Mitsuba: segments around analytic shapes"}, m.resolution, 3, 4096));
    m.clampRho = clampRho(params);
    m.defaultRho =
        params.getDouble({"mitsuba.default_rho", "Mitsuba: reflectance of shapes without a BSDF"},
                         m.defaultRho, 0.0, 0.999999);
    m.textureRho = params.getDouble(
        {"mitsuba.texture_rho", "Mitsuba: reflectance standing in for a textured BSDF"},
        m.textureRho, 0.0, 0.999999);
    m.maxFaces =
        uint64_t(params.getInt({"mitsuba.max_faces", "Mitsuba: faces at most (a resource bound)"},
                               int64_t(m.maxFaces), 1, int64_t(1) << 40));
    m.maxInflatedBytes =
        uint64_t(params.getInt({"mitsuba.max_inflated_mb",
                                "Mitsuba: MiB the scene's .serialized meshes may inflate to (a "
                                "resource bound)"},
                               int64_t(m.maxInflatedBytes >> 20), 1, int64_t(1) << 24))
        << 20;
    Params sub = params.subset("mitsuba.param");
    for (const auto& [key, entry] : sub.entries()) {
        m.params[key] = Params::valueToString(entry.value);
        sub.recordAsGiven({key, "Mitsuba: a $" + key + " of the scene file, set from outside"});
    }
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

namespace {

enum class SplitMode { Off, All, Unreachable };

/// split_intersections: false, true, or "unreachable".
SplitMode readSplitMode(const Params& params) {
    const Params::Key key{"split_intersections",
                          "cut patches that pass through one another along the crossing (true), "
                          "only where light cannot reach (\"unreachable\"), or keep them whole"};
    if (!params.has(key.name) || std::holds_alternative<bool>(params.entries().at(key.name).value))
        return params.getBool(key, false) ? SplitMode::All : SplitMode::Off;
    const auto& v = params.entries().at("split_intersections").value;
    const auto* text = std::get_if<std::string>(&v);
    params.markUsed("split_intersections");
    if (!text || *text != "unreachable")
        throwInputError(params.where("split_intersections"),
                        "setting 'split_intersections' = '{}' must be true, false or "
                        "\"unreachable\"",
                        Params::valueToString(v));
    return SplitMode::Unreachable;
}

}  // namespace

DiscontinuitySettings readDiscontinuitySettings(const Params& params) {
    Params::Scope scope(params, "discontinuity meshing");
    DiscontinuitySettings d;
    const std::string mode = params.getEnum(
        {"mesh.discontinuity",
         "cut patches along the shadow boundaries (EV/VE events) cast by emitters, or by "
         "emitters and the largest reflectors, before the hierarchy is built"},
        "off", {"off", "emitters", "emitters+occluders"});
    d.mode = mode == "off"        ? DiscontinuitySettings::Mode::Off
             : mode == "emitters" ? DiscontinuitySettings::Mode::Emitters
                                  : DiscontinuitySettings::Mode::EmittersOccluders;
    d.where = params.where("mesh.discontinuity");
    d.maxCurves = int(params.getInt(
        {"mesh.max_curves", "discontinuity meshing: cut segments per patch at most (longest kept)"},
        d.maxCurves, 1, 4096));
    d.maxOccluders = int(params.getInt(
        {"mesh.max_occluders",
         "discontinuity meshing: occluders per receiver and source at most (largest kept)"},
        d.maxOccluders, 1, 1 << 20));
    d.secondarySources = int(params.getInt(
        {"mesh.secondary_sources",
         "discontinuity meshing (emitters+occluders): reflectors of largest area x reflectance "
         "that cast curves like emitters"},
        d.secondarySources, 0, 4096));
    d.cullHidden = params.getBool(
        {"mesh.cull_hidden",
         "discontinuity meshing: drop curves whose critical surface other surfaces block (rays)"},
        d.cullHidden);
    d.minCurve = params.getDouble(
        {"mesh.min_curve",
         "discontinuity meshing: shortest cut segment, as a fraction of the receiver's diameter"},
        d.minCurve, 1e-9, 0.5);
    return d;
}

namespace {

/// After discontinuity meshing and makeSides: each patch's index in the
/// scene loaded without meshing (Scene::sourcePatch). Fronts map through
/// `origin`; addBackSides appends the twins in front order, so the back of
/// input patch i is nInput + (the number of input patches before i that got
/// one).
std::vector<uint32_t> sourceIndex(const Scene& scene, const std::vector<uint32_t>& origin,
                                  size_t nInput) {
    const size_t nFront = origin.size();
    std::vector<uint8_t> hasBack(nInput, 0);
    for (size_t b = nFront; b < scene.patches.size(); ++b)
        hasBack[origin[scene.patches[b].twin]] = 1;
    std::vector<uint32_t> backIndex(nInput, UINT32_MAX);
    uint32_t next = uint32_t(nInput);
    for (size_t i = 0; i < nInput; ++i)
        if (hasBack[i]) backIndex[i] = next++;
    std::vector<uint32_t> src(scene.patches.size());
    for (size_t k = 0; k < scene.patches.size(); ++k)
        src[k] = k < nFront ? origin[k] : backIndex[origin[scene.patches[k].twin]];
    return src;
}

}  // namespace

// split_intersections = "unreachable" (loader.h says which cuts are kept).
SplitStats splitWhereDark(Scene& scene, int rays, const std::function<void(Scene&)>& makeSides,
                          const ReachabilityFn& reach) {
    // One copy: cut, then given its back sides (appended after the fronts,
    // so the first nCut patches stay the cut scene's pieces).
    Scene probe = scene;
    std::vector<uint32_t> origin;
    SplitStats st = splitIntersections(probe, &origin, /*touching=*/true);
    st.candidates = st.splitPatches;
    if (st.splitPatches == 0) return st;
    const size_t nCut = probe.patches.size();
    makeSides(probe);
    const LightPaths paths = reach(probe, rays);
    if (paths.reachable.size() != probe.patches.size())
        throw std::logic_error("split_intersections: reachability of the wrong size");
    const std::vector<uint8_t>& lit = paths.reachable;
    // Input patch and side (0 front, 1 back) of each probe patch.
    auto inputOf = [&](uint32_t k) -> std::pair<uint32_t, int> {
        if (k < nCut) return {origin[k], 0};
        return {origin[probe.patches[k].twin], 1};
    };
    const size_t n = scene.patches.size();
    std::vector<uint8_t> isCut(n, 0);
    for (size_t k = 0; k + 1 < nCut; ++k)
        if (origin[k + 1] == origin[k]) isCut[origin[k]] = 1;
    // reached[i] bit `side`: a piece of that side of input patch i is
    // reachable (whole, that side is lit).
    std::vector<uint8_t> reached(n, 0);
    for (uint32_t k = 0; k < uint32_t(probe.patches.size()); ++k)
        if (lit[k]) {
            const auto [i, side] = inputOf(k);
            reached[i] |= uint8_t(1 << side);
        }
    // A cut is kept where a dark piece s of a side that is lit elsewhere is
    // seen by a patch r that stays dark: r's own side has no reachable piece,
    // or r's patch keeps its cut. Keeping a cut can make another necessary
    // (the stub of a leg under a floor sees other stubs, which are dark only
    // if their legs stay cut), so the rule runs to its fixed point; it only
    // adds cuts, so it ends.
    std::vector<uint8_t> keep(n, 0);
    for (bool changed = true; changed;) {
        changed = false;
        for (const auto& [s, r] : paths.darkEdges) {
            const auto [i, side] = inputOf(s);
            if (!isCut[i] || keep[i] || !(reached[i] & (1 << side))) continue;
            const auto [j, rside] = inputOf(r);
            if (j == i) continue;
            if (!(reached[j] & (1 << rside)) || keep[j]) {
                keep[i] = 1;
                changed = true;
            }
        }
    }
    std::vector<Patch> out;
    uint64_t kept = 0, pieces = 0;
    out.reserve(n);
    size_t k = 0;
    for (uint32_t i = 0; i < uint32_t(n); ++i) {
        const size_t first = k;
        while (k < nCut && origin[k] == i) ++k;
        if (first < k && keep[i]) {
            ++kept;
            for (size_t j = first; j < k; ++j) {
                out.push_back(probe.patches[j]);
                out.back().twin = UINT32_MAX;  // the loader makes the sides again
                ++pieces;
            }
        } else {
            out.push_back(scene.patches[i]);
        }
    }
    scene.patches = std::move(out);
    // The pieces' UV rows live in the probe, whose rows extend the scene's.
    scene.cornerUVs = std::move(probe.cornerUVs);
    st.splitPatches = kept;
    st.pieces = pieces;
    return st;
}

Scene loadScene(const std::string& spec, const Params& params, const ReachabilityFn& reach,
                const MeshingFn& mesh) {
    Timer timer;
    // Every key is read up front, whether or not it applies to this format,
    // so that the caller's reportUnused() only flags misspellings.
    for (const SceneFormat& f : sceneFormats()) {
        Params::Scope scope(params, std::string("loader ") + f.name);
        f.readSettings(params);
    }
    Params::Scope scope(params, "scene loading");
    const std::string twoSided = params.getEnum(
        {"two_sided", "two-sided surfaces: auto (follow the materials), all, or none"}, "auto",
        {"auto", "all", "none"});
    bool validate = params.getBool(
        {"validate", "check the scene when loading (false skips the checks, for hrad info)"}, true);
    const SplitMode split = readSplitMode(params);
    const int splitRays = int(params.getInt(
        {"split_reach_rays", "rays per piece to find unreachable pieces after split_intersections"},
        256, 1, 1 << 20));
    const bool skipMissing =
        params.getEnum({"scene.missing",
                        "files the scene names that are not there (meshes, includes, spectra, "
                        "textures): error (list them all) or skip (warn and load the rest)"},
                       "error", {"error", "skip"}) == "skip";
    const double uniformRho = params.getDouble(
        {"uniform_rho", "override every material's reflectance with this grey (-1: the scene's)"},
        -1.0, -1.0, 0.999999);
    const DiscontinuitySettings disc = readDiscontinuitySettings(params);

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
        if (!format) {
            // "cornel" or "ofice:2": the nearest built-in names (core/suggest.h).
            const std::string hint =
                didYouMean(nearestNames(spec.substr(0, spec.find(':')), builtinNames()));
            throwInputError(SourceLocation{spec, 0, 0},
                            "{} (expected a file ending in one of {}, or a built-in name: {})",
                            hint.empty() ? fmt::format("unknown scene file extension '{}'", ext)
                                         : fmt::format("unknown scene '{}'; {}", spec, hint),
                            known, fmt::format("{}", fmt::join(builtinNames(), ", ")));
        }
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
        scene.stats.missingFiles.apply(skipMissing, scene.stats.warnings);  // scene/missing_files.h
        // A face too large for doubles is not degenerate: dropping it would
        // load a different scene without a word (issue 64).
        if (scene.stats.overflowFaces > 0)
            throwInputError(SourceLocation{spec, 0, 0},
                            "{} faces are too large for double precision: their areas overflow "
                            "(coordinates or transforms beyond about 1e150); rescale the scene",
                            scene.stats.overflowFaces);
    }
    // Two-sided materials become front/back patch pairs (scene.h, Patch::twin).
    auto makeSides = [&](Scene& s) {
        if (twoSided == "none") {
            for (Material& m : s.materials) m.twoSided = false;
        } else {
            s.addBackSides(twoSided == "all");
        }
    };
    // Patches that pass through one another are cut along the intersection
    // (before back sides are made, so both sides get the same pieces).
    if (split == SplitMode::Unreachable && !reach)
        throwInputError(params.where("split_intersections"),
                        "split_intersections = \"unreachable\" needs the ray tracer; this "
                        "command loads scenes without it");
    if (split != SplitMode::Off) {
        Timer ts;
        const SplitStats st = split == SplitMode::All
                                  ? splitIntersections(scene)
                                  : splitWhereDark(scene, splitRays, makeSides, reach);
        scene.stats.splitPatches = st.splitPatches;
        scene.stats.splitPieces = st.pieces;
        scene.stats.splitCandidates = st.candidates;
        if (split == SplitMode::All && st.splitPatches > 0)
            spdlog::info(
                "split {} patches that pass through others into {} triangles ({} crossings, "
                "{} pieces thinner than the tolerance left out, {:.3g} in area; {:.2f} s)",
                st.splitPatches, st.pieces, st.crossings, st.thinPieces, st.thinArea,
                ts.seconds());
        if (split == SplitMode::Unreachable && st.candidates > 0)
            spdlog::info(
                "split {} of the {} patches that pass through or touch others, those whose "
                "dark pieces light would otherwise reach, into {} triangles ({} rays per "
                "piece; {:.2f} s)",
                st.splitPatches, st.candidates, st.pieces, splitRays, ts.seconds());
    }
    // Discontinuity meshing, after the crossings are cut and before back
    // sides: both sides of a two-sided patch get the same pieces.
    std::vector<uint32_t> meshOrigin;
    const size_t nInput = scene.patches.size();
    if (disc.mode != DiscontinuitySettings::Mode::Off) {
        if (!mesh)
            throwInputError(disc.where,
                            "mesh.discontinuity needs the ray tracer; this command loads scenes "
                            "without it");
        scene.stats.discontinuity = mesh(scene, disc, meshOrigin);
    }
    makeSides(scene);
    if (scene.stats.discontinuity.cutPatches > 0)
        scene.sourcePatch = sourceIndex(scene, meshOrigin, nInput);
    if (uniformRho >= 0.0) {
        // One grey everywhere: textures no longer modulate anything.
        for (Material& m : scene.materials) {
            m.rho = RGB(uniformRho);
            m.diffuseMap.texture = -1;
        }
        for (Patch& p : scene.patches) p.rho = RGB(uniformRho);
    } else if (!scene.textures.empty()) {
        // The solve sees each textured patch's own mean (scene/texture.h).
        applyTextureMeans(scene);
    }
    if (validate) scene.validate();
    // The loaders grow the array by doubling; it lives as long as the solve.
    scene.patches.shrink_to_fit();
    scene.stats.loadSeconds = timer.seconds();
    return scene;
}

}  // namespace hrad::scene
