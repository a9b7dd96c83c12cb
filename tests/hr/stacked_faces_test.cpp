// Stacked coplanar faces (scene/coplanar.h): a closed box standing on a table
// whose top lies in the plane of the box's floor. Inside the box the floor
// and the table under it occupy the same points; counted both, the form
// factors of the box's walls summed to more than one and the iteration
// created light (graz.mgf diverged this way). With the front face decided
// once, the box is a furnace again: B = E / (1 - rho) exactly, in the
// hierarchical solve, the full matrix and Monte Carlo, and the table (seen
// only through the box's opaque walls) stays dark.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/montecarlo.h"
#include "scene/coplanar.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"
#include "transport/visibility.h"

namespace hrad {
namespace {

constexpr double kRho = 0.9, kE = 1.0, kExact = kE / (1.0 - kRho);

scene::Scene boxOnTable() {
    scene::Scene s;
    s.name = "box-on-table";
    uint32_t box = s.addMaterial({"box", RGB(kRho), RGB(kE)});
    uint32_t table = s.addMaterial({"table", RGB(kRho), RGB(0.0)});
    test::addBox(s, Vec3(0), Vec3(1), {box, box, box, box, box, box}, true);
    test::addQuadFacing(s, Vec3(-0.5, -0.5, 0), Vec3(1.5, -0.5, 0), Vec3(1.5, 1.5, 0), Vec3(-0.5, 1.5, 0),
                        table, Vec3(0.5, 0.5, 1));
    s.applyMaterials();
    return s;
}

RGB patchAverage(const scene::RadiosityField& f, uint32_t p) { return f.average(p, scene::kRootKey); }

TEST(StackedFaces, TheBoxFloorHidesTheTableUnderIt) {
    scene::Scene s = boxOnTable();
    scene::CoplanarOverlaps ov(s);
    ASSERT_EQ(ov.numPairs(), 1u);
    transport::Visibility vis(s);
    // From the box's ceiling straight down: the floor (patch 4), not the table.
    transport::RayHit h = vis.intersect(Vec3(0.3, 0.6, 0.999), Vec3(0, 0, -1));
    ASSERT_TRUE(h.hit);
    EXPECT_EQ(h.patch, 4u);
    // Segments to a point of the table under the floor are blocked, to the
    // floor itself are not.
    transport::Segment toTable{Vec3(0.3, 0.6, 0.999), Vec3(0.3, 0.6, 0.0), 5, 6};
    transport::Segment toFloor{Vec3(0.3, 0.6, 0.999), Vec3(0.3, 0.6, 0.0), 5, 4};
    EXPECT_TRUE(vis.occluded(toTable));
    EXPECT_FALSE(vis.occluded(toFloor));
}

TEST(StackedFaces, BoxOnATableIsAFurnaceForEverySolver) {
    scene::Scene s = boxOnTable();
    transport::Visibility vis(s);
    auto check = [&](const scene::RadiosityField& f, double tol, const char* what) {
        for (uint32_t p = 0; p < 6; ++p)
            EXPECT_NEAR(patchAverage(f, p).r, kExact, tol * kExact) << what << " wall " << p;
        EXPECT_LT(patchAverage(f, 6).r, 1e-6) << what << " table";
    };
    {
        hr::HrSolver solver(s, vis, test::hrSettings("error", 1e-3));
        hr::HrResult r = solver.solve();
        ASSERT_TRUE(r.converged);
        check(*r.field, 2e-3, "hr error");
    }
    {
        hr::HrSolver solver(s, vis, test::hrSettings("uniform", 0));
        hr::HrResult r = solver.solve();
        ASSERT_TRUE(r.converged);
        check(*r.field, 1e-2, "hr uniform level 2");
    }
    {
        reference::FullMatrixSettings fm;
        fm.level = 2;
        auto m = reference::computeFormFactorMatrix(s, vis, fm, false);
        auto r = reference::solveFormFactorMatrix(s, m, fm);
        ASSERT_TRUE(r.stats.converged);
        check(*r.field, 1e-2, "full matrix level 2");
    }
    {
        reference::MonteCarloSettings mc;
        mc.samples = 1024;
        reference::MonteCarloResult r = reference::solveMonteCarlo(s, vis, mc, false);
        for (uint32_t p = 0; p < 6; ++p) {
            double se = r.stdError[r.field->offset(p)].r;
            EXPECT_GT(se, 0.0);
            EXPECT_NEAR(patchAverage(*r.field, p).r, kExact, 4 * se) << "monte carlo wall " << p;
        }
        EXPECT_EQ(patchAverage(*r.field, 6).r, 0.0) << "monte carlo table";
    }
}

// The two sides of a sheet in a lit room: a panel's -y side is one face, and
// its +y side is only a label, a smaller face of opposite normal in the same
// plane (graz.mgf's binder spines). Both sides see the lamp. The label's
// light must not depend on which end a ray starts from or on which face
// Embree meets first at equal depth: the hierarchical solve and Monte Carlo
// agree on both faces, and both are lit.
TEST(StackedFaces, BothSidesOfASheetAreLitAlikeByEverySolver) {
    scene::Scene s;
    s.name = "sheet";
    uint32_t wall = s.addMaterial({"wall", RGB(0.5), RGB(0.0)});
    uint32_t lamp = s.addMaterial({"lamp", RGB(0.0), RGB(5.0)});
    test::addBox(s, Vec3(0), Vec3(4, 3, 2.5), {wall, wall, wall, wall, wall, wall}, true);
    test::addQuadFacing(s, Vec3(1.5, 1, 2.49), Vec3(2.5, 1, 2.49), Vec3(2.5, 2, 2.49),
                        Vec3(1.5, 2, 2.49), lamp, Vec3(2, 1.5, 0));
    test::addQuadFacing(s, Vec3(1.5, 1.5, 0.5), Vec3(2.5, 1.5, 0.5), Vec3(2.5, 1.5, 1.5),
                        Vec3(1.5, 1.5, 1.5), wall, Vec3(2, 0, 1));
    const uint32_t panel = uint32_t(s.patches.size() - 1);
    test::addQuadFacing(s, Vec3(1.8, 1.5, 0.7), Vec3(2.2, 1.5, 0.7), Vec3(2.2, 1.5, 1.3),
                        Vec3(1.8, 1.5, 1.3), wall, Vec3(2, 3, 1));
    const uint32_t label = uint32_t(s.patches.size() - 1);
    s.applyMaterials();
    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, test::hrSettings("bfa", 1e-4));
    hr::HrResult h = solver.solve();
    ASSERT_TRUE(h.converged);
    reference::MonteCarloSettings mc;
    mc.samples = 4096;
    reference::MonteCarloResult r = reference::solveMonteCarlo(s, vis, mc, false);
    for (uint32_t p : {panel, label}) {
        const double ref = patchAverage(*r.field, p).r, se = r.stdError[r.field->offset(p)].r;
        const double got = patchAverage(*h.field, p).r;
        std::cout << "patch " << p << ": hierarchical " << got << ", monte carlo " << ref << " +- "
                  << se << "\n";
        EXPECT_GT(ref, 0.03);  // lit: about 0.075 on both sides
        EXPECT_NEAR(got, ref, 0.02 * ref + 4.0 * se) << "patch " << p;
    }
}

}  // namespace
}  // namespace hrad
