// Irradiance from the scene's non-area lights (scene/lights/light.h) at a
// surface point, with visibility: the one estimate the hierarchical solve's
// light links (hr/light_links.h), the full matrix's E_direct
// (reference/fullmatrix.h), the Monte Carlo reference and the path tracer
// (next-event estimation) share.
//
//   delta lights (point, spot, sun): E(x) = value * cos t * V(x, light),
//       exact up to the shadow ray (one ray, to the point or towards the
//       sun's direction with no end).
//   environments: E(x) = \int L(w) V(x, w) cos t dw, estimated with k x k
//       stratified cosine-distributed directions (pdf cos t / pi, so each
//       scores pi L(w) V): exact for an unoccluded receiver under a constant
//       sky, otherwise a stratified estimate of standard error ~ pi L / k^2
//       at a shadow boundary (stratification, Veach 1997 sec. 2.7). A light
//       that is importanceSampled() (an envmap that varies: a sun in the
//       map is a small bright solid angle cosine directions rarely hit)
//       adds k x k stratified draws of its sample(), both sets weighted by
//       the balance heuristic (Veach 1997 sec. 9.2): twice the rays.
// Directions and jitter are drawn from Pcg32(seed): deterministic per caller.
#pragma once

#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::transport {

/// Irradiance at x (normal n, on the front of `patch`) from light l;
/// `strata` k gives k^2 directions for an environment. `rays` counts rays.
RGB lightIrradiance(const scene::Light& l, const Visibility& vis, const Vec3& x, const Vec3& n,
                    uint32_t patch, int strata, uint64_t seed, uint64_t& rays);

/// Midpoint-rule points of an element for a mean over it: quads the m x m
/// cell midpoints of the (a, b) square weighted by the map's Jacobian,
/// triangles the centroids of the m^2 congruent sub-triangles (equal
/// weights); weights sum to 1, O(h^2) error in the mean. Returns m^2.
int elementMeanPoints(const scene::Patch& p, const scene::Domain& d, int m, std::vector<Vec3>& x,
                      std::vector<double>& w);

/// Mean irradiance (all lights) over an element by elementMeanPoints(m).
RGB elementLightsIrradiance(const scene::Scene& s, const Visibility& vis, uint32_t patch,
                            const scene::Domain& d, int m, int strata, uint64_t seed,
                            uint64_t& rays);

/// The same without visibility (the same directions for an environment):
/// what x would receive were nothing in the way; no rays.
RGB lightIrradianceUnoccluded(const scene::Light& l, const Vec3& x, const Vec3& n, int strata,
                              uint64_t seed);

/// Sum over the scene's lights.
RGB lightsIrradiance(const scene::Scene& s, const Visibility& vis, const Vec3& x, const Vec3& n,
                     uint32_t patch, int strata, uint64_t seed, uint64_t& rays);

/// Radiance an escaping ray of direction dir picks up from the environments.
RGB environmentRadiance(const scene::Scene& s, const Vec3& dir);

// Next-event estimation of the environments for random walks (the Monte
// Carlo reference, the final gather, the path tracer): at a vertex x the
// integral \int L(w) V(x, w) cos t dw of every importanceSampled() light is
// estimated from n_l draws of its sample() and the n_c cosine (BSDF)
// directions the walk casts anyway, combined by the power heuristic with
// exponent 2 (Veach & Guibas 1995; Veach 1997 sec. 9.2.3, counts n_l, n_c).
// With a = n_l pdf_l(w), b = n_c cos t / pi and f = L(w) cos t V, a light
// draw scores a f / (a^2 + b^2), a cosine draw b f / (a^2 + b^2), and the
// estimate is the sum over all n_l + n_c draws (unbiased). The power
// heuristic, not the balance heuristic the solvers' stratified estimate
// uses above: with the final gather's 64 cosine rays against 4 light draws
// a cosine ray that hits a small sun would score as much as a light draw
// under the balance heuristic (a rare large score); under the power
// heuristic it scores ~1 % of that. The other environments (constant, a
// uniform map) stay on cosine directions alone, pi L / n_c per escaping
// direction: their cosine pdf is proportional to the unoccluded integrand,
// so light draws would add rays and no accuracy (light.h importanceSampled()).

/// Whether some light of the scene is importanceSampled().
bool hasSampledEnvironment(const scene::Scene& s);
/// The light half: n_l draws of every importanceSampled() light at x
/// (normal n, front of `patch`; m x m strata of the light's (u1, u2) when
/// n_l = m^2), each with a shadow ray towards infinity when it scores; the
/// sum of their scores. Draws 2 n_l numbers per light.
RGB sampledEnvironmentDirect(const scene::Scene& s, const Visibility& vis, const Vec3& x,
                             const Vec3& n, uint32_t patch, int lightSamples, int cosineSamples,
                             Pcg32& rng, uint64_t& rays);
/// The cosine half: the score of one cosine direction `dir` about n that
/// escaped, for the importanceSampled() lights.
RGB sampledEnvironmentEscape(const scene::Scene& s, const Vec3& n, const Vec3& dir,
                             int lightSamples, int cosineSamples);
/// Radiance along dir of the environments that are not importanceSampled().
RGB unsampledEnvironmentRadiance(const scene::Scene& s, const Vec3& dir);
/// Whether the scene has a light at infinity that is not a delta (an environment).
bool hasEnvironment(const scene::Scene& s);

/// The lights' power (max channel) into the scene's bounding sphere (light.h power()).
double lightsPower(const scene::Scene& s);

}  // namespace hrad::transport
