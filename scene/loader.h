// Scene loading entry point: built-in names and files chosen by extension.
//
//   cornell, furnace, plates:parallel:W:H:D, plates:perpendicular:W:H:L,
//   plates:occluded:W:H:D:S:Z,
//   office:N                      built-in procedural scenes (scene/builtin.h)
//   *.obj                         OBJ/MTL (tinyobjloader): Kd -> rho, Ke -> E
//   *.mgf                         Ward's Materials and Geometry Format
//   *.ply                         PLY, ASCII or binary, optional colours as rho
//   *.gltf, *.glb                 glTF 2.0 (tinygltf), see scene/gltf_loader.h
//   *.xml                         Mitsuba 3 (and 0.5/0.6) XML (scene/mitsuba_loader.h,
//                                 settings mitsuba.* listed there)
//
// Settings (Params keys, all optional):
//   mgf.resolution   int    16     segments around sph/cyl/cone/ring/torus
//   mgf.max_faces    int    2e7    most faces, and most statements executed after
//                                  xf/include expansion, an MGF file may yield
//   mgf.max_includes int   1e5    most `i` statements executed, repeats counted
//   obj.default_rho  double 0.5    grey reflectance for faces with no material
//   scene.clamp_rho  double 0.99   every format: reflectance channels >= 1 become this
//                                  (a warning per material); 0: an error at the file:line
//                                  (scene.h clampReflectance; replaces obj/gltf/mitsuba.clamp_rho)
//   mgf.white_point  string "E"    white of the xy -> RGB conversion: "E"
//                                  (equal energy, as Radiance/MGF) or "D65"
//   ply.emission     double 1.0    E of faces coloured pure white (255,255,255)
//   ply.default_rho  double 0.5    grey reflectance of faces without colour
//   mgf.default_sides int   1      `sides` of MGF materials that do not state it
//                                  (the MGF spec says 2; RenderPark forces 1)
//   obj.two_sided    bool   false  every OBJ material is two-sided
//   obj.texture_kd   string multiply map_Kd reflectance: Kd x texel (MTL spec) or
//                                  "replace": the texel alone
//   texture.max_mb   int    2048   MiB of decoded textures per scene (12 bytes a
//                                  texel), checked before decoding (scene/texture.h)
//   gltf.default_rho double 0.5    grey reflectance of glTF primitives without material
//   gltf.emission_scale double 1   multiplies glTF emission (E = pi * emissive)
//   gltf.max_faces   int    2e7    most triangles a glTF scene may yield after instancing
//   two_sided        string "auto" "auto": materials say which surfaces are two-
//                                  sided (MGF sides 2, ...); "all": every
//                                  surface; "none": ignore the flags (one-sided)
//   validate         bool   true   run Scene::validate() (rho range, emitter)
//   scene.missing    string "error" files the scene names that are not there (meshes,
//                                  includes, spectra, textures): "error" names them all
//                                  in one message; "skip" warns once per file and loads
//                                  the rest (scene/missing_files.h)
//   uniform_rho      double (unset) every material's and patch's reflectance becomes
//                                  this grey. A conservation check on any scene: with
//                                  one reflectance everywhere the light a solver hands
//                                  to the wrong surfaces is not lost or gained, so the
//                                  reflected power of two solvers differs only by what
//                                  their transfers lose or gain (in a closed scene it
//                                  is P_e rho / (1 - rho) exactly)
//   split_intersections      false  false, true or "unreachable". true splits patches
//                                  that pass through one another along their
//                                  intersection lines, so parts inside another object
//                                  become patches of their own (scene/triangulate.h
//                                  splitIntersections); real scenes cross a lot
//                                  (classroom.mgf 5,826 -> 11,720 patches, graz.mgf
//                                  13,948 -> 58,511, the bathroom 734 k -> 1.63 M with
//                                  its back sides). "unreachable" also cuts along
//                                  edges that lie inside other patches (a box's walls
//                                  standing on a floor), then keeps only the cuts
//                                  whose dark pieces light would otherwise reach
//                                  (splitWhereDark below; graz.mgf 556 of 4,491
//                                  patches, classroom.mgf none); it needs the ray
//                                  tracer, which the caller hands in
//                                  (transport::loadScene)
//   split_reach_rays int    256    rays per piece of that reachability pass
//   mesh.*                         discontinuity meshing (DiscontinuitySettings
//                                  below, transport/discontinuity.h): patches cut
//                                  along shadow boundaries before back sides are
//                                  made; needs the ray tracer (transport::loadScene)
//
// Every key is read whatever the format, so callers may reportUnused().
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/params.h"
#include "scene/scene.h"
#include "scene/triangulate.h"

