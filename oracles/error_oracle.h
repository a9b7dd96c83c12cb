// `error`: refinement on a bound of the radiosity error a link makes.
//
// After Lischinski, Tampieri & Greenberg 1993 ("Combining hierarchical
// radiosity and discontinuity meshing"), Lischinski, Smits & Greenberg 1994
// ("Bounds and error estimates for radiosity") and Holzschuch & Sillion 1998
// ("An exhaustive error-bounding algorithm for hierarchical radiosity"):
// refine while the bound on the radiosity error a link transports exceeds
// eps. A link gives every receiver point the radiosity rho_r B_s F_rs where
// the exact transfer (B_s constant) is rho_r B_s F(x), F(x) the point-to-
// element form factor with visibility. With F(x) in [Fmin, Fmax] over the
// receiver the error is at most
//     dB = max_c rho_r,c B_s,c (Fmax - Fmin)        (max over RGB channels)
// times the receiver's importance (1 until computed; Smits, Arvo & Salesin
// 1992), accepted when within eps (ErrorNorm, oracles/oracle.h):
//     norm = power      A_r dB <= eps * P, P the power hr.eps_power names
//                       (hr/eps_power.h), the units of `bfa`;
//     norm = radiosity  dB <= eps * (largest emitted radiosity).
// Otherwise the element that looks larger from the other is subdivided
// (refineLarger, HSA91; setting side).
//
// This per-link bound judges links touching a cluster ([Fmin, Fmax] =
// [0, max(F, Fupper)]: a point approximation has no receiver points). Links
// between two surfaces are judged by their receiver's aggregate instead
// (hr/receiver_error.h): the receiver's links are accepted when
//     A_r * E_r <= eps * P,   E_r = max_k D(x_k) - min_k D(x_k)
// (the range of the summed kernel error over the receiver's sample points);
// otherwise the links carrying at least an even share of E_r are refined on
// the receiver side, and the sender where its own variation F rho_r
// max_c |B_c - B_s| exceeds the same bound. Polynomial bases judge what the
// projection misses (F_l(x) - P_l(x)). The estimates are sampled, not the
// fully reliable bounds of Holzschuch & Sillion, and ignore the error of B_s
// itself, which Lischinski et al. 1994 propagate. Measurements behind these
// choices: papers/README.md ("The receiver check by default").
//
// Settings: oracle.* (`hrad settings oracle.`).
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
