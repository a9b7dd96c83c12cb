#include "oracles/error_oracle.h"

#include <algorithm>

namespace hrad::oracles {

double ErrorBoundOracle::linkError(const LinkEstimate& e) const {
    double width = std::max(0.0, e.Fmax - e.Fmin);
    return maxComponent(e.receiverRho * e.senderB) * width * e.importance;
}

}  // namespace hrad::oracles
