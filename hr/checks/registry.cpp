#include "hr/checks/registry.h"

#include <algorithm>

namespace hrad::hr {

const std::vector<CheckEntry>& refinementChecks() {
    static const std::vector<CheckEntry> table = {
        {"receiver", makeReceiverCheck,
         "a receiver's links together within eps (bfa, ff; hr.receiver_eps)"},
        {"leaf_budget", makeLeafBudgetCheck,
         "the leaves' averages' error summed within eps (hr.leaf_budget)"},
        {"sender_total", makeSenderTotalCheck,
         "a subdivided sender's mean over all its receivers within eps (hr.sender_total)"},
        {"sampled_uncertainty", makeSampledUncertaintyCheck,
         "a sampled near cluster link's error bound within eps"},
        {"partial_receivers", makePartialReceiversCheck,
         "the light a cluster link may hand to unseen surfaces within eps "
         "(cluster.partial_receivers)"},
        {"near_stand_in", makeNearStandInCheck,
         "a refused near stand-in opens the side its geometry asks for (cluster.near)"},
        {"importance", makeImportanceCheck,
         "weights each link's error by its receiver's importance (hr.importance)"},
    };
    return table;
}

std::vector<std::unique_ptr<RefinementCheck>> makeRefinementChecks(
    const HrSettings& s, const std::vector<CheckEntry>& extra) {
    std::vector<std::unique_ptr<RefinementCheck>> out;
    // hr.checks: the table's rows it names (all by default), in table order.
    for (const CheckEntry& e : refinementChecks())
        if (s.allChecks || std::find(s.checks.begin(), s.checks.end(), e.name) != s.checks.end())
            out.push_back(e.make(s));
    for (const CheckEntry& e : extra) out.push_back(e.make(s));
    return out;
}

}  // namespace hrad::hr
