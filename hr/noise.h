// The solver's own Monte Carlo noise, estimated from one solve.
//
// A hierarchical solve is one draw of its own rays: the visibility of every
// partially visible link, and the transfer of every sampled cluster link and
// stand-in, are Monte Carlo estimates, and the oracles bound each link's
// error alone, not their sum. Solves with other seeds (hr.seed) measure that
// noise; this estimates it from the solve itself.
//
// Per link i, the relative standard error r_i of its transfer:
//   - a sampled near cluster link or a stand-in (cluster/link.h): the
//     standard error its samples give (Link::uncertainty);
//   - a link whose visibility is a fraction v of n rays, 0 < v < 1 (n =
//     ff.vis_rays, or cluster.vis_rays with a cluster at one end):
//     r_i^2 = (1 - v) / (v n), the binomial variance over the square; v is
//     the mean of the carried and the judged fraction where both are stored.
//     Stratification (smaller) and kernel weighting (larger) are not
//     modelled; bench/results/solver_noise.md measures how they net out;
//   - every other link: 0.
// With P_i the power link i's receiver reflects of what it delivers
// (Hierarchy::linkLight), independent link errors move the reflected power by
// sqrt(sum_i (r_i P_i)^2), and reflected on, the total by that times
//     g = sum_i P_i / sum_i P_i e_i,
// e_i the emitted share of what link i's sender sends (E / B per channel; a
// cluster: sum A E over sum A B below it). g is one number per channel:
// exact for a uniform furnace, an average where rooms differ.
//
// The per-patch figure is the direct part only: per root patch the variance
// of its mean reflected radiosity from the links that light it (and its
// ancestors), as the area-weighted relative L2 of luminance over
// non-emitters (reference/metrics.h l2_nonemitter_lum).
//
// Not modelled: the reachability pass (hr.reach_rays), the hand-over's
// openness table, and which links refinement chose.
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.h"
#include "hr/hierarchy.h"

namespace hrad::hr {

/// Rays per visibility estimate (ff.vis_rays, cluster.vis_rays).
struct NoiseRays {
    int surface = 16;
    int cluster = 8;
};

struct SolverNoise {
    uint64_t links = 0;         ///< links with a sampling error
    RGB direct{0.0};            ///< sd of the reflected power, the links' errors alone (W)
    RGB amplification{1.0};     ///< g: reflected power over its first bounce
    RGB powerSd{0.0};           ///< direct x g
    double relative = 0.0;      ///< max over channels of powerSd / reflected power
    double l2NonEmitter = 0.0;  ///< the direct per-patch figure (header)
};

/// Per link, the relative standard error of its transfer (header).
std::vector<float> linkRelativeErrors(const Hierarchy& h, const NoiseRays& rays);

/// `light`, when given, receives the light of each link
/// (Hierarchy::linkLight, link order), which the estimate computes anyway.
SolverNoise estimateNoise(const Hierarchy& h, const NoiseRays& rays,
                          std::vector<RGB>* light = nullptr);

}  // namespace hrad::hr
