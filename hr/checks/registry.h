// The refinement checks (hr/checks/check.h), in the order they amend a
// decision: one row each in registry.cpp.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "hr/checks/check.h"

namespace hrad::hr {

using CheckFactory = std::unique_ptr<RefinementCheck> (*)(const HrSettings&);

struct CheckEntry {
    const char* name;
    CheckFactory make;
    const char* summary;  ///< one line: what the check holds
};

/// The table, in amendment order.
const std::vector<CheckEntry>& refinementChecks();

/// The checks of a solve, in table order (each decides per pass whether it
/// takes part): those hr.checks names (HrSettings::checks), all by default. `extra` rows (tests) are appended after the table's.
std::vector<std::unique_ptr<RefinementCheck>> makeRefinementChecks(
    const HrSettings& s, const std::vector<CheckEntry>& extra = {});

// The factories, one per file of hr/checks/.
std::unique_ptr<RefinementCheck> makeImportanceCheck(const HrSettings&);
std::unique_ptr<RefinementCheck> makeReceiverCheck(const HrSettings&);
std::unique_ptr<RefinementCheck> makeLeafBudgetCheck(const HrSettings&);
std::unique_ptr<RefinementCheck> makeSenderTotalCheck(const HrSettings&);
std::unique_ptr<RefinementCheck> makeSampledUncertaintyCheck(const HrSettings&);
std::unique_ptr<RefinementCheck> makePartialReceiversCheck(const HrSettings&);
std::unique_ptr<RefinementCheck> makeNearStandInCheck(const HrSettings&);

}  // namespace hrad::hr
