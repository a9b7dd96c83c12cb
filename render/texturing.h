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
// `bilinear` looks up rho(x) at the hit alone (a minified texture aliases);
// `mip` (default) filters over the sample's footprint with a mip map
// (Williams 1983: level k + 1 the 2 x 2 box mean of level k, down to 1 x 1).
// The footprint is a ray differential (Igehy 1999; PBR 3rd ed. section
// 10.1.1): the camera rays one sample spacing (1 / sqrt(spp) pixel) to the
// right and below, met on the hit patch's plane and mapped to texels through
// patchInverse and the UV map. Magnified (both steps <= 1 texel): the
// bilinear lookup exactly. Else anisotropic (EXT_texture_filter_anisotropic):
// N = min(8, ceil(major / minor)) trilinear probes along the major axis at
// level log2(w / sqrt(3)), w = max(minor, major / 8): the level whose 2^k box
// and tent have the pixel box's second moment (the derivation and the
// measurements: papers/notes/2026-12-02-textures.md, 2026-12-03). The
// pyramid costs 1/3 of the texels again, at render time only. Lightmap
// texels are filtered over the texel (render/lightmap.h), final gather at its
// pixel's hit point over the camera's footprint; the path tracer (the
// reference) stays bilinear.
//
// Reflectance per leaf (hr.texture_rho = element; scene/field.h
// leafTextureRho): the solve gave each leaf l of a textured patch its own
// rho_l (scene/texture.h elementRho), so its irradiance is H_l = (B_l - E) /
// rho_l, not (B - E) / rho_bar (LeafReflectance). The picture is then
// E + H(x) rho_shown(x), rho_shown = rho_raw(x) rho_bar / rho_raw_bar (the
// texel as above, 1 x the texel unless the patch mean was clamped): flat,
// H(x) = H_l of the leaf; smooth, H is what render/smooth.h interpolates on
// these patches. Where every leaf's rho is the patch mean this is the patch
// picture exactly.
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "core/types.h"
#include "scene/element.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "scene/texture.h"

namespace hrad::render {

/// The doc of render.textures (read by RenderSettings and LightmapSettings).
inline constexpr const char* kTexturesDoc =
    "render: textured surfaces show texel x solved irradiance (on) or the solved radiosity (off)";

/// The doc of render.texture_filter (read by RenderSettings).
inline constexpr const char* kTextureFilterDoc =
    "render: texel lookups at the point alone (bilinear) or mip-mapped over its footprint: a camera "
    "sample's (images, final gather) or an atlas texel's (lightmaps) (mip)";

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

/// The reflectance each leaf of a textured root patch was solved with, for a
/// field whose leaves carry their own (RadiosityField::leafTextureRho; else
/// any() is false): scene::elementRho over the leaf's domain, the value
/// hr/element_rho.h gave it.
class LeafReflectance {
  public:
    explicit LeafReflectance(const scene::RadiosityField& field);
    bool any() const { return any_; }
    /// Whether patch's leaves carry their own reflectance.
    bool covers(uint32_t patch) const { return any_ && !rho_[patch].empty(); }
    /// rho of leaf `key` of a covered patch.
    const RGB& rho(uint32_t patch, scene::ElementKey key) const;
    /// The leaf of a covered patch that contains (u, v), and its domain.
    scene::ElementKey leafAt(uint32_t patch, double u, double v) const;
    /// H = (B - E) / rho_leaf per channel (0 where rho_leaf is 0) at (u, v) of
    /// a covered patch, B the field's value there (flat).
    RGB irradianceAt(uint32_t patch, double u, double v) const;

  private:
    const scene::RadiosityField* field_;
    std::vector<std::unordered_map<scene::ElementKey, RGB>> rho_;  ///< per patch, per leaf
    bool any_ = false;
};

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
    /// scale x texel at (u, v) of a textured `patch` (filtered over `fp`
    /// with mip): rho_raw(x), unclamped (ratio = texel / rho_raw_bar).
    RGB texel(uint32_t patch, double u, double v, const ParamFootprint* fp = nullptr) const;
    /// E + (B - E) ratio(u, v, fp): B at (u, v) of `patch` shown with its texture.
    RGB shade(uint32_t patch, double u, double v, const RGB& B,
              const ParamFootprint* fp = nullptr) const;
    /// E + H rho_shown(u, v, fp): irradiance H at (u, v) of a textured
    /// `patch` shown with its texture (rho_shown = ratio x the patch's rho).
    RGB shadeIrradiance(uint32_t patch, double u, double v, const RGB& H,
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
