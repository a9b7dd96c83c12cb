#include "oracles/ff_oracle.h"

#include <algorithm>

#include <fmt/format.h>

namespace hrad::oracles {

FormFactorOracle::Settings FormFactorOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.eps = p.getDouble("eps", s.eps, 0.0, 1.0, true);
    s.minArea = p.getDouble("min_area", s.minArea, 0.0, 1e300);
    s.useBound = p.getBool("use_bound", s.useBound);
    return s;
}

Decision FormFactorOracle::decide(const LinkEstimate& e) const {
    double frs = s_.useBound ? e.Fupper : e.unoccludedF;
    double fsr = e.senderArea > 0 ? frs * e.receiverArea / e.senderArea : 0.0;
    if (std::max(frs, fsr) < s_.eps) return Decision::Accept;
    LinkEstimate c = e;
    c.receiverCanSubdivide = e.receiverCanSubdivide && e.receiverArea > s_.minArea;
    c.senderCanSubdivide = e.senderCanSubdivide && e.senderArea > s_.minArea;
    c.F = frs;
    return refineLarger(c);
}

std::string FormFactorOracle::describe() const {
    return fmt::format("ff(eps={}, min_area={}, use_bound={})", s_.eps, s_.minArea, s_.useBound);
}

}  // namespace hrad::oracles
