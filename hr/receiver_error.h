// The receiver-aggregate kernel error that error-driven oracles judge links by
// (oracles::LinkEstimate::receiverRange and friends).
//
// Hierarchical radiosity gives every point of a receiver element the same
// gathered radiosity rho_r sum_l K_l B_l. The exact irradiance from the same
// senders (B constant on each) at x is rho_r sum_l v_l F_l(x) B_l, so
//     D(x) = rho_r sum_l B_l v_l (F_l(x) - F_l)
// is the receiver's error, and it is the sum over links that matters: per
// link the kernel varies a lot near shared edges even where a receiver's
// links compensate (in a closed room sum_l F_l(x) = 1), while many links of
// one sign each pass a per-link threshold and add up to several per cent
// (papers/notes/2026-11-29-receiver-error.md). This is the estimate of
// Holzschuch & Sillion 1998 and Lischinski, Smits & Greenberg 1994 taken over
// all links of a receiver, sampled at its corners, edge midpoints and
// centroid (FormFactorEngine::kernelSamples), where a planar receiver's
// kernel takes its extremes.
//
// The sender side is aggregated the same way: a link from a subdivided
// sender s carries K B_s where the receiver would gather sum_c K_c B_c; the
// difference is at most K max_c |B_c - B_s|, and its sign is not random (the
// parts a receiver sees best are mostly the lit ones), so the receiver's sum
// over its links of K_l max_c |B_c - B_l| is held to eps as a whole
// (papers/README.md, "Where the darkness came from").
//
// Polynomial bases (hr.basis above constant, scene/basis.h): a receiver gets
// from each surface link the projection P_l(x) of its kernel onto the basis
// (Galerkin: Zatz 1993; Bekaert & Willems 1995), so it misses
//     D(x) = rho_r sum_l B_l v_l (F_l(x) - P_l(x)),
// sampled at the same points (linkResidualSamples). For the constant basis
// P_l = F_l. In a closed room the residuals still sum to zero at every point,
// so the furnace stays exact, and a transfer the basis represents is not
// refined.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <vector>

#include "hr/hierarchy.h"
#include "transport/coupling.h"
#include "transport/formfactor.h"

