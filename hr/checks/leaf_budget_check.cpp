// Leaf budget (hr.leaf_budget): the receiver check bounds each receiver,
// not their sum; this holds the error of the leaves' averages, summed over
// the leaves (every ancestor link's push to every leaf, signed, so that a
// leaf's own links and its ancestors' cancel: hr/receiver_error.h
// leafErrorTotals), to the receiver check's eps of the eps power, pushing
// the links of the receivers with the largest parts one level down
// (leafBudgetMarks). In the spirit of the global error bounds of
// Lischinski et al. 1994 and Holzschuch & Sillion 1998.
//
// Settings: hr.leaf_budget  balanced | full | off  [balanced]
//   full: the sum within eps, judged in every pass (no lazy refinement).
//   balanced: the sum within eps beyond the error inside the leaves (the
//     pointwise estimate less the averages'), judged where a stage would
//     converge and, after a pass that pushed links, after the next gather;
//     pushes aim at half the eps beyond it. Its last check's totals are the
//     final error_estimate_leaves / _points when nothing changed after it.
//   With hr.receiver_eps = off the balanced budget is off for bfa and ff.
// Constant basis only. Measurements: papers/README.md, "The leaf budget".
#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>

#include "core/timer.h"
#include "hr/checks/check.h"
#include "hr/checks/registry.h"

namespace hrad::hr {
namespace {

using LeafBudget = HrSettings::LeafBudget;

class LeafBudgetCheck final : public RefinementCheck {
  public:
    LeafBudgetCheck(LeafBudget mode, double receiverEps) : mode_(mode), receiverEps_(receiverEps) {}
    const char* name() const override { return "leaf_budget"; }
    bool beginPass(const CheckPass& pass) override;
    void amend(const CheckRound& round, size_t i, const oracles::LinkEstimate& e,
               oracles::Decision& d) const override {
        const uint32_t r = round.recv[i], s = round.pending[i].sender;
        if (d == oracles::Decision::Accept && r < push_.size() && push_[r] &&
            !round.h.isCluster(r) && !round.h.isCluster(s) && e.receiverCanSubdivide)
            d = oracles::Decision::RefineReceiver;
    }
    void beginStage() override { marks_.clear(); }
    bool atConvergence(CheckConvergence& c) override;
    bool wantsPass() const override { return !marks_.empty(); }
    bool judgesEveryIteration() const override { return mode_ == LeafBudget::Full; }

  private:
    /// The budget in power (luminance): the receiver check's eps of the eps
    /// power; 0 where there is none.
    double budgetPower(const oracles::Oracle& oracle, double epsPower, const RGB& emitted) const {
        double leafEps = oracle.receiverCheckEps();
        if (!oracle.needsReceiverError() && receiverEps_ > 0.0) leafEps = receiverEps_;
        if (!(leafEps > 0.0) || !oracle.refinesByError()) return 0.0;
        return leafEps * epsPower * luminance(emitted) / std::max(maxComponent(emitted), 1e-300);
    }
    LeafBudget mode_;
    double receiverEps_;
    std::vector<uint8_t> push_;   ///< receivers pushed in this pass
    std::vector<uint8_t> marks_;  ///< balanced: the marks the next pass pushes
};

bool LeafBudgetCheck::beginPass(const CheckPass& pass) {
    push_.clear();
    if (mode_ == LeafBudget::Full && pass.h.basisDegree() == 0) {
        const double budget = budgetPower(pass.oracle, pass.epsPower, pass.emitted);
        if (budget > 0.0) {
            std::vector<double> shares;
            const LeafErrorTotals t =
                leafErrorTotals(pass.h, pass.recv, pass.pending, pass.engine, false, nullptr,
                                &shares);
            push_ = leafBudgetMarks(shares, t.leaves - budget);
            spdlog::debug("leaf budget: leaves {:.4g} against {:.4g}, {} pushed", t.leaves,
                          budget, std::count(push_.begin(), push_.end(), uint8_t(1)));
        }
    } else if (!marks_.empty()) {
        push_ = std::move(marks_);
        marks_.clear();
    }
    return !push_.empty();
}

bool LeafBudgetCheck::atConvergence(CheckConvergence& c) {
    c.cache.valid = false;
    if (mode_ != LeafBudget::Balanced || c.h.basisDegree() != 0) return false;
    // The default budget sums the receiver check's errors: with the check
    // off (hr.receiver_eps = off: bfa and ff as published) it is off too.
    if (!c.oracle.needsReceiverError() && receiverEps_ == 0.0) return false;
    const double budget = budgetPower(c.oracle, c.epsPower, c.emitted);
    if (!(budget > 0.0)) return false;
    Timer t0;
    const std::vector<uint32_t> recv = c.h.linkReceivers();
    std::vector<double> shares;
    LeafErrorTotals& totals = c.cache.totals;
    totals = leafErrorTotals(c.h, recv, c.h.links(), c.engine, true,
                             c.h.hasKernelSamples() ? &c.h.kernelSamples() : nullptr, &shares);
    // The leaves' averages may be wrong by eps beyond the error inside them.
    const double allowed = budget + totals.inside();
    spdlog::debug("leaf budget: leaves {:.4g}, inside {:.4g}, eps {:.4g} ({:.2f} s)",
                  totals.leaves, totals.inside(), budget, t0.seconds());
    if (totals.leaves > allowed) {
        // Pushes aim at half the budget beyond the inside error: a push
        // removes only part of a receiver's share, and aiming at the limit
        // itself crept towards it one receiver per pass.
        marks_ = leafBudgetMarks(shares, totals.leaves - allowed + 0.5 * budget);
        if (!marks_.empty()) {
            c.seconds += t0.seconds();  // a judging pass follows
            return true;
        }
    }
    // Held: the pass is the final estimate's if nothing changes after it.
    c.cache.valid = true;
    c.cache.seconds = t0.seconds();
    c.seconds += c.cache.seconds;
    return false;
}

}  // namespace

std::unique_ptr<RefinementCheck> makeLeafBudgetCheck(const HrSettings& s) {
    return std::make_unique<LeafBudgetCheck>(s.leafBudget, s.receiverEps);
}

}  // namespace hrad::hr
