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
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace hrad::render {

/// The doc of render.textures (read by RenderSettings and LightmapSettings).
inline constexpr const char* kTexturesDoc =
    "render: textured surfaces show texel x solved irradiance (on) or the solved radiosity (off)";

class TextureShading {
  public:
    /// Precomputes every textured patch's raw mean (scene/texture.h
    /// patchTextureMean, the same quadrature the loader used).
    explicit TextureShading(const scene::Scene& scene);
    /// Whether any patch is textured (else shade() is the identity).
    bool any() const { return any_; }
    /// rho(x) / rho_bar at the patch's parametric (u, v); 1 for untextured patches.
    RGB ratio(uint32_t patch, double u, double v) const;
    /// E + (B - E) ratio(u, v): B at (u, v) of `patch` shown with its texture.
    RGB shade(uint32_t patch, double u, double v, const RGB& B) const;

  private:
    const scene::Scene* scene_;
    std::vector<RGB> inverseMean_;  ///< per patch, 1 / rho_raw_bar (0 where untextured)
    std::vector<uint8_t> textured_;
    bool any_ = false;
};

}  // namespace hrad::render
