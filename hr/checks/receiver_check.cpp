// Receiver check (hr.receiver_eps): for oracles that judge links one by one
// (bfa, ff), a link the oracle accepts is still refined on the receiver side
// while its receiver's aggregate kernel error, the range of the irradiance
// all its links together give over the receiver (hr/receiver_error.h),
// carries more than eps of the power hr.eps_power names (A_r range >
// eps Phi) and the link carries at least an even share of it. Links judged
// one by one add up: next to a finely linked wall a coarse receiver accepts
// many links each under eps. The aggregate follows the error-driven
// refinement of Lischinski et al. 1994 and Holzschuch & Sillion 1998.
//
// Settings: hr.receiver_eps  auto | off | a fraction of the eps power
//   [auto: Oracle::receiverCheckEps(), the oracle's eps mapped to a power
//   fraction; ff: F_eps / 100]. The error oracles (error, kv) judge the
//   aggregate themselves and take no receiver check.
// Measurements: papers/README.md, "The receiver check by default".
#include <memory>

#include "hr/checks/check.h"
#include "hr/checks/registry.h"

namespace hrad::hr {
namespace {

class ReceiverCheck final : public RefinementCheck {
  public:
    const char* name() const override { return "receiver"; }
    bool beginPass(const CheckPass& pass) override {
        eps_ = pass.guardEps;
        return eps_ > 0.0;
    }
    CheckNeeds needs() const override { return {.receiverErrors = true}; }
    void amend(const CheckRound&, size_t, const oracles::LinkEstimate& e,
               oracles::Decision& d) const override {
        // Only the receiver's subdivision lowers its aggregate (the children
        // of a sender sum to its kernel): a receiver that cannot subdivide
        // keeps the link (oracles::receiverRefinement).
        if (d == oracles::Decision::Accept && e.receiverRange >= 0.0 &&
            e.receiverRange * e.receiverArea * e.importance > eps_ * e.emittedPower &&
            oracles::carriesReceiverShare(e))
            d = oracles::receiverRefinement(e);
    }

  private:
    double eps_ = 0.0;
};

}  // namespace

std::unique_ptr<RefinementCheck> makeReceiverCheck(const HrSettings&) {
    return std::make_unique<ReceiverCheck>();
}

}  // namespace hrad::hr
