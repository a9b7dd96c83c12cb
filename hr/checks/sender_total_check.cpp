// Sender total (hr.sender_total, with the receiver check): a link whose
// sender is subdivided gathers the sender's mean; the error of doing so,
// summed over all the sender's receivers (hr/receiver_error.h SenderTotal),
// must stay within the receiver check's eps share of the eps power, else
// the links with at least an even share of it are refined on the sender
// side (oracles::senderTotalRefines). Without it the receiver check's
// receiver-side refinement lost 0.9 % of the power of a closed room at bfa
// 1e-4 (papers/README.md, "The receiver check by default"). The error
// oracles read the same totals inside their own decision.
//
// Settings: hr.sender_total  bool [true].
#include <memory>

#include "hr/checks/check.h"
#include "hr/checks/registry.h"

namespace hrad::hr {
namespace {

class SenderTotalCheck final : public RefinementCheck {
  public:
    explicit SenderTotalCheck(bool on) : on_(on) {}
    const char* name() const override { return "sender_total"; }
    bool beginPass(const CheckPass& pass) override {
        eps_ = pass.guardEps;
        return on_ && eps_ > 0.0;
    }
    CheckNeeds needs() const override { return {.receiverErrors = true, .senderTotals = true}; }
    void amend(const CheckRound&, size_t, const oracles::LinkEstimate& e,
               oracles::Decision& d) const override {
        if (d == oracles::Decision::Accept && oracles::senderTotalRefines(e, eps_))
            d = oracles::senderRefinement(e);
    }

  private:
    bool on_;
    double eps_ = 0.0;
};

}  // namespace

std::unique_ptr<RefinementCheck> makeSenderTotalCheck(const HrSettings& s) {
    return std::make_unique<SenderTotalCheck>(s.senderTotal);
}

}  // namespace hrad::hr
