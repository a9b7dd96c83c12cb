// `error`: refinement on a bound of the radiosity error a link makes.
//
// After Lischinski, Tampieri & Greenberg, "Combining hierarchical radiosity
// and discontinuity meshing" (SIGGRAPH 93; DESIGN.md lists it as Lischinski
// et al. 1994, the year of Lischinski, Smits & Greenberg, "Bounds and error
// estimates for radiosity", SIGGRAPH 94), and Holzschuch & Sillion 1998 ("An
// exhaustive error-bounding algorithm for hierarchical radiosity", CGF 17(4)):
// refine a link while the bound on the radiosity error it transports exceeds
// eps. A link gives every point x of the receiver the same radiosity
// rho_r B_s F_rs, while the exact transfer (B_s constant over the sender) is
// rho_r B_s F(x), with F(x) = F_{dA(x) -> s} the point-to-element form factor,
// visibility included. If F(x) lies in [Fmin, Fmax] over the receiver, the
// error of the link at any x is at most
//     dB = max_c rho_r,c B_s,c (Fmax - Fmin)        (max over RGB channels)
// times the receiver's importance (1 until importance is computed; Smits,
// Arvo & Salesin 1992). The link is accepted when dB is within eps (see
// ErrorNorm in oracles/oracle.h):
//     norm = power      A_r dB <= eps * P (P: the power hr.eps_power names,
//                       max channel; by default the smaller of the emitted and
//                       the predicted reflected power, hr/eps_power.h),
//                       the units of `bfa`, so eps values are comparable;
//     norm = radiosity  dB <= eps * (largest emitted radiosity, max channel),
//                       the per-radiosity criterion of the papers.
// Otherwise the element that looks larger from the other is subdivided
// (refineLarger, HSA91; setting side), constrained by what may subdivide.
//
// This per-link bound is what links touching a cluster are judged by (the
// solver gives them [Fmin, Fmax] = [0, max(F, Fupper)]: a point
// approximation has no receiver points). For links between two surfaces the
// solver skips it (no per-link range is evaluated) and the receiver
// aggregate below decides. The estimates are sampled, not the fully reliable
// bounds of Holzschuch & Sillion 1998, and ignore the error of B_s itself,
// which Lischinski, Smits & Greenberg 1994 propagate through
// interreflections.
//
// Surface links are judged by their receiver's aggregate (what eps bounds).
// A receiver gets the error D(x) = rho_r sum_l B_l v_l (F_l(x) - F_l) from all
// its surface links together (hr/receiver_error.h, LinkEstimate::
// receiverRange / receiverDeviation), sampled at its corners, edge midpoints
// and centroid. With norm = power the receiver's links are accepted when
//     A_r * E_r <= eps * P (P as above),
// E_r = max_k D(x_k) - min_k D(x_k) (the range): eps bounds the power the receiver's
// piecewise-constant irradiance misplaces, as a fraction of the light in the
// scene. Otherwise the links carrying at least an even share of E_r are
// refined on the receiver side; the sender is refined when
// F rho_r max_c |B_c - B_s| over its children (the sender's own variation)
// exceeds the same bound. Judged link by link (as before), the kernel
// variations of many links on one receiver passed one by one and added up
// (furnace L1 7.1 % (error) and 7.5 % (kv) at eps 1e-3); judged together,
// links whose kernels compensate (in a closed room sum_l F_l(x) = 1) are not
// refined, and the furnace stays exact. Links touching a cluster have no
// aggregate and keep the per-link estimate below. Cost: the kernel samples
// are computed once per link when it is made and cached with it (24 bytes
// per surface-to-surface link, hr::KernelSamples); each refinement round
// sums them.
//
// Polynomial bases (hr.basis linear, quadratic, cubic). The receiver's
// irradiance is then the projection of each link's kernel onto its basis,
// so D(x) above sums F_l(x) - P_l(x) instead of F_l(x) - F_l (P_l the
// projection; hr/receiver_error.h): the aggregate judges what the basis
// misses, a higher degree refines less where the transfer is smooth, and
// for the constant basis the rule is the one above. Links touching a
// cluster exchange the constant term only and keep the per-link estimate.
//
// Settings:
//   eps       double  1e-3     threshold (0, 1], relative as set by norm
//   norm      string  "power"  "power" | "radiosity" (see above)
//   min_area  double  0        elements at or below this area are not subdivided
//   side      string  "larger" (links touching a cluster) which element a refused link subdivides: "larger"
//                              (refineLarger, HSA91) or "receiver" (the element
//                              whose variation is measured; the other side only
//                              when the receiver cannot subdivide). Measured on
//                              cornell against the fm level-3 reference,
//                              "receiver" stalls near 1.3 % L2 at eps 1e-4 (vs
//                              0.45 % for error / 0.54 % for kv with "larger"):
//                              receiver splits never resolve the variation of
//                              the sender's own radiosity, which the constant
//                              link averages away.
#pragma once

#include "oracles/oracle.h"

namespace hrad::oracles {

class ErrorBoundOracle final : public VariationOracle {
  public:
    using VariationOracle::VariationOracle;
    std::string name() const override { return "error"; }
    double linkError(const LinkEstimate& e) const override;
    double receiverError(const LinkEstimate& e) const override { return e.receiverRange; }
};

}  // namespace hrad::oracles
