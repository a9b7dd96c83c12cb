// `ff`: form-factor threshold refinement.
//
// Hanrahan, Salzman & Aupperle 1991, section 3 ("Refine"): a link is accepted
// when both form-factor estimates F_rs and F_sr are below F_eps, or when
// neither element may be subdivided (area below A_eps); otherwise the element
// that looks larger from the other one is subdivided.
//
// Polynomial bases (hr.basis linear, quadratic, cubic). F stands for the
// error of a constant link (the whole transfer may be misplaced over the
// receiver); a higher-order receiver misses only what the projection of the
// kernel onto its basis misses, so the residual R_rs (LinkEstimate::
// basisResidualF, the rule of `bfa`, oracles/bfa_oracle.h) takes F's place in
// both tests: accept when R_rs and R_rs A_r / A_s are below F_eps. Partially
// visible links keep F (the residual of the unoccluded kernel does not see a
// shadow edge). basis_residual = false or use_bound restore the constant rule.
// (`uniform` fixes the mesh by definition and stays blind to the basis.)
//
// The receiver check. The solver adds, by default, the error oracles'
// receiver check to this rule (hr.receiver_eps = auto, hr/solver.h): link by
// link, the errors of the links a coarse receiver accepts add up, and in a
// closed box with rho 0.9 the accepted coefficients of some leaves sum above
// 1 / rho, so the gather diverges (papers/README.md "The receiver check by
// default"). The check bounds a power, a fraction of the power hr.eps_power
// names (by default the smaller of the emitted and the reflected power), and
// F_eps is a form factor; under auto it takes F_eps / 100, so that the error
// falls with F_eps (at a fixed 1e-3 the Cornell box stayed at 4.9-5.7 % for
// F_eps 0.2 to 0.05). The factor is a choice, not a bound: F_eps / 1000
// cuts the error 3-6 times for 6-21 times the links (papers/README.md "ff's
// check follows its eps"). hr.receiver_eps = off gives the rule alone. The
// solver's other power checks (the light a stand-in or a partially visible
// cluster link may misplace, a sampled near link's error) take the same
// F_eps / 100 (receiverCheckEps), whatever hr.receiver_eps: taking F_eps
// itself as the power fraction left the classroom's clustered solve 7.9 %
// darker than its unclustered one (papers/README.md "ff's clustered solves
// were dark").
//
// Settings:
//   eps          double  0.01   F_eps, form-factor threshold (0, 1]
//   basis_residual bool  true   higher-order bases: judge by R_rs (above)
//   min_area     double  0      A_eps: elements at or below this area are not
//                               subdivided by this oracle (0: only the solver's
//                               own minimum element area applies)
//   use_bound    bool    false  test the conservative upper bound Fupper instead
//                               of the unoccluded estimate (never under-refines)
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
    static constexpr double kReceiverCheckPerF = 0.01;
    std::string name() const override { return "ff"; }
    std::string describe() const override;
    const Settings& settings() const { return s_; }

  private:
    Settings s_;
};

}  // namespace hrad::oracles
