// The residual of a radiosity solution: how far each leaf's radiosity is from
// what the exact transport operator makes of the solution itself.
//
// For a solution B_h (any RadiosityField: hierarchical, full matrix,
// progressive) the continuous residual is
//     r(x) = B_h(x) - ( E(x) + rho(x) \int K(x,y) V(x,y) B_h(y) dy )
// (the radiosity equation, Goral et al. 1984, applied to B_h; a residual
// formulation of the error as in Lischinski, Tampieri & Greenberg 1994 and
// Bekaert & Willems 1996). The bracket is the final gather of B_h
// (render/final_gather.h: the direct term from the emitters' exact E, the
// indirect term by cosine-distributed rays reading B_h - E), so it needs no
// reference. Averaged over a leaf element, r_i is what the solver's own
// transport (its links, matrix rows, shots) got wrong given its own answer:
// a systematic sign over lit surfaces (r < 0: the solver gathered less than
// the operator gives) is lost or invented light, found without a reference
// solve. Because B - B_exact = (I - rho K)^-1 r, the residual also bounds the
// error to first order: |B - B_exact| ~ |r| / (1 - rho_mean).
//
// Each leaf gets `points` stratified points (weighted by the patch map's
// Jacobian), each point `gather_rays` + `shadow_rays` per emitter rays; the
// estimate's standard error per leaf comes from the spread over its points.
// Deterministic per (seed, patch, leaf): no dependence on threads.
//
// Settings (below "residual."):
//   points      int  16   points per leaf element
//   gather_rays int  64   indirect rays per point
//   shadow_rays int  4    points per emitter for the direct term
//   seed        int  1
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/types.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::render {

struct ResidualSettings {
    int points = 16;
    int gatherRays = 64;
    int shadowRays = 4;
    uint64_t seed = 1;
    static ResidualSettings fromParams(const Params& params, const std::string& prefix = "residual");
};

struct LeafResidual {
    uint32_t patch = 0;
    scene::ElementKey key = 0;
    double area = 0.0;
    RGB B{0.0};        ///< the solution's leaf value
    RGB gathered{0.0}; ///< E + rho K B_h averaged over the leaf (Monte Carlo)
    RGB stdError{0.0}; ///< standard error of `gathered`
};

struct ResidualSummary {
    std::vector<LeafResidual> leaves;
    /// Over non-emitting leaves, luminance-weighted (Rec. 709 Y):
    double reflectedSolution = 0;  ///< sum A (B - E)
    double reflectedGathered = 0;  ///< sum A (gathered - E)
    double l1 = 0;                 ///< sum A |B - gathered| / sum A (gathered - E)
    double l1Noise = 0;            ///< the part of l1 the estimate's noise explains (sum A se sqrt(2/pi))
    uint64_t rays = 0;
    double seconds = 0;
    /// reflectedSolution / reflectedGathered: below 1 the solver loses light.
    double ratio() const { return reflectedGathered > 0 ? reflectedSolution / reflectedGathered : 1.0; }
};

ResidualSummary computeResidual(const scene::Scene& scene, const transport::Visibility& visibility,
                                const scene::RadiosityField& field, const ResidualSettings& settings,
                                bool showProgress = false);

/// Writes one CSV row per leaf: patch, key, area, B, gathered, stdError (RGB).
void writeResidualCsv(const std::string& path, const ResidualSummary& r);

}  // namespace hrad::render
