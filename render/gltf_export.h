// glTF 2.0 binary (.glb) export of a radiosity field's leaf elements, for
// Blender and web glTF viewers; the glTF counterpart of render/ply_export.h.
//
// Geometry: every leaf element becomes its own corner vertices (not shared
// between leaves, so a flat solution keeps its constant value per leaf) and
// one triangle (triangle leaves) or two (quad leaves, split along the 0-2
// diagonal). One mesh, one TRIANGLES primitive, uint32 indices, positions in
// the scene's own coordinates (float). The mesh hangs under a root node that
// turns the scene's up axis (Scene::upAxis: Z for MGF) into glTF's +Y (glTF
// 2.0 §3.4), so a z-up scene stands upright in a viewer; a scene with a
// camera gets a perspective camera node at that view (glTF cameras look down
// -Z with +Y up, §3.10, which is what glm::lookAt's inverse places).
//
// Colours. COLOR_0 (float RGB) is *linear* in glTF (§3.7.2.1), and viewers
// sRGB-encode it for display. hrad writes the radiosity tone mapped exactly as
// the PNG and the PLY vertex colours (render/image.h): exposure * B, clamped
// to [0, 1], but *before* the sRGB encoding, so that a viewer's own encoding
// gives the PNG's pixel values. The material is unlit (KHR_materials_unlit,
// base colour 1, single-sided: the back side of a two-sided surface is its
// own patch with the opposite winding), so viewers show COLOR_0 as it is
// instead of shading it a second time. A custom attribute _RADIOSITY (float
// RGB, glTF allows application attributes with a leading underscore, §3.7.2.1)
// carries the linear radiosity B in W/m^2 for scripts, as the PLY export's
// radiosity_r/g/b. asset.extras records the exposure and these conventions.
//
// Settings (GltfExportOptions; the callers read them from Params):
//   exposure     double  0      > 0 multiplies B before tone mapping; <= 0:
//                               the automatic rule of render/image.h over
//                               the leaves, area-weighted (the PLY export's)
//   tone         ToneMap unset  when set, the tone map (the PNG's), and
//                               exposure is ignored
//   interpolate  bool    false  vertex colours (and _RADIOSITY) are the
//                               corner values of render::VertexInterpolation
//                               (the render's `interpolated` reconstruction,
//                               Cohen & Wallace 1993 ch. 10) instead of the
//                               leaf's constant value
#pragma once

#include <cstdint>
#include <string>

#include <optional>

#include "render/image.h"
#include "render/smooth.h"
#include "scene/field.h"

namespace hrad::render {

struct GltfExportOptions {
    double exposure = 0.0;
    bool interpolate = false;
    std::optional<ToneMap> tone;
    SmoothSettings smooth;  ///< with interpolate
};

struct GltfCounts {
    uint64_t leaves = 0, vertices = 0, triangles = 0;
    double exposure = 0.0;  ///< the exposure used (chosen automatically when <= 0 was asked)
};

/// Writes the leaves of `field` as a binary glTF file. Throws hrad::InputError
/// naming the path when it cannot be written or exceeds GLB's 4 GiB.
GltfCounts writeGlb(const scene::RadiosityField& field, const std::string& path,
                    const GltfExportOptions& options = {});

}  // namespace hrad::render
