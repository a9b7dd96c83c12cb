// `bfa`: transported-power ("BF") refinement.
//
// Hanrahan, Salzman & Aupperle 1991, section 4 ("brightness-weighted
// refinement"): the error a link can make is bounded by the power it carries,
// rho_r * B_s * F_rs * A_r. A link is accepted when that power (max over RGB
// channels) is below eps times the scene's total emitted power (max channel),
// so eps is a fraction of the light in the scene and comparable across scenes.
// Otherwise the element that looks larger from the other is subdivided.
// With importance (Smits, Arvo & Salesin 1992) the power is also multiplied by
// the receiver's importance, which is 1 until importance is computed.
//
// Settings:
//   eps          double  1e-3   fraction of total emitted power (0, 1]
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
        static Settings fromParams(const Params& p);
    };
    explicit PowerOracle(Settings s) : s_(s) {}
    Decision decide(const LinkEstimate& e) const override;
    std::string name() const override { return "bfa"; }
    double powerEps() const override { return s_.eps; }
    std::string describe() const override;
    /// The transported power the decision is based on (max channel).
    double transportedPower(const LinkEstimate& e) const;

  private:
    Settings s_;
};

}  // namespace hrad::oracles
