#include "oracles/error_oracle.h"

#include <fmt/format.h>

#include <algorithm>

namespace hrad::oracles {

ErrorBoundOracle::Settings ErrorBoundOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.eps = p.getDouble("eps", s.eps, 0.0, 1.0, true);
    s.norm = readErrorNorm(p, "norm", s.norm);
    s.minArea = p.getDouble("min_area", s.minArea, 0.0, 1e300);
    s.refineReceiver = p.getEnum("side", "larger", {"larger", "receiver"}) == "receiver";
    return s;
}

double ErrorBoundOracle::errorBound(const LinkEstimate& e) const {
    double width = std::max(0.0, e.Fmax - e.Fmin);
    return maxComponent(e.receiverRho * e.senderB) * width * e.importance;
}

Decision ErrorBoundOracle::decide(const LinkEstimate& e) const {
    if (errorWithinEps(errorBound(e), s_.eps, s_.norm, e)) return Decision::Accept;
    LinkEstimate c = e;
    c.receiverCanSubdivide = e.receiverCanSubdivide && e.receiverArea > s_.minArea;
    c.senderCanSubdivide = e.senderCanSubdivide && e.senderArea > s_.minArea;
    if (s_.refineReceiver) return constrain(Decision::RefineReceiver, c);
    return refineLarger(c);
}

std::string ErrorBoundOracle::describe() const {
    return fmt::format("error(eps={}, norm={}, min_area={}, side={})", s_.eps,
                       errorNormName(s_.norm), s_.minArea,
                       s_.refineReceiver ? "receiver" : "larger");
}

}  // namespace hrad::oracles
