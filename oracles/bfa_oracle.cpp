#include "oracles/bfa_oracle.h"

#include <fmt/format.h>

namespace hrad::oracles {

PowerOracle::Settings PowerOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.eps = p.getDouble({"eps",
                         "oracle threshold: bfa/error/kv a fraction of the emitted power (the "
                         "power a link carries or misplaces), ff the form factor F_eps "
                         "(default 0.01); lower for accuracy, raise for speed"},
                        s.eps, 0.0, 1.0, true);
    s.useBound =
        p.getBool({"use_bound", "judge by the form factor's upper bound rather than its estimate"},
                  s.useBound);
    s.minArea = p.getDouble({"min_area", "elements below this area are not refined by the oracle"},
                            s.minArea, 0.0, 1e300);
    s.basisResidual = p.getBool(
        {"basis_residual",
         "with a polynomial basis, judge the residual the basis leaves, not the whole transfer"},
        s.basisResidual);
    return s;
}

double PowerOracle::transportedPower(const LinkEstimate& e) const {
    double f = s_.useBound ? e.Fupper : e.F;
    if (needsBasisResidual() && e.basisResidualF >= 0.0) f = e.basisResidualF;
    return maxComponent(e.receiverRho * e.senderB) * f * e.receiverArea * e.importance;
}

Decision PowerOracle::decide(const LinkEstimate& e) const {
    if (transportedPower(e) <= s_.eps * e.emittedPower) return Decision::Accept;
    LinkEstimate c = e;
    c.receiverCanSubdivide = e.receiverCanSubdivide && e.receiverArea > s_.minArea;
    c.senderCanSubdivide = e.senderCanSubdivide && e.senderArea > s_.minArea;
    if (s_.useBound) c.F = e.Fupper;
    return refineLarger(c);
}

std::string PowerOracle::describe() const {
    return fmt::format("bfa(eps={}, use_bound={}, min_area={}{})", s_.eps, s_.useBound, s_.minArea,
                       s_.basisResidual ? "" : ", basis_residual=false");
}

}  // namespace hrad::oracles
