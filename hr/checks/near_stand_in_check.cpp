// Near stand-ins (cluster.near = stand_in): a refused stand-in, or sampled
// link, of a cluster pair too close for the point approximation is opened on
// the side its geometry asks for (LinkBuilder::forcedDecision), not the side
// the oracle or an earlier check chose (cluster/link.h "Judged stand-ins").
// It runs last: on every refusal of the judging pass and on those the
// finishing checks make (RoundDecisions::changedInFinish).
//
// Settings: cluster.near [stand_in] (cluster/link.h).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <memory>

#include "hr/checks/check.h"
#include "hr/checks/registry.h"

namespace hrad::hr {
namespace {

class NearStandInCheck final : public RefinementCheck {
  public:
    const char* name() const override { return "near_stand_in"; }
    bool beginPass(const CheckPass& pass) override {
        return pass.nearStandIns && pass.h.numClusters() > 0;  // sampled links join clusters
    }
    void amend(const CheckRound& round, size_t i, const oracles::LinkEstimate&,
               oracles::Decision& d) const override {
        d = sided(round, i, d);
    }
    void finishRound(const CheckRound& round, RoundDecisions& d) override {
        const size_t n = round.pending.size();
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const auto& range) {
            for (size_t i = range.begin(); i != range.end(); ++i)
                if (d.changedInFinish[i]) d.decision[i] = uint8_t(sided(round, i, d[i]));
        });
    }

  private:
    static oracles::Decision sided(const CheckRound& round, size_t i, oracles::Decision d) {
        const Link& l = round.pending[i];
        if (d == oracles::Decision::Accept || !(l.flags & Link::kSampled)) return d;
        const oracles::Decision f = round.links.forcedDecision(round.h, round.recv[i], l.sender);
        return f != oracles::Decision::Accept ? f : d;
    }
};

}  // namespace

std::unique_ptr<RefinementCheck> makeNearStandInCheck(const HrSettings&) {
    return std::make_unique<NearStandInCheck>();
}

}  // namespace hrad::hr
