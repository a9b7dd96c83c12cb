// Partial receivers (cluster.partial_receivers = open): a partially visible
// (or all-blocked) link into a cluster hands its light to every surface of
// the cluster that faces the sender, seen or not, so up to its unseen
// fraction of its power, rho B F_unoccluded (1 - v) A, lands on the wrong
// surfaces (closed cavities, the far side of a table). A stand-in whose
// receiving cluster takes the light by area may misplace all of it. That
// power must be within the oracle's eps share of the eps power
// (Oracle::receiverCheckEps), and so must the sum over the links into one
// cluster (as a receiver's averaged senders misplace light together,
// hr/receiver_error.h), refining the links with at least an even share of
// it; else the receiving cluster is opened. The sums are known only once
// the round is decided: amend() records each link's power, finishRound()
// refines.
//
// Settings: cluster.partial_receivers  open | keep [open]; the stand-in part
// also runs with cluster.near = stand_in. Measurements: papers/README.md
// (graz.mgf one-sided, light on regions Monte Carlo has dark).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <memory>

#include "hr/checks/check.h"
#include "hr/checks/registry.h"

namespace hrad::hr {
namespace {

class PartialReceiversCheck final : public RefinementCheck {
  public:
    explicit PartialReceiversCheck(bool open) : open_(open) {}
    const char* name() const override { return "partial_receivers"; }
    bool beginPass(const CheckPass& pass) override {
        eps_ = pass.checkEps;
        return (open_ || pass.nearStandIns) && eps_ > 0 && pass.h.numClusters() > 0;
    }
    void prepareRound(const CheckRound& round) override {
        misplaced_.assign(round.capHit ? 0 : round.pending.size(), 0.0);
    }
    void amend(const CheckRound& round, size_t i, const oracles::LinkEstimate& e,
               oracles::Decision&) const override {
        if (!round.h.isCluster(round.recv[i])) return;
        const Link& l = round.pending[i];
        double& out = misplaced_[i];
        if (l.byArea()) {
            out = maxComponent(e.receiverRho * e.senderB) * e.F * e.receiverArea * e.importance;
        } else if (open_ && (l.flags & (Link::kPartial | Link::kUncertain))) {
            const double unseen = (l.flags & Link::kUncertain) ? 1.0 : 1.0 - e.visibility;
            out = maxComponent(e.receiverRho * e.senderB) *
                  (e.visibility > 0 ? e.F / e.visibility : e.F) * unseen * e.receiverArea *
                  e.importance;
        }
    }
    void finishRound(const CheckRound& round, RoundDecisions& d) override;
    void releaseRound() override { std::vector<double>().swap(misplaced_); }

  private:
    bool open_;
    double eps_ = 0.0;
    /// The power each pending link of the round may misplace; amend() writes
    /// link i's slot only (parallel).
    mutable std::vector<double> misplaced_;
};

void PartialReceiversCheck::finishRound(const CheckRound& round, RoundDecisions& d) {
    if (misplaced_.empty()) return;
    const Hierarchy& h = round.h;
    const size_t n = round.pending.size();
    std::vector<double> clusterMisplaced(h.numClusters(), 0.0);
    std::vector<uint32_t> clusterPartial(h.numClusters(), 0);
    for (size_t i = 0; i < n; ++i)
        if (misplaced_[i] > 0) {
            clusterMisplaced[h.clusterIndex(round.recv[i])] += misplaced_[i];
            ++clusterPartial[h.clusterIndex(round.recv[i])];
        }
    const double limit = eps_ * round.epsPower;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            if (!(misplaced_[i] > 0) || d[i] != oracles::Decision::Accept) continue;
            const uint32_t r = round.recv[i], s = round.pending[i].sender;
            const uint32_t c = h.clusterIndex(r);
            if (!(misplaced_[i] > limit || (clusterMisplaced[c] > limit &&
                                            misplaced_[i] * clusterPartial[c] >= clusterMisplaced[c])))
                continue;
            oracles::LinkEstimate sides;
            sides.receiverCanSubdivide = h.canSubdivide(r);
            sides.senderCanSubdivide = h.canSubdivide(s);
            d.set(i, oracles::constrain(oracles::Decision::RefineReceiver, sides));
        }
    });
}

}  // namespace

std::unique_ptr<RefinementCheck> makePartialReceiversCheck(const HrSettings& s) {
    return std::make_unique<PartialReceiversCheck>(s.openPartialReceivers);
}

}  // namespace hrad::hr
