// Lightmaps: the reconstructed radiosity baked into a texture atlas, for any
// glTF viewer or game engine ("the basis for light mapping", Cohen & Wallace
// 1993; issue 60 item 3).
//
// Charts. Every root patch's parametric domain (scene/element.h) is one chart,
// a w x h rectangle of texels with w = ceil(|v1 - v0| d) and h = ceil(|v3 -
// v0| d) (|v2 - v0| for triangles, whose chart is the lower-left half), d the
// texel density in texels per scene unit. Charts are packed with stb_rect_pack
// (Debian libstb-dev; skyline, no rotation) with `gutter` texels on every
// side. Texel (i, j) of a chart holds the field at its centre, u = (i + 1/2) /
// w, v = (j + 1/2) / h, clamped to the patch's domain, gutters and the unused
// half of a triangle's chart included: a texel outside the domain repeats the
// value at the nearest border point, so bilinear filtering (and mip levels up
// to about log2(gutter)) never mixes in a neighbouring chart. Values are the
// smooth reconstruction (render/smooth.h) or, for flat, the leaf values.
// Seams: both sides of a border of one smooth surface read the same C0
// vertex values, so the lightmap is continuous across charts up to the
// field's change over one texel (tests/render/lightmap_test.cpp).
//
// Density: `density` > 0 fixes it and the atlas grows (powers of two from
// `size`) until the charts fit; 0 picks the largest density for which they fit
// into size x size (bisection over d).
//
// Settings (Params keys below "render"):
//   lightmap_size     int    1024  atlas width = height in texels (--lightmap RES)
//   lightmap_density  double 0     texels per scene unit (metre); 0: fit the atlas
//   lightmap_gutter   int    2     texels around each chart
//   lightmap_texels   string "radiosity"  what texels of textured patches hold
//                                  (render/texturing.h): "radiosity" E + rho(x) H,
//                                  the texture multiplied in at the texel; or
//                                  "irradiance" H = (B - E) / rho_bar (each
//                                  leaf's own rho under hr.texture_rho =
//                                  element, render/texturing.h), for an
//                                  engine that multiplies its own base texture
//                                  (lightmap.exr/png). The .glb's unlit material
//                                  always shows E + rho(x) H (core glTF has no
//                                  product of two textures), so it stays viewable
//   textures          string "on"  render.textures; off: B as solved everywhere
//   texture_filter    string "mip" render.texture_filter: the texture filtered
//                                  over each atlas texel (texturing.h)
#pragma once

#include <string>
#include <vector>

#include "core/params.h"
#include "render/image.h"
#include "render/smooth.h"
#include "render/texturing.h"
#include "scene/field.h"

namespace hrad::render {

struct LightmapSettings {
    int size = 1024;
    double density = 0.0;
    int gutter = 2;
    enum class Texels { Radiosity, Irradiance };
    Texels texels = Texels::Radiosity;
    bool textures = true;
    TextureFilter filter = TextureFilter::Mip;  ///< render.texture_filter
    static LightmapSettings fromParams(const Params& params, const std::string& prefix = "render");
};

struct Lightmap {
    struct Chart {
        int x = 0, y = 0, w = 1, h = 1;  ///< the domain's texels (gutter outside)
    };
    int size = 0;          ///< atlas width = height
    double density = 0.0;  ///< texels per scene unit used
    int gutter = 0;
    std::vector<Chart> charts;  ///< one per root patch
    Image atlas;                ///< linear radiosity B, row 0 at the top

    /// Atlas coordinates in [0, 1]^2 (glTF convention: (0,0) the top-left
    /// corner of the image) of parametric (u, v) of `patch`.
    Vec2 uv(uint32_t patch, double u, double v) const;
    /// Bilinear lookup at atlas coordinates (texel centres at (k + 1/2) / size).
    RGB sample(const Vec2& uv) const;
    /// Share of the atlas's texels inside some chart's domain.
    double fill() const;
};

/// Packs and fills the atlas; `smooth` null: the leaf values (flat). Throws
/// hrad::InputError (naming the settings) when the charts cannot fit.
Lightmap bakeLightmap(const scene::RadiosityField& field, const LightmapSettings& settings,
                      const VertexInterpolation* smooth);

/// A .glb of the root patches with TEXCOORD_0 (the patch's parametric (u,v))
/// and TEXCOORD_1 (the atlas), and one unlit material whose base colour
/// texture is the atlas tone mapped by `tone` (sRGB PNG inside the file), read
/// through TEXCOORD_1: any viewer shows the lit scene as image.png does.
void writeLightmapGlb(const scene::RadiosityField& field, const Lightmap& lightmap,
                      const ToneMap& tone, const std::string& path);

/// bakeLightmap, then lightmap.exr (linear B), lightmap.png and lightmap.glb
/// (both with `tone`, the image's tone map) into `dir`; returns the atlas.
Lightmap writeLightmapFiles(const scene::RadiosityField& field, const LightmapSettings& settings,
                            const VertexInterpolation* smooth, const ToneMap& tone,
                            const std::string& dir);

}  // namespace hrad::render
