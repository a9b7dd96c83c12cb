// `ff`: form-factor threshold refinement.
//
// Hanrahan, Salzman & Aupperle 1991, section 3 ("Refine"): a link is accepted
// when both form-factor estimates F_rs and F_sr are below F_eps, or when
// neither element may be subdivided (area below A_eps); otherwise the element
// that looks larger from the other one is subdivided.
//
// Polynomial bases (hr.basis linear, quadratic, cubic): a higher-order
// receiver misses only what the projection of the kernel onto its basis
// misses, so the residual R_rs (LinkEstimate::basisResidualF, the rule of
// `bfa`) takes F's place in both tests. Partially visible links keep F (the
// unoccluded kernel's residual does not see a shadow edge); basis_residual =
// false or use_bound restore the constant rule.
//
// The receiver check (hr/checks/receiver.cpp) is added by default: link by
// link, the errors a coarse receiver accepts add up, and in a closed box with
// rho 0.9 the gather can diverge. It bounds a power, so under
// hr.receiver_eps = auto it takes F_eps / 100, and the error falls with F_eps;
// the factor is a choice, not a bound (papers/README.md, "The receiver check
// by default" and "ff's check follows its eps"). The solver's other power
// checks take the same F_eps / 100 (receiverCheckEps).
//
// Settings: oracle.* (`hrad settings oracle.`).
#pragma once

#include "oracles/oracle.h"

namespace hrad::oracles {

class FormFactorOracle final : public Oracle {
  public:
    struct Settings {
        double eps = 0.01;
        double minArea = 0.0;
        bool useBound = false;
        bool basisResidual = true;
        static Settings fromParams(const Params& p);
    };
    explicit FormFactorOracle(Settings s) : s_(s) {}
    Decision decide(const LinkEstimate& e) const override;
    bool needsBasisResidual() const override { return s_.basisResidual && !s_.useBound; }
    bool needsUpperBound() const override { return s_.useBound; }
    /// The receiver check's eps under auto: F_eps / 100 of the power eps refers to
    /// (above, "The receiver check").
    double receiverCheckEps() const override { return kReceiverCheckPerF * s_.eps; }
    double eps() const override { return s_.eps; }
    static constexpr double kReceiverCheckPerF = 0.01;
    std::string name() const override { return "ff"; }
    std::string describe() const override;
    const Settings& settings() const { return s_; }

  private:
    Settings s_;
};

}  // namespace hrad::oracles
