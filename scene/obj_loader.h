// Wavefront OBJ/MTL loader (tinyobjloader).
//
// Kd -> rho, Ke -> emission (E, W/m^2), material names kept. Faces are read as
// polygons (tinyobjloader's triangulate = false) so quads stay quads; every
// face goes through addPolygon (scene/triangulate.h). Faces without a
// material get one grey material named "default" with rho = defaultRho
// (Params key obj.default_rho) and one warning with their count
// (stats.defaultMaterialFaces). Before tinyobjloader runs, a cheap pre-scan of
// the text checks what tinyobjloader accepts silently, so errors carry a line:
// non-finite or malformed vertex coordinates and face indices that name no
// vertex. A material with rho outside [0, 1) is reported at its `newmtl` line
// in the .mtl file. map_Kd: per-vertex UVs (vt) on faces of textured
// materials and the decoded texture (scene/texture.h); rho(x) = Kd * texel.
#pragma once

#include <string>

#include "scene/scene.h"

namespace hrad::scene {

struct ObjOptions {
    double defaultRho = 0.5;  ///< reflectance of faces with no material
    /// Reflectance channels >= 1 (Kd 1 in scenes made for path tracers)
    /// become this, one warning per material; 0: an error (scene.clamp_rho,
    /// the rule of every loader: scene.h clampReflectance).
    double clampRho = 0.99;
    /// Every material is two-sided (OBJ has no per-material flag); emitters
    /// still emit from the front only.
    bool twoSided = false;
    /// obj.texture_kd = replace: rho(x) is the map_Kd texel alone, not Kd
    /// times it (exporters that write the texture's mean colour as Kd).
    bool textureReplacesKd = false;
    /// UVs on every face that has them, textured or not (Mitsuba's obj
    /// shapes, whose BSDF comes from the XML), and whether map_Kd is read.
    bool keepUVs = false;
    bool readTextures = true;
    uint64_t textureBudget = uint64_t(2048) << 20;  ///< texture.max_mb, decoded bytes
};

/// Loads an OBJ file (and its MTL libraries); throws InputError with file:line.
Scene loadObj(const std::string& path, const ObjOptions& options = {});

}  // namespace hrad::scene
