// `bfa`: transported-power ("BF") refinement.
//
// Hanrahan, Salzman & Aupperle 1991, section 4 ("brightness-weighted
// refinement"): the error a link can make is bounded by the power it carries,
// rho_r * B_s * F_rs * A_r. A link is accepted when that power (max over RGB
// channels) is below eps times a power of the scene: HSA91 take the total
// emitted power; here it is the power hr.eps_power names (hr/eps_power.h), so
// eps is a fraction of the light the error metrics measure. Otherwise the
// element that looks larger from the other is subdivided. With importance
// (Smits, Arvo & Salesin 1992) the power is multiplied by the receiver's
// importance (1 until computed).
//
// Polynomial bases (hr.basis linear, quadratic, cubic; scene/basis.h): the
// receiver holds the Galerkin projection of the transfer, so the power at
// stake is what the projection misses:
//   rho_r * B_s * R_rs * A_r <= eps * P,  R_rs = max_k |P(x_k) - F(x_k)| * v
// over the receiver's corners, edge midpoints and centroid (LinkEstimate::
// basisResidualF). Partially visible links keep the constant rule (the
// unoccluded kernel's residual does not see a shadow edge); use_bound and
// basis_residual = false restore it for every basis.
//
// The receiver check (hr/checks/receiver.cpp, hr.receiver_eps = auto) is added
// by default: link by link, the errors a coarse receiver accepts add up
// (papers/README.md, "The receiver check by default"); hr.receiver_eps = off
// gives the rule alone.
//
// Settings: oracle.* (`hrad settings oracle.`).
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
    double eps() const override { return s_.eps; }
    std::string describe() const override;
    /// The transported power the decision is based on (max channel).
    double transportedPower(const LinkEstimate& e) const;

  private:
    Settings s_;
};

}  // namespace hrad::oracles
