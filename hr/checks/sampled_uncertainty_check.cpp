// Sampled-link uncertainty: a near cluster pair estimated by sampling
// (Link::kSampled, cluster/link.h "Sampled near pairs") that the oracle
// accepts must also be known well enough: the power it may carry wrongly,
// rho_r B_s F A_r times its relative error bound (Link::uncertainty, in
// percent), within the oracle's eps share of the eps power
// (Oracle::receiverCheckEps). Otherwise the pair is opened on the side its
// geometry asks for (LinkBuilder::forcedDecision). Smits, Arvo & Greenberg
// 1994 refine cluster links by the bound of the transfer; this bounds the
// sampling error of the estimate instead.
//
// Settings: none of its own (cluster.near = sample | stand_in makes such links).
#include <memory>

#include "hr/checks/check.h"
#include "hr/checks/registry.h"

namespace hrad::hr {
namespace {

class SampledUncertaintyCheck final : public RefinementCheck {
  public:
    const char* name() const override { return "sampled_uncertainty"; }
    bool beginPass(const CheckPass& pass) override {
        eps_ = pass.checkEps;
        return eps_ > 0.0 && pass.h.numClusters() > 0;  // sampled links join clusters
    }
    void amend(const CheckRound& round, size_t i, const oracles::LinkEstimate& e,
               oracles::Decision& d) const override {
        const Link& l = round.pending[i];
        if (d == oracles::Decision::Accept && (l.flags & Link::kSampled) &&
            maxComponent(e.receiverRho * e.senderB) * e.F * (l.uncertainty / 100.0) *
                    e.receiverArea * e.importance >
                eps_ * e.emittedPower)
            d = round.links.forcedDecision(round.h, round.recv[i], l.sender);
    }

  private:
    double eps_ = 0.0;
};

}  // namespace

std::unique_ptr<RefinementCheck> makeSampledUncertaintyCheck(const HrSettings&) {
    return std::make_unique<SampledUncertaintyCheck>();
}

}  // namespace hrad::hr
