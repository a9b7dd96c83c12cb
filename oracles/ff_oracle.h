// `ff`: form-factor threshold refinement.
//
// Hanrahan, Salzman & Aupperle 1991, section 3 ("Refine"): a link is accepted
// when both form-factor estimates F_rs and F_sr are below F_eps, or when
// neither element may be subdivided (area below A_eps); otherwise the element
// that looks larger from the other one is subdivided.
//
// Settings:
//   eps          double  0.01   F_eps, form-factor threshold (0, 1]
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
        static Settings fromParams(const Params& p);
    };
    explicit FormFactorOracle(Settings s) : s_(s) {}
    Decision decide(const LinkEstimate& e) const override;
    std::string name() const override { return "ff"; }
    std::string describe() const override;
    const Settings& settings() const { return s_; }

  private:
    Settings s_;
};

}  // namespace hrad::oracles
