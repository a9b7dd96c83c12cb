// The scene model: root patches, materials, camera.
//
// A root patch is an input triangle or a planar convex quad (DESIGN.md "Core
// model"). Everything else (n-gons, non-planar and non-convex polygons) is
// triangulated by the loaders (scene/triangulate.h). Reflectance rho and
// emission E live on the patch (copied from its material) so that the hot
// loops of every solver read one flat array.
//
// Units: emission is radiosity in W/m^2 (per RGB channel); lengths are in the
// scene file's units and areas in their square. Emitted power of a patch is
// E * area.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/types.h"
#include "core/warning_log.h"
#include "scene/lights/light.h"
#include "scene/missing_files.h"

namespace hrad::scene {

enum class PatchKind : uint8_t { Triangle = 3, Quad = 4 };

struct Texture;  // scene/texture.h

/// How a material uses a diffuse texture: rho(x) = scale * texel(uv(x))
/// (scene/texture.h).
struct TextureBinding {
    int32_t texture = -1;  ///< index in Scene::textures, -1 none
    RGB scale{1.0};
    /// Patch means >= 1 in a channel become this (the loader's clamp_rho);
    /// 0 makes them an error naming clampKey.
    double clampRho = 0.99;
    const char* clampKey = "clamp_rho";
};

struct Material {
    std::string name;
    RGB rho{0.0};       ///< diffuse reflectance, each channel in [0, 1)
    RGB emission{0.0};  ///< emitted radiosity E (W/m^2)
    /// Seen and lit from both sides (MGF `sides 2`, Mitsuba `twosided`, glTF
    /// `doubleSided`, the `two_sided` setting). Scene::addBackSides() gives
    /// every patch of such a material a back-side twin (see Patch::twin).
    bool twoSided = false;
    /// For a two-sided material: whether the back side emits too. Mitsuba's
    /// area emitters emit from the front only; MGF and glTF materials are the
    /// same on both faces.
    bool emitsBothSides = false;
    /// The diffuse texture (OBJ map_Kd, Mitsuba bitmap, glTF baseColorTexture);
    /// rho is then its mean over all texels times the scale, the fallback for
    /// patches without UVs (scene/texture.h).
    TextureBinding diffuseMap{};
    bool isEmitter() const { return emission.r > 0 || emission.g > 0 || emission.b > 0; }
};

/// The one reflectance rule of every loader (setting scene.clamp_rho, read
/// in scene/loader.cpp): a channel >= 1 (an MTL `Kd 1`, a glTF base colour
/// 1, a Mitsuba reflectance 1, a saturated MGF colour, a white PLY float
/// colour) becomes `clamp`, or, with clamp = 0, is an error the loader
/// reports at its file:line ending in kClampRhoHint. Radiosity needs rho < 1
/// (a closed scene of rho = 1 has no finite solution).
enum class RhoCheck { Fine, Clamped, TooLarge };
RhoCheck clampReflectance(RGB& rho, double clamp);
/// "reflectance >= 1 clamped to 0.99 (scene.clamp_rho)", for the warning.
std::string clampedNote(double clamp);
inline constexpr const char* kClampRhoHint = "set scene.clamp_rho, e.g. 0.99, to clamp";

/// A root patch. Vertices are counter-clockwise seen from the front (the side
/// the normal points to). For a quad, v[0..3] are in order around the boundary
/// and the patch is planar and convex; the parametrisation is bilinear:
///   p(u,v) = (1-u)(1-v) v0 + u(1-v) v1 + u v v2 + (1-u) v v3.
/// For a triangle, p(u,v) = v0 + u (v1-v0) + v (v2-v0) with u,v >= 0, u+v <= 1.
struct Patch {
    PatchKind kind = PatchKind::Triangle;
    bool backSide = false;  ///< see twin below
    uint32_t material = 0;
    std::array<Vec3, 4> v{};  ///< v[3] unused (equal to v[2]) for triangles
    Vec3 normal{0.0};         ///< unit normal
    double area = 0.0;
    RGB rho{0.0};
    RGB emission{0.0};
    /// Two-sided surfaces are two patches on the same polygon with opposite
    /// normals (RenderPark's "twin" faces): each side has its own elements
    /// and radiosity, and nothing else changes in the solvers. `twin` is the
    /// other side's index (UINT32_MAX for a one-sided patch); `backSide`
    /// marks the copy made by Scene::addBackSides(). Visibility keeps one
    /// polygon per pair and reports the side a ray arrives at.
    uint32_t twin = UINT32_MAX;
    /// Row of Scene::cornerUVs holding this patch's texture coordinates at
    /// v[0..3] (UINT32_MAX: none); a back side's row follows its winding.
    uint32_t uvs = UINT32_MAX;

