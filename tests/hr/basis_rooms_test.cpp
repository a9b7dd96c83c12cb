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

// The linear solve's reflected power against the Monte Carlo reference of
// issue "Error control" (16,384 paths per root patch, seed 1; `hrad --set
// mc.level=0 --set mc.samples=16384 --set mc.seed=1 reference SCENE --kind
// montecarlo` prints it with its standard error, 0.2 % per channel; stored
// here, the reference takes minutes). Measured: -0.8 / -0.3 / -0.1 % with
// the hand-over by openness (cluster/openness.h; -0.2 / +0.3 / +0.6 % when
// it was introduced), -2.5 / -2.1 / -1.6 % by cosine alone then; the constant basis at this eps is -4.3 % (green). A
// diverging iteration (the bug above) or light lost in the clusters fails
// 1.5 %. This is bfa as published (hr.receiver_eps = off): with the
// receiver check (the default) the same solve is -1.6 / -1.5 / -1.7 %, and
// at eps 1e-4 -2.0 / -2.0 / -2.2 % (off: -2.5 / -2.5 / -2.8 %), so the
// linear basis's clustered classroom does not converge to the Monte Carlo
// power as eps falls (papers/README.md, "The receiver check by default").
TEST(BasisRooms, ClassroomLinearBasisConvergesToTheMonteCarloPower) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes not present";
    const auto path = *dir / "renderpark-mgf" / "salon" / "classroom.mgf";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
    scene::Scene s = scene::loadScene(path.string());
    transport::Visibility vis(s);
    Params p;
    p.set("hr.oracle", std::string("bfa"));
    p.set("oracle.eps", 1e-3);
    p.set("cluster.model", std::string("oriented"));
    p.set("hr.max_iterations", int64_t(60));
    p.set("hr.basis", std::string("linear"));
    p.set("hr.receiver_eps", std::string("off"));
    HrSettings st = HrSettings::fromParams(p);
    p.reportUnused();
    HrResult l = HrSolver(s, vis, st).solve();
    EXPECT_TRUE(l.converged);
    const RGB pl = l.hierarchy->reflectedPower();
    const RGB mc(1114.55, 1171.15, 1100.29);  // +- (2.08, 2.13, 2.10), one standard error
    std::cout << "reflected power: linear " << pl.x << " " << pl.y << " " << pl.z
              << ", Monte Carlo " << mc.x << " " << mc.y << " " << mc.z << "\n";
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(pl[k] / mc[k], 1.0, 0.015) << "channel " << k;
}
