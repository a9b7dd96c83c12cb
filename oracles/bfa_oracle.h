// `bfa`: transported-power ("BF") refinement.
//
// Hanrahan, Salzman & Aupperle 1991, section 4 ("brightness-weighted
// refinement"): the error a link can make is bounded by the power it carries,
// rho_r * B_s * F_rs * A_r. A link is accepted when that power (max over RGB
// channels) is below eps times a power of the scene: HSA91 take the total
// emitted power; here it is the power hr.eps_power names (max channel; by
// default the smaller of the emitted power and the reflected power the
// iteration is heading to, hr/eps_power.h), so eps is a fraction of the
// light the error metrics measure and comparable across scenes.
// Otherwise the element that looks larger from the other is subdivided.
// With importance (Smits, Arvo & Salesin 1992) the power is also multiplied by
// the receiver's importance, which is 1 until importance is computed.
//
// Polynomial bases (hr.basis linear, quadratic, cubic; scene/basis.h). A
// link's receiver then holds the Galerkin projection of the link's transfer,
// not its average, so the power at stake is what the projection misses: the
// rule is
//   rho_r * B_s * R_rs * A_r <= eps * P   (P: the power hr.eps_power names),
//   R_rs = max_k |P(x_k) - F(x_k)| * visibility
// with F(x) the point form factor from receiver point x to the sender and P
// its projection onto the receiver's basis, over the receiver's corners, edge
// midpoints and centroid (LinkEstimate::basisResidualF; the sender's own
// variation is not judged, as in the constant rule). Partially visible links
// keep the constant rule (the residual of the unoccluded kernel does not see
// a shadow edge across the receiver). The higher the degree,
// the smaller R for a smooth transfer, and the less the link is refined. For
// the constant basis the published rule above applies unchanged (it bounds
// the error by all the power the link carries, not by the projection's
// miss). use_bound and basis_residual = false restore the constant rule for
// every basis.
//
// The solver adds, by default, the error oracles' receiver check to this
// rule (hr.receiver_eps = auto, hr/solver.h): link by link, the errors of the
// links a coarse receiver accepts add up (furnace, papers/README.md "The
// receiver check by default"); hr.receiver_eps = off gives the rule alone.
//
// Settings:
//   eps          double  1e-3   fraction of the power hr.eps_power names (0, 1]
//   basis_residual bool  true   higher-order bases: judge by R_rs (above)
//   use_bound    bool    false  use the upper bound Fupper instead of F
//   min_area     double  0      elements at or below this area are not subdivided
#pragma once

#include "oracles/oracle.h"

namespace hrad::oracles {

class PowerOracle final : public Oracle {
  public:
    struct Settings {
        double eps = 1e-3;
        bool useBound = false;
        double minArea = 0.0;
        bool basisResidual = true;
        static Settings fromParams(const Params& p);
    };
    explicit PowerOracle(Settings s) : s_(s) {}
    Decision decide(const LinkEstimate& e) const override;
    bool needsBasisResidual() const override { return s_.basisResidual && !s_.useBound; }
    bool needsUpperBound() const override { return s_.useBound; }
    std::string name() const override { return "bfa"; }
    double powerEps() const override { return s_.eps; }
    std::string describe() const override;
    /// The transported power the decision is based on (max channel).
    double transportedPower(const LinkEstimate& e) const;

  private:
    Settings s_;
};

}  // namespace hrad::oracles
