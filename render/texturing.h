// Texture times irradiance: the radiosity a renderer shows on textured
// surfaces (the lecture's "Mesh vs. Textures": reflectance x irradiance =
// radiosity; light maps store the illumination and are multiplied by the base
// texture).
//
// The solve works with one reflectance per root patch, the texture's mean
// rho_bar over the patch (scene/texture.h). Where the field gives B at x, the
// irradiance is H = (B - E) / rho_bar, and the picture shows
//   B_tex(x) = E + rho(x) H = E + (B - E) rho_raw(x) / rho_raw_bar,
// rho_raw(x) = scale * bilinear texel, rho_raw_bar its patch mean before
// clamping (so a clamped patch keeps its solved mean: the shown rho(x) is the
// texture scaled to rho_bar). Per channel; a channel with rho_raw_bar = 0
// shows E. Patches without texture or UVs show B unchanged.
//
// Setting: render.textures  on | off  (default on; off shows the solved B).
//
// Filtering (render.texture_filter, read by RenderSettings, render/render.h):
// `bilinear` looks up rho(x) at the hit alone, so a texture minified below
// the pixel rate aliases (a far checker turns to noise or moire). `mip`
// (default) filters over the sample's footprint with a mip map (Williams 1983,
// "Pyramidal parametrics"): level k + 1 is the 2 x 2 box mean of level k,
// sizes halved and rounded up (an odd edge's missing texel wraps by the
// texture's mode), down to 1 x 1. The footprint is a ray differential (Igehy
// 1999; Pharr, Jakob & Humphreys, PBR 3rd ed. section 10.1.1): the camera rays
// one sample spacing (1 / sqrt(spp) pixel) to the right and below meet the hit
// patch's plane, their points mapped back to the patch's (u, v) and through
// its UV map to texels; that carries distance, pixel angle, 1 / cos and the
// UV Jacobian. Two steps of at most one texel (magnification) are the
// bilinear lookup exactly. Else the footprint is anisotropic, as GPUs filter
// it (EXT_texture_filter_anisotropic): N = min(8, ceil(major / minor))
// trilinear probes spread along the major axis, each at the level of a
// square w = max(minor, major / 8) wide. A level-k lookup is a 2^k box
// followed by a tent two level-k texels wide, of standard deviation 2^k / 2;
// the pixel's box of width w has w / sqrt(12): the level is log2(w / sqrt(3)),
// the one whose filter has the box's second moment (isotropic, always at the
// longer step, as OpenGL's rho = max and PBR section 10.4.3, blurred the
// holodeck: papers/notes/2026-12-02-textures.md, 2026-12-03). The pyramid
// costs 1/3 of the texels again, at render time only. Final gather, the path
// tracer and lightmap texels stay bilinear.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"
#include "scene/texture.h"

namespace hrad::render {

/// The doc of render.textures (read by RenderSettings and LightmapSettings).
inline constexpr const char* kTexturesDoc =
    "render: textured surfaces show texel x solved irradiance (on) or the solved radiosity (off)";

/// The doc of render.texture_filter (read by RenderSettings).
inline constexpr const char* kTextureFilterDoc =
    "render: texel lookups at the hit alone (bilinear) or mip-mapped over the sample's footprint (mip)";

enum class TextureFilter : uint8_t { Bilinear, Mip };

/// A texture's mip map (see above): levels()[0] is the texture itself.
class MipChain {
  public:
    explicit MipChain(const scene::Texture& base);
    size_t numLevels() const { return 1 + coarser_.size(); }
    const scene::Texture& level(size_t k) const { return k == 0 ? *base_ : coarser_[k - 1]; }
    /// Trilinear lookup at (s, t) (v up) at level log2(width), `width` in
    /// level-0 texels (level 0 for width <= 1, the 1 x 1 level past the top).
    RGB lookup(double s, double t, double width) const;
    /// The mean over a footprint at (s, t) whose two axes are sx and sy
    /// level-0 texels long (see above): bilinear when both are at most one
    /// texel, else up to kMaxProbes trilinear probes along the major axis.
    RGB filtered(const Vec2& st, const Vec2& sx, const Vec2& sy) const;
    static constexpr int kMaxProbes = 8;

  private:
    const scene::Texture* base_;
    std::vector<scene::Texture> coarser_;
};

/// How the patch's parametric (u, v) changes from a sample to its neighbours
/// one sample spacing to the right (dx) and below (dy).
struct ParamFootprint {
    Vec2 dx{0.0}, dy{0.0};
};

/// The footprint at `uv` on patch p of the camera rays from `eye` along dirX
/// and dirY (the neighbouring samples' directions), met on the patch's plane.
/// A ray (nearly) parallel to the plane gives an unbounded footprint (1e30).
ParamFootprint footprintOnPatch(const scene::Patch& p, const Vec3& eye, const Vec3& dirX,
                                const Vec3& dirY, const Vec2& uv);

class TextureShading {
  public:
    /// Precomputes every textured patch's raw mean (scene/texture.h
    /// patchTextureMean, the same quadrature the loader used), and with `mip`
    /// every texture's mip map.
    explicit TextureShading(const scene::Scene& scene, TextureFilter filter = TextureFilter::Bilinear);
    /// Whether any patch is textured (else shade() is the identity).
    bool any() const { return any_; }
    TextureFilter filter() const { return filter_; }
    /// rho(x) / rho_bar at the patch's parametric (u, v); 1 for untextured
    /// patches. With `fp` and the mip filter, rho(x) is filtered over it.
    RGB ratio(uint32_t patch, double u, double v, const ParamFootprint* fp = nullptr) const;
    /// E + (B - E) ratio(u, v, fp): B at (u, v) of `patch` shown with its texture.
    RGB shade(uint32_t patch, double u, double v, const RGB& B,
              const ParamFootprint* fp = nullptr) const;

  private:
    const scene::Scene* scene_;
    TextureFilter filter_;
    std::vector<RGB> inverseMean_;  ///< per patch, 1 / rho_raw_bar (0 where untextured)
    std::vector<uint8_t> textured_;
    std::vector<std::unique_ptr<MipChain>> mips_;  ///< per scene texture, with mip
    bool any_ = false;
};

}  // namespace hrad::render
