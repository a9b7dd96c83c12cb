// The residual error estimate: the error of any radiosity solution against
// the exact one, from the solution alone (no reference solve).
//
// For a solution B_h and the exact transport T (B = E + rho T B), the
// residual r = E + rho T B_h - B_h and the error e = B* - B_h satisfy
// e = r + rho T e, so e = (I - rho T)^-1 r (the residual formulation of
// Lischinski, Tampieri & Greenberg 1994; Bekaert & Willems 1996). Per root
// patch p, the regions the metrics compare at mc.level 0:
//   r_p = E_p + rho_p mean_j H_j - Bbar_p,
//   H_j = next-event estimate of the direct light at x_j (MIS, as the Monte
//         Carlo reference: reference/light_sampling.h) + B_h(y_j) - E(y_j),
//         y_j the hit of one cosine-distributed ray, x_j uniform on p.
// Every transfer the solver approximated (surface, cluster and stand-in
// links, visibility, hand-over, its own ray noise) is in B_h and is tested
// by exact rays, so no link kind is left out. The same rays estimate the
// patch-to-patch form factors (T^_pq: the share of p's rays that hit the
// front of q), and e = r + rho T^ e is solved by Jacobi iteration: the error
// a residual causes bounces on (r constant per patch: second order).
//
// Noise: each region's samples are split in two independent halves (even,
// odd), each with its own residual and its own T^, giving e1 and e2. Their
// noises are independent, so
// sum A Y(e1) Y(e2) estimates sum A Y(e)^2 without the noise's bias
// (Y = luminance); the L1 uses sqrt(max(0, Y(e1) Y(e2))) per patch. Norms
// as reference/metrics.h: L2 over non-emitters relative to B* = B_h + e, L1
// relative to the reflected part B* - E, the non-emitters' mean ratio
// sum A Bbar / sum A B* (below 1: the solve lost light). `noiseL2` is the
// half-difference's L2, the size of the noise the cross product removes.
// Calibration against Monte Carlo references: bench/results/error_estimate.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/types.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::reference {

struct ErrorEstimateSettings {
    uint64_t samples = 1000000;  ///< samples over the scene (split over regions)
    int regionSamples = 16;      ///< samples per region the patches are split for
    int maxLevel = 8;            ///< region subdivision level at most
    int minSamples = 8;          ///< per region at least (even: two halves)
    int maxSamples = 4096;       ///< per region at most
    uint64_t seed = 1;
    static ErrorEstimateSettings fromParams(const Params& params,
                                            const std::string& prefix = "estimate");
    std::string describe() const;
};

struct ErrorEstimate {
    double l2NonEmitter = 0.0;   ///< estimate of metrics l2_nonemitter_lum
    double l1Reflected = 0.0;    ///< estimate of metrics l1_reflected_lum
    double meanRatio = 1.0;      ///< estimate of metrics mean_ratio_nonemitter
    double noiseL2 = 0.0;        ///< L2 (non-emitters) of the halves' difference / 2
    double meanRatioNoise = 0.0; ///< standard error of meanRatio (patches independent)
    double residualL2 = 0.0;     ///< L2 (non-emitters) of r itself, before bouncing
    size_t regions = 0;         ///< regions the residual was sampled on
    int samplesPerRegion = 0;
    uint64_t rays = 0;
    int iterations = 0;
    double seconds = 0.0;
    /// Per root patch: the estimated error e = B* - Bbar (mean of the halves).
    std::vector<RGB> perPatch;
};

ErrorEstimate estimateError(const scene::Scene& scene, const transport::Visibility& visibility,
                            const scene::RadiosityField& field,
                            const ErrorEstimateSettings& settings, bool showProgress = false);

}  // namespace hrad::reference