    int numVertices() const { return kind == PatchKind::Quad ? 4 : 3; }
    bool isEmitter() const { return emission.r > 0 || emission.g > 0 || emission.b > 0; }
    /// Point at parametric coordinates (u,v) (see above).
    Vec3 point(double u, double v) const;
    Vec3 centroid() const;
};

/// The image axis a scene file's field of view is measured along (Mitsuba's
/// fov_axis): x (horizontal), y (vertical), the diagonal, or whichever of x
/// and y is the smaller / larger dimension of the image.
enum class FovAxis { X, Y, Diagonal, Smaller, Larger };

struct Camera {
    Vec3 eye{0.0, 0.0, 1.0};
    Vec3 target{0.0, 0.0, 0.0};
    Vec3 up{0.0, 1.0, 0.0};
    /// Vertical field of view in degrees; for a camera with a film, at the
    /// film's aspect (filmWidth / filmHeight).
    double fovYDegrees = 40.0;
    /// The film of the scene file's sensor in pixels (Mitsuba's
    /// hdrfilm/ldrfilm width and height; 768 x 576, Mitsuba's default, for a
    /// sensor without a film); 0 x 0 for a camera without one (built-in
    /// scenes, glTF, automatic and explicit cameras). It is the default image
    /// size of `hrad solve` and `hrad render` (render/render.h).
    int filmWidth = 0, filmHeight = 0;
    /// With a film: the axis along which the scene file gave the field of
    /// view. An image of another aspect than the film's keeps the fov along
    /// this axis (what Mitsuba renders when the film size is changed), so a
    /// 16:9 scene rendered square with fov_axis x keeps its horizontal fov.
    FovAxis fovAxis = FovAxis::Y;
    /// Where the film (or the sensor, without a film) is in the scene file,
    /// for errors about the image size it implies.
    SourceLocation filmWhere;

