#include "oracles/kv_oracle.h"

#include <fmt/format.h>

#include <algorithm>

namespace hrad::oracles {

KernelVariationOracle::Settings KernelVariationOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.eps = p.getDouble("eps", s.eps, 0.0, 1.0, true);
    s.norm = readErrorNorm(p, "norm", s.norm);
    s.minArea = p.getDouble("min_area", s.minArea, 0.0, 1e300);
    s.refineReceiver = p.getEnum("side", "larger", {"larger", "receiver"}) == "receiver";
    return s;
}

double KernelVariationOracle::errorEstimate(const LinkEstimate& e) const {
    double dK = std::max({0.0, e.Fmax - e.F, e.F - e.Fmin});
    return maxComponent(e.receiverRho * e.senderB) * dK * e.importance;
}

Decision KernelVariationOracle::decide(const LinkEstimate& e) const {
    if (errorWithinEps(errorEstimate(e), s_.eps, s_.norm, e)) return Decision::Accept;
    LinkEstimate c = e;
    c.receiverCanSubdivide = e.receiverCanSubdivide && e.receiverArea > s_.minArea;
    c.senderCanSubdivide = e.senderCanSubdivide && e.senderArea > s_.minArea;
    if (s_.refineReceiver) return constrain(Decision::RefineReceiver, c);
    return refineLarger(c);
}

std::string KernelVariationOracle::describe() const {
    return fmt::format("kv(eps={}, norm={}, min_area={}, side={})", s_.eps, errorNormName(s_.norm),
                       s_.minArea, s_.refineReceiver ? "receiver" : "larger");
}

}  // namespace hrad::oracles