namespace hrad::scene {

/// One scene file format. Adding a loader: its files in scene/ and one entry
/// in sceneFormats() (loader.cpp).
struct SceneFormat {
    const char* name;                     ///< "obj", "mgf", ...
    std::vector<std::string> extensions;  ///< lower case, with the dot
    /// Reads (and range-checks) every setting the format uses, so that
    /// Params::reportUnused() flags only misspellings whatever the format.
    void (*readSettings)(const Params&);
    Scene (*load)(const std::string& path, const Params&);
};

/// The registry of file formats, in the order they are listed to users.
const std::vector<SceneFormat>& sceneFormats();

/// Which patches of a scene light can reach, and where light would go next
/// from those it cannot (transport/reachability.h).
struct LightPaths {
    std::vector<uint8_t> reachable;  ///< per patch: 1 when light can reach it
    /// (s, r): r is unreachable and sees the front of s (also unreachable).
    std::vector<std::pair<uint32_t, uint32_t>> darkEdges;
};
/// Finds them with `rays` rays per patch. The loader casts no rays (scene/
/// sits below transport/); callers that can hand one in
/// (transport::loadScene) for split_intersections = "unreachable".
using ReachabilityFn = std::function<LightPaths(const Scene&, int rays)>;

/// Discontinuity meshing's settings (mesh.*), read here so that every
/// command knows the keys; the stage itself is transport/discontinuity.h.
struct DiscontinuitySettings {
    enum class Mode { Off, Emitters, EmittersOccluders };
    Mode mode = Mode::Off;   ///< mesh.discontinuity
    int maxCurves = 64;      ///< mesh.max_curves: cut segments per patch (longest kept)
    int maxOccluders = 32;   ///< mesh.max_occluders: per receiver and source (largest kept)
    int secondarySources = 4;  ///< mesh.secondary_sources (emitters+occluders)
    bool cullHidden = true;  ///< mesh.cull_hidden: drop critical surfaces others block
    double minCurve = 1e-3;  ///< mesh.min_curve: shortest segment / receiver diameter
    SourceLocation where;    ///< of mesh.discontinuity, for errors
};
DiscontinuitySettings readDiscontinuitySettings(const Params& params);

/// The meshing stage as the loader calls it: cuts `scene` (no back sides
/// yet) and fills `origin` (per patch of the result, the index of the patch
/// it is or is a piece of; pieces of a patch adjacent).
using MeshingFn = std::function<DiscontinuityStats(Scene& scene, const DiscontinuitySettings&,
                                                   std::vector<uint32_t>& origin)>;

/// split_intersections = "unreachable" (before back sides are made): every
/// crossing or touched patch is cut (splitIntersections with touching), a
/// copy of the cut scene gets its back sides (`makeSides`) and `reach` with
/// `rays` rays per patch, and a patch keeps its cut only where, kept whole,
/// it would bring light to a patch light cannot reach: a side of it has a
/// reachable piece, and one of its unreachable pieces is seen by a patch
/// that stays dark (its own side reaches nowhere, or its patch keeps its
/// cut; to the fixed point, since one kept cut can call for another).
/// Whole, such a patch is lit and shines into the closed space its piece
/// lies in (graz.mgf: a binder's cover through a paper block lights the
/// inside of the block; the binder's floor, on which the inward-facing faces
/// of a paper block stand, lights them). Every other crossing stays whole: a
/// chair leg through a lit floor hides a piece of the floor that only the
/// backs of the leg's one-sided walls see, and the stubs of legs under a
/// floor see only one another. Returns the kept cuts (splitPatches, pieces)
/// and the crossing or touched patches (candidates).
SplitStats splitWhereDark(Scene& scene, int rays, const std::function<void(Scene&)>& makeSides,
                          const ReachabilityFn& reach);

/// Loads a built-in scene by name or a file by extension; throws InputError
/// with file:line on malformed input. Fills scene.stats (incl. load time).
/// `reach` is needed only by split_intersections = "unreachable", `mesh`
/// only by mesh.discontinuity other than off.
Scene loadScene(const std::string& spec, const Params& params = {},
                const ReachabilityFn& reach = {}, const MeshingFn& mesh = {});

/// True when spec names a built-in scene rather than a file.
bool isBuiltinName(const std::string& spec);

}  // namespace hrad::scene