    /// Vertical field of view (degrees) of an image of width x height
    /// pixels: fovYDegrees when the camera has no film or the aspect is the
    /// film's; otherwise the fov along fovAxis (resolved on the film's
    /// aspect) carried over to the image's aspect.
    double fovYDegreesFor(int width, int height) const;
};

struct Bounds3 {
    Vec3 lo{1e300}, hi{-1e300};
    void expand(const Vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    bool valid() const { return lo.x <= hi.x; }
    Vec3 extent() const { return hi - lo; }
    Vec3 center() const { return 0.5 * (lo + hi); }
    double diagonal() const { return valid() ? glm::length(hi - lo) : 0.0; }
};

/// What discontinuity meshing cut (transport/discontinuity.h), in
/// summary.json's scene_info.discontinuity and the log.
struct DiscontinuityStats {
    uint64_t sources = 0;          ///< emitters (and secondary sources) casting curves
    uint64_t pairs = 0;            ///< (receiver, source) pairs looked at
    uint64_t occluders = 0;        ///< candidate occluders over all pairs (after the shaft test)
    uint64_t occludersDropped = 0; ///< candidates over mesh.max_occluders, left out
    uint64_t events = 0;           ///< EV and VE critical surfaces that reach a receiver
    uint64_t hidden = 0;           ///< of them, blocked by other surfaces (mesh.cull_hidden)
    uint64_t curvesDropped = 0;    ///< segments over mesh.max_curves on their receiver
    uint64_t curves = 0;           ///< segments handed to the arrangements
    uint64_t cutPatches = 0;       ///< patches replaced by their pieces
    uint64_t pieces = 0;           ///< triangles that replaced them
    uint64_t faces = 0;            ///< arrangement faces on the cut patches
    uint64_t thin = 0;             ///< rounding slivers left out
    double thinArea = 0.0;         ///< their area
    double seconds = 0.0;
};

/// Counters filled by loaders, reported by `hrad info`.
struct LoadStats {
    uint64_t inputFaces = 0;         ///< faces read from the file (before triangulation)
    uint64_t droppedDegenerate = 0;  ///< faces of (near) zero area dropped
    /// faces whose area or normal overflows a double (coordinates past about
    /// 1e150): not degenerate, so loadScene refuses the scene (issue 64)
    uint64_t overflowFaces = 0;
    uint64_t triangulatedFaces = 0;  ///< faces that had to be triangulated
    uint64_t defaultMaterialFaces = 0;
    uint64_t ignoredStatements = 0;  ///< e.g. MGF rs/ts
    uint64_t splitPatches = 0;       ///< patches cut where others pass through them
    uint64_t splitPieces = 0;        ///< the triangles that replaced them
    /// split_intersections = "unreachable": the patches that cross or touch
    /// others, of which splitPatches kept their cut (loader.h splitWhereDark)
    uint64_t splitCandidates = 0;
    double loadSeconds = 0.0;
    DiscontinuityStats discontinuity;
    WarningLog warnings;  ///< counted, not repeated (core/warning_log.h)
    /// Files the scene names that are not there, skipped by the loader;
    /// loadScene applies scene.missing (scene/missing_files.h).
    MissingFiles missingFiles;
    /// Emitters the loader could not use (an envmap, a point light, an area
    /// emitter on no shape), "type (file:line)", the first kMaxDropped of
    /// droppedEmitterCount: a scene left without emitter names them.
    static constexpr size_t kMaxDropped = 8;
    std::vector<std::string> droppedEmitters;
    uint64_t droppedEmitterCount = 0;
    void dropEmitter(const std::string& type, const std::string& where) {
        if (droppedEmitters.size() < kMaxDropped) droppedEmitters.push_back(type + " (" + where + ")");
        ++droppedEmitterCount;
    }
};

class Scene {
  public:
    std::string name;    ///< built-in name or file path
    std::string source;  ///< "builtin" or the loader used
    std::vector<Patch> patches;
    std::vector<Material> materials;
    std::optional<Camera> camera;
    /// The format's up axis (0 x, 1 y, 2 z) for the automatic camera: Y for
    /// OBJ, PLY and glTF (their conventions), Z for MGF (Ward's examples and
    /// RenderPark's scenes are z-up).
    int upAxis = 1;
    LoadStats stats;
    /// Discontinuity meshing (transport/discontinuity.h) replaces patches by
    /// pieces; sourcePatch[p] is then the index patch p (a piece or a whole
    /// patch) has in the same scene loaded without it (back sides included:
    /// the back of a piece maps to the back of its patch), so that metrics
    /// and references compare per original patch. Empty: no meshing, every
    /// patch is its own source.
    std::vector<uint32_t> sourcePatch;
    uint32_t sourceOf(uint32_t p) const { return sourcePatch.empty() ? p : sourcePatch[p]; }
    /// Number of patches of the scene without meshing (patches.size() when empty).
    size_t numSourcePatches() const;
    /// Decoded diffuse textures (Material::diffuseMap), shared by copies.
    std::vector<std::shared_ptr<const Texture>> textures;
    /// Texture coordinates per patch corner (Patch::uvs), v up (texture.h).
    std::vector<std::array<glm::vec2, 4>> cornerUVs;
    /// Non-area lights (point, spot, sun, environments; scene/lights/light.h),
    /// filled by loaders, shared by copies. Area emitters are patches.
    LightList lights;

    uint32_t addMaterial(Material m);
    /// Adds a triangle or quad with material index; computes normal and area.
    /// Returns false (and adds nothing) when the face is degenerate.
    bool addTriangle(const Vec3& a, const Vec3& b, const Vec3& c, uint32_t material);
    bool addQuad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, uint32_t material);

    /// Copies rho/emission from materials onto patches (after materials change);
    /// a back side gets emission only when its material emitsBothSides.
    void applyMaterials();
    /// Appends a back-side twin (reversed winding, negated normal) for every
    /// one-sided patch whose material is twoSided, or for every patch when
    /// `all` is set. Returns the number of twins added. Idempotent.
    size_t addBackSides(bool all = false);
    /// Number of back-side twins (patches made by addBackSides()).
    size_t numBackSides() const;
    /// The patch that carries the polygon in the ray-tracing structures: the
    /// front side of a pair, or the patch itself.
    uint32_t frontOf(uint32_t i) const { return patches[i].backSide ? patches[i].twin : i; }
    Bounds3 bounds() const;
    double totalArea() const;
    RGB emittedPower() const;  ///< sum of E * area
    size_t numEmitters() const;
    size_t count(PatchKind k) const;

    /// Load-time validation (nori's Scene::activate()): finite coordinates,
    /// rho in [0,1) per channel on every used material, at least one emitter.
    /// Throws InputError naming the material or the problem.
    void validate() const;

  private:
    /// Shared by addTriangle (v[3] == v[2]) and addQuad.
    bool addPolygonPatch(PatchKind kind, const Vec3 (&v)[4], uint32_t material);
};

/// Relative area below which a face counts as degenerate (times bbox diagonal^2).
inline constexpr double kDegenerateAreaRel = 1e-14;

}  // namespace hrad::scene
