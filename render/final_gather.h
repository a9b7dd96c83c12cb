// Final gather and a path-traced reference image (render.reconstruction =
// final-gather | path-traced).
//
// Final gather (the rendering-stage gather applied to a radiosity solution,
// e.g. Lischinski, Tampieri & Greenberg 1993): the radiosity
// seen at a pixel's hit point x (patch i) is recomputed from the solution
// instead of being read from its (coarse) elements:
//     B(x) = E_i + rho_i ( D(x) + I(x) )
//     D(x) = sum_e E_e \int_e cos t_x cos t_y / (pi r^2) V(x,y) dA_y   (direct)
//     I(x) = mean over gather_rays cosine-distributed rays from x of
//            B_field(y) - E(y), y the nearest hit (0 when it hits a back)
// The direct term samples shadow_rays points per emitter (area sampling,
// weight = the patch map's Jacobian: unbiased for any convex quad); the
// indirect term uses the solution only for light reflected at least once, so
// the sharp shadows and the bright regions next to the light come from the
// exact kernel, not from the elements' averages.
//
// Path tracing (Kajiya 1986) estimates the same B(x) with I(x) replaced by a
// recursive estimate along one cosine-distributed path (next-event
// estimation at every vertex, Russian roulette after 3 bounces with the
// maximum RGB reflectance as survival probability). It needs no solution and
// converges to the exact radiosity: the Monte Carlo reference image.
//
// Non-area lights (scene/lights/light.h) in both: D(x) adds every point,
// spot and sun light by one shadow ray (exact). An environment that is
// importanceSampled() (an envmap that varies) is drawn by next-event
// estimation, shadow_rays draws of its sample() at x, beside the cosine
// rays that escape (gather_rays of them in the final gather, the path's one
// at a path vertex), all weighted by the power heuristic (Veach & Guibas
// 1995; transport/light_irradiance.h). Other environments (a constant sky)
// score pi L(w) on escaping rays alone: the cosine pdf is proportional to
// their unoccluded integrand, so light draws would add rays and nothing else.
//
// Textures: rho at a hit is the bilinear texel (clamp_rho), at a final
// gather pixel's own hit the mip texel over the camera footprint
// (render/texturing.h); the path tracer (the reference) stays bilinear.
//
// Both are deterministic per (seed, pixel, sample): the random sequence of a
// sample is seeded by hashIds(seed, pixel, sample), so images do not depend
// on the tiling or on thread scheduling. Images are computed in parallel
// over 16 x 16 tiles with a progress bar.
//
// Settings (below "render."; reconstruction: render/render.h):
//   gather_rays    int    64      indirect rays per pixel sample (final gather);
//                                 a square k*k is stratified over the hemisphere
//   shadow_rays    int    4       points per emitter for the direct term, and
//                                 draws of each importance-sampled environment
//   seed           int    0       seed of every sampled image
#pragma once

#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::render {

struct GatherSettings {
    int gatherRays = 64;
    int shadowRays = 4;
    uint64_t seed = 0;
    /// render.textures: the reflectance at a hit is the texel rho(x)
    /// (scene/texture.h), not the patch mean.
    bool textures = true;
};

class Gatherer {
  public:
    Gatherer(const scene::Scene& scene, const transport::Visibility& visibility,
             GatherSettings settings);
    /// Final-gather radiosity at x on the front of `patch` from `field`.
    /// `texel`: scale x texel at x filtered over the camera sample's
    /// footprint (render/texturing.h TextureShading::texel) to use instead
    /// of the bilinear texel (clamped alike); null: the bilinear one.
    RGB finalGather(const scene::RadiosityField& field, uint32_t patch, const Vec3& x,
                    Pcg32& rng, const RGB* texel = nullptr) const;
    /// Path-traced radiosity at x on the front of `patch`.
    RGB pathTraced(uint32_t patch, const Vec3& x, Pcg32& rng) const;
    /// Direct term D(x) (see the header), per RGB channel of E.
    RGB direct(uint32_t patch, const Vec3& x, Pcg32& rng) const;
    const GatherSettings& settings() const { return settings_; }

  private:
    /// rho(x) at x on `patch` with textures on, else the patch's rho;
    /// `texel` as finalGather's.
    RGB rhoAt(uint32_t patch, const Vec3& x, const RGB* texel = nullptr) const;
    /// The sampled environments' light half at x (shadow_rays draws, each
    /// weighted against `cosineSamples` cosine rays).
    RGB environmentDirect(uint32_t patch, const Vec3& x, int cosineSamples, Pcg32& rng) const;
    const scene::Scene* scene_;
    const transport::Visibility* vis_;
    GatherSettings settings_;
    std::vector<uint32_t> emitters_;
    bool hasSampledEnv_ = false;  ///< an importanceSampled() light (transport/light_irradiance.h)
};

}  // namespace hrad::render
