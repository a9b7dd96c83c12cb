// The solver's own Monte Carlo noise, estimated from one solve.
//
// A hierarchical solve is one draw of its own rays: the visibility of every
// partially visible link, and the transfer of every sampled cluster link and
// stand-in, are Monte Carlo estimates, and the oracles bound each link's
// error alone, not their sum. Solves repeated with other ray seeds (hr.seed)
// measure that noise; this estimates it from the solve itself, so every
// solve can say how much of its difference from a reference may be its own
// noise.
//
// Per link i, the relative standard error r_i of its transfer:
//   - a sampled near cluster link or a stand-in (cluster/link.h): the
//     standard error its samples give (Link::uncertainty, the judged
//     estimate's; the carried one is drawn alike);
//   - a link whose visibility is a fraction v of n rays, 0 < v < 1 (n =
//     ff.vis_rays between surface elements, cluster.vis_rays where a cluster
//     is at one end): r_i^2 = (1 - v) / (v n), the binomial variance of the
//     fraction over its square. v is the mean of the carried and the
//     independent judged estimate where both are stored (it is the plug-in
//     for the true fraction, which neither alone should decide: a carried
//     fraction of 1 says nothing of the link's variance). The segments are
//     stratified (transport/formfactor.cpp), which makes the true variance
//     smaller; the kernel weighting makes the effective n smaller. Neither is
//     modelled: the seed spreads measured against this estimate
//     (bench/results/solver_noise.md) say how the two net out.
//   - every other link (no rays, or all of them unblocked): 0.
// With P_i the power link i's receiver reflects of what it delivers
// (Hierarchy::linkLight), the links' errors, independent, move the reflected
// power by sqrt(sum_i (r_i P_i)^2) directly; that light is then reflected on
// like any other, so the total moves by that times the amplification
//     g = sum_i P_i / sum_i P_i e_i,
// the reflected power over its first bounce, e_i the share of emitted light
// in what link i's sender sends (E / B per channel; for a cluster, sum A E
// over sum A B below it). g is one number per channel for the whole scene:
// exact for a uniform furnace, an average where rooms differ.
//
// The per-patch figure is the direct part only: per root patch the variance
// of its mean reflected radiosity from the links that light it (and its
// ancestors), as an area-weighted relative L2 of luminance over the patches
// that do not emit, the measure reference/metrics.h calls
// l2_nonemitter_lum. The light the errors move on is spread over the scene
// and is not in it.
//
// Not in either figure: the reachability pass (hr.reach_rays), the
// hand-over's openness table, and which links refinement chose (a link
// judged with another draw may be refined or kept).
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
