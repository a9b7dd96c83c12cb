#include "oracles/kv_oracle.h"

#include <algorithm>

namespace hrad::oracles {

double KernelVariationOracle::linkError(const LinkEstimate& e) const {
    double dK = std::max({0.0, e.Fmax - e.F, e.F - e.Fmin});
    return maxComponent(e.receiverRho * e.senderB) * dK * e.importance;
}

}  // namespace hrad::oracles
