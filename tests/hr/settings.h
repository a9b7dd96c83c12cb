// Settings for the hierarchical-solver tests.
#pragma once

#include <string>
#include <utility>

#include "hr/solver.h"

namespace hrad::test {

/// HrSettings for `oracle` (eps, or level 2 for `uniform`), a tight
/// convergence tolerance and the given cluster model; unknown keys fail.
inline hr::HrSettings hrSettings(const std::string& oracle, double eps,
                                 const std::string& clusterModel = "none",
                                 double minAreaRel = 1e-5) {
    Params p;
    p.set("hr.oracle", oracle);
    if (oracle == "uniform")
        p.set("oracle.level", int64_t(2));
    else
        p.set("oracle.eps", eps);
    p.set("hr.tolerance", 1e-7);
    p.set("hr.min_area_rel", minAreaRel);
    p.set("cluster.model", clusterModel);
    hr::HrSettings s = hr::HrSettings::fromParams(p);
    p.reportUnused();
    return s;
}

/// Unclustered settings converged far (tolerance 1e-8, up to 400
/// iterations) with the given oracle, eps and basis; `extra` adds other
/// keys. Unknown keys fail.
inline hr::HrSettings plateSettings(const std::string& oracle, double eps, const std::string& basis,
                                    Params extra = {}) {
    Params p = std::move(extra);
    p.set("hr.oracle", oracle);
    p.set("oracle.eps", eps);
    p.set("hr.tolerance", 1e-8);
    p.set("hr.max_iterations", int64_t(400));
    p.set("cluster.model", std::string("none"));
    p.set("hr.basis", basis);
    hr::HrSettings s = hr::HrSettings::fromParams(p);
    p.reportUnused();
    return s;
}

}  // namespace hrad::test
