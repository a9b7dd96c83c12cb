#include "oracles/ff_oracle.h"

#include <fmt/format.h>

#include <algorithm>

namespace hrad::oracles {

FormFactorOracle::Settings FormFactorOracle::Settings::fromParams(const Params& p) {
    Settings s;
    s.eps = p.getDouble({"eps", "oracle threshold: form factor F_eps a link may have (ff)"}, s.eps,
                        0.0, 1.0, true);
    s.minArea = p.getDouble({"min_area", "elements below this area are not refined by the oracle"},
                            s.minArea, 0.0, 1e300);
    s.useBound =
        p.getBool({"use_bound", "judge by the form factor's upper bound rather than its estimate"},
                  s.useBound);
    s.basisResidual = p.getBool(
        {"basis_residual",
         "with a polynomial basis, judge the residual the basis leaves, not the whole transfer"},
        s.basisResidual);
    return s;
}

Decision FormFactorOracle::decide(const LinkEstimate& e) const {
    double frs = s_.useBound ? e.Fupper : e.unoccludedF;
    if (needsBasisResidual() && e.basisResidualF >= 0.0) frs = e.basisResidualF;
    double fsr = e.senderArea > 0 ? frs * e.receiverArea / e.senderArea : 0.0;
    if (std::max(frs, fsr) < s_.eps) return Decision::Accept;
    LinkEstimate c = e;
    c.receiverCanSubdivide = e.receiverCanSubdivide && e.receiverArea > s_.minArea;
    c.senderCanSubdivide = e.senderCanSubdivide && e.senderArea > s_.minArea;
    c.F = frs;
    return refineLarger(c);
}

std::string FormFactorOracle::describe() const {
    return fmt::format("ff(eps={}, min_area={}, use_bound={}{})", s_.eps, s_.minArea, s_.useBound,
                       s_.basisResidual ? "" : ", basis_residual=false");
}

}  // namespace hrad::oracles
