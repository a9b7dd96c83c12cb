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
//     norm = power      A_r dB <= eps * (total emitted power, max channel),
//                       the units of `bfa`, so eps values are comparable;
//     norm = radiosity  dB <= eps * (largest emitted radiosity, max channel),
//                       the per-radiosity criterion of the papers.
// Otherwise the element that looks larger from the other is subdivided
// (refineLarger, HSA91; setting side), constrained by what may subdivide.
//
// Fmin and Fmax come from the solver (LinkEstimate; needsBounds() is true):
// the smallest and largest point-to-element form factor over the receiver
// points of the form-factor rule (transport/formfactor.h pointRange), with
// partial visibility widening the interval to [0, Fmax]. They are sample
// estimates, not the fully reliable bounds of Holzschuch & Sillion 1998: the
// extremes of F(x) may lie between the rule's points. The bound also ignores
// the error of B_s itself, which Lischinski, Smits & Greenberg 1994 propagate
// through interreflections.
//
// Cost: the solver re-evaluates the receiver-point form factors (9 contour
// integrals with the default 3 x 3 rule, no rays) for every link it judges,
// in every iteration. Measured on cornell at eps 1e-4 (L2 vs the fm level-3
// reference; solve time): error 21.5k links, 0.45 %, 0.47 s; kv 14.8k links,
// 0.54 %, 0.34 s; bfa 23.1k links, 0.53 %, 0.12 s: a lower error per link
// for ~3-4x the time of bfa.
//
// Settings:
//   eps       double  1e-3     threshold (0, 1], relative as set by norm
//   norm      string  "power"  "power" | "radiosity" (see above)
//   min_area  double  0        elements at or below this area are not subdivided
//   side      string  "larger" which element a refused link subdivides: "larger"
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
};

}  // namespace hrad::oracles