namespace hrad::hr {

/// The aggregate of one receiver and one link's part in it (see LinkEstimate).
struct ReceiverError {
    float range = -1.f, deviation = -1.f;  ///< negative: not evaluated
    float linkDeviation = 0.f;
    uint32_t links = 0;
    /// Sender side: sum over the receiver's surface links of K_l times the
    /// spread of the sender's children (rho_r max_c |B_c - B_s|, max
    /// channel), and this link's own term (see LinkEstimate::senderAggregate).
    float senderSum = 0.f, linkSender = 0.f;
};

/// The sender side summed per sender (hr.sender_total): a subdivided sender
/// s whose average is gathered through surface links misplaces, over all
/// their receivers together, the power
///   P_s = sum over surface links l from s of A_r K_l max_c rho_r,c spread_s,c,
/// spread_s = max(hi - B_s, B_s - lo) over its leaves' radiosities. Judged
/// receiver by receiver (the sender aggregate above, in the power norm) each
/// term is small when the receivers are small, but every receiver along a
/// bright edge of the sender makes the same error and refinement makes more
/// of them as eps falls: a floor (papers/README.md, "The constant basis's
/// floor on the plates"). By reciprocity P_s <= rho A_s spread_s F_s, which
/// does not grow with the number of receivers.
struct SenderTotal {
    float total = -1.f;  ///< P_s; negative: not evaluated (not a surface link)
    float link = 0.f;    ///< this link's term
    uint32_t links = 0;  ///< surface links from s with a positive term
};

/// Per surface element, the range [lo, hi] of its leaves' radiosities, per
/// channel (clusters and unused slots: zero). What senderTotals() and
/// receiverErrors() bound a subdivided sender's spread by; computed once
/// per refinement round and handed to both.
struct LeafRanges {
    std::vector<RGB> lo, hi;
};
void leafRanges(const Hierarchy& h, LeafRanges& out);

/// P_s for the sender of every link of `pending` that carriesKernelSamples()
/// (links in `pending` and `accepted` both count), and the link's own term:
/// one entry per such link, in their order (no other link has a term).
void senderTotals(const Hierarchy& h, const std::vector<uint32_t>& pendingRecv,
                  const std::vector<Link>& pending, const std::vector<uint32_t>& acceptedRecv,
                  const std::vector<Link>& accepted, std::vector<SenderTotal>& out,
                  const LeafRanges* ranges = nullptr);

/// The samples of the link from surface element s to surface element r
/// (receiverErrors' `compute`).
using SampleFn = std::function<KernelSamples(uint32_t r, uint32_t s)>;

/// For every link of `pending` whose receiver and sender are surface
/// elements: the aggregate over all surface links of its receiver, in
/// `pending` and in `accepted` together (the links refinement has already
/// kept this round count too), and the link's own part. `out` holds one
/// entry per link of `pending` that carriesKernelSamples(), in link order
/// (no other link is evaluated). Each samples array holds one entry per
/// link of its array that storesKernelSamples(), in link order; with
/// `compute` given, an array may also be empty, and the samples a link
/// lacks are computed now (the error estimate). Without it a receiver that
/// cannot subdivide gets no kernel term, only the unsigned part of its
/// partially visible links: no decision reads its aggregate
/// (oracles::receiverRefinement); and a receiver none of whose pending
/// surface links has an end that can subdivide is not evaluated at all
/// (its entries stay "not evaluated": refinement keeps such links unjudged).
/// Parallel over receivers; deterministic.
/// `ranges`, when given, must be leafRanges() of `h` as it is.
void receiverErrors(const Hierarchy& h, const std::vector<uint32_t>& pendingRecv,
                    const std::vector<Link>& pending,
                    const std::vector<KernelSamples>& pendingSamples,
                    const std::vector<uint32_t>& acceptedRecv, const std::vector<Link>& accepted,
                    const std::vector<KernelSamples>& acceptedSamples,
                    std::vector<ReceiverError>& out, bool residualSamples = false,
                    const SampleFn& compute = {}, const LeafRanges* ranges = nullptr);

/// The kernel samples of the link from surface element s to surface element
/// r (zeros past the receiver's sample count).
KernelSamples linkKernelSamples(const Hierarchy& h, const transport::FormFactorEngine& engine,
                                uint32_t r, uint32_t s);

/// For a polynomial basis: F(x_k) - P(x_k) at the same points, P the
/// projection of the link's kernel onto the receiver's basis (transport
/// CouplingEngine::residualSamples). receiverErrors() with residualSamples
/// = true sums these instead of F(x_k) - F: the error of the receiver's
/// polynomial irradiance, which is what a higher-order element misses.
KernelSamples linkResidualSamples(const Hierarchy& h, const transport::CouplingEngine& coupling,
                                  uint32_t r, uint32_t s);


/// A posteriori estimates of the solve's error that let the levels cancel
/// (summary error_estimate_leaves and error_estimate_points).
///
/// A leaf L gathers through its own links and through those of its
/// ancestors, each ancestor link l (receiver A, sender s) pushed to L as the
/// receiver average K_l = v_l F_l over A. The average over L of the exact
/// transfer from the same sender (B constant on it) is v_l F_l(L), F_l(L)
/// the mean over L of the point form factor to s. The error of L's average
/// is therefore
///     e_L = rho_L sum over strict surface ancestors A of L,
///                 sum over A's surface links l of B_s (v_l F_l(L) - K_l),
/// signed, so that links that compensate each other cancel (in a closed
/// room the point form factors to all senders sum to one: the furnace's
/// e_L is the leaf's error, one bounce deep), where the receiver-by-receiver
/// range of the refinement check (receiverErrors) and of error_estimate
/// adds them up level by level (Lischinski, Smits & Greenberg 1994 bound
/// each link's part; this sums the parts before taking the norm). F_l(L)
/// is the tensor Simpson rule on L's kernel sample points (corners, edge
/// midpoints, centroid: weights 1, 4, 16 over 36 on a parallelogram; 3, 8,
/// 27 over 60 on a triangle). The returned value is
/// sum_L A_L |luminance(e_L)| over the luminance of the reflected power
/// (the units of the l1_reflected_lum metric).
///
/// `pointwise`, when given, receives the same sum taken at each of L's
/// sample points with L's own links included, D(x_k) = rho_L sum over L and
/// its ancestors of B_s (v_l F_l(x_k) - K_l), Simpson-weighted |D| over the
/// points: also the variation of the exact irradiance inside a leaf, which
/// a constant leaf cannot follow and a reference finer than the leaf sees.
///
/// Left out: links that touch a cluster, where a partially visible link's
/// shadow falls, the sender side (averaged senders: senderTotals) and the
/// interreflection of the error. NaN for a polynomial basis. Parallel over
/// leaves, deterministic. papers/README.md, "Estimates that let the levels
/// cancel", measures both against full-matrix and Monte Carlo references.
/// `stored`, when given and not empty, holds the kernel samples of the links
/// that storesKernelSamples(), in link order (Hierarchy::kernelSamples):
/// the leaves' own links read theirs from it instead of computing them.
double leafAverageError(const Hierarchy& h, const std::vector<uint32_t>& recv,
                        const std::vector<Link>& links, const transport::FormFactorEngine& engine,
                        double* pointwise = nullptr,
                        const std::vector<KernelSamples>* stored = nullptr);


/// What leafAverageError leaves out, as a share: the reflected power
/// (luminance) delivered by links with a cluster at either end, over that of
/// every link. `light` is Hierarchy::linkLight of h (link order; the noise
/// estimate computes it: hr/noise.h). 0 without clusters.
double uncoveredLightShare(const Hierarchy& h, const std::vector<uint32_t>& recv,
                           const std::vector<RGB>& light);


/// The sums behind leafAverageError, in power (luminance, not divided by
/// the reflected power): `leaves`, sum over leaves of A_L |luminance(e_L)|;
/// with `points`, `points`, the Simpson-weighted |D(x_k)| summed the same
/// way (0 without). `shares`, when given, receives per element A the
/// leaf budget's share of A (leafBudgetMarks; 0 for elements that cannot
/// subdivide). Deterministic.
struct LeafErrorTotals {
    double leaves = 0.0, points = 0.0;
    /// The error inside the leaves that their averages do not carry:
    /// points - leaves (>= 0 up to rounding: |mean of D| <= mean of |D|).
    double inside() const { return std::max(0.0, points - leaves); }
};
LeafErrorTotals leafErrorTotals(const Hierarchy& h, const std::vector<uint32_t>& recv,
                                const std::vector<Link>& links,
                                const transport::FormFactorEngine& engine, bool points,
                                const std::vector<KernelSamples>* stored = nullptr,
                                std::vector<double>* shares = nullptr);

/// The leaf budget (hr.leaf_budget): the receivers whose surface links are
/// pushed one level down so that the leaves' error (LeafErrorTotals::leaves)
/// loses `excess`, its amount over the budget. Each strict surface ancestor
/// A of a leaf owns the part of e_L that its own links make, e_L^A; its
/// share (leafErrorTotals `shares`) is sum over its leaves of
/// A_L |luminance(e_L^A)|. The receivers that can subdivide are marked in
/// decreasing order of their share until the marked shares cover the excess
/// (greedy; a share is at least the error its push removes where the
/// leaves' parts do not compensate each other). Returns one flag per
/// element, or nothing when nothing is marked (excess <= 0, or no share).
///
/// What the budget is (hr/solver.h, hr.leaf_budget): full, the check's eps
/// of the power eps refers to; balanced (the default), that eps beyond
/// LeafErrorTotals::inside(). A constant leaf is wrong by its average's error
/// plus the variation it cannot follow; pushing the first far below the
/// second buys little per link (the rooms of papers/README.md, "The leaf
/// budget"), while where the exact irradiance is flat over the leaves (the
/// furnace: the point form factors to all senders sum to one at every point)
/// the inside part vanishes and the budget holds the sum to eps.
std::vector<uint8_t> leafBudgetMarks(const std::vector<double>& shares, double excess);

}  // namespace hrad::hr
