// Polynomial bases on a real clustered room (RenderPark's classroom, from
// ../shared/scenes; skipped where that folder is absent). The chamfers of its
// tables are slivers 7 mm x 1.2 m meeting at right angles; before the check
// on the point-to-point rule (hr.basis_check, transport/coupling.h) their
// higher-order couplings were wrong and the Jacobi iteration diverged for the
// linear and quadratic bases (red power growing up to 18x per iteration).
#include <gtest/gtest.h>

#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/test_util.h"

using namespace hrad;
using namespace hrad::hr;

TEST(BasisRooms, ClassroomConvergesForTheLinearBasis) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes not present";
    const auto path = *dir / "renderpark-mgf" / "salon" / "classroom.mgf";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
    scene::Scene s = scene::loadScene(path.string());
    transport::Visibility vis(s);
    auto settings = [](const std::string& basis) {
        Params p;
        p.set("hr.oracle", std::string("bfa"));
        p.set("oracle.eps", 1e-3);
        p.set("cluster.model", std::string("oriented"));
        p.set("hr.max_iterations", int64_t(60));
        p.set("hr.basis", basis);
        HrSettings st = HrSettings::fromParams(p);
        p.reportUnused();
        return st;
    };
    HrResult c = HrSolver(s, vis, settings("constant")).solve();
    HrResult l = HrSolver(s, vis, settings("linear")).solve();
    EXPECT_TRUE(l.converged);
    const RGB pc = c.hierarchy->reflectedPower(), pl = l.hierarchy->reflectedPower();
    std::cout << "reflected power: constant " << pc.x << " " << pc.y << " " << pc.z << ", linear "
              << pl.x << " " << pl.y << " " << pl.z << "\n";
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(pl[k] / pc[k], 1.0, 0.05) << "channel " << k;
}
