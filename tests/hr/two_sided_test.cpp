// Two-sided surfaces: a front/back patch pair per polygon (scene.h,
// Patch::twin) through the loaders, visibility, the hierarchical solver and the
// full-matrix and Monte Carlo references.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/montecarlo.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"
#include "transport/visibility.h"

using namespace hrad;

namespace {

/// An emitter (E = 1, rho = 0) at z = 2 facing down over [-1,1]^2, a plate at
/// z = 1 over [-0.5,0.5]^2 facing up (rho 0.5, two-sided when asked) and,
/// when asked, a one-sided floor at z = 0 over [-2,2]^2 facing up (rho 0.5).
/// Patch 0 emitter, 1 plate front, 2 floor, then the plate's back twin.
scene::Scene plateScene(bool twoSided, bool floor) {
    scene::Scene s;
    scene::Material lamp{"lamp", RGB(0.0), RGB(1.0)};
    scene::Material plate{"plate", RGB(0.5), RGB(0.0)};
    plate.twoSided = twoSided;
    scene::Material ground{"floor", RGB(0.5), RGB(0.0)};
    uint32_t ml = s.addMaterial(lamp), mp = s.addMaterial(plate), mf = s.addMaterial(ground);
    // Counter-clockwise seen from the side the normal points to.
    EXPECT_TRUE(s.addQuad({-1, -1, 2}, {-1, 1, 2}, {1, 1, 2}, {1, -1, 2}, ml));  // faces -z
    EXPECT_TRUE(s.addQuad({-0.5, -0.5, 1}, {0.5, -0.5, 1}, {0.5, 0.5, 1}, {-0.5, 0.5, 1}, mp));
    if (floor) {
        EXPECT_TRUE(s.addQuad({-2, -2, 0}, {2, -2, 0}, {2, 2, 0}, {-2, 2, 0}, mf));
    }
    s.addBackSides();
    s.applyMaterials();
    return s;
}

reference::FullMatrixResult fullMatrix(const scene::Scene& s, int level) {
    transport::Visibility vis(s);
    reference::FullMatrixSettings fm;
    fm.level = level;
    fm.tolerance = 1e-10;
    return reference::solveFullMatrix(s, vis, fm, false);
}

RGB patchAverage(const scene::RadiosityField& f, uint32_t patch) {
    return f.average(patch, scene::kRootKey);
}

}  // namespace

TEST(TwoSided, BackSideIsATwinWithReversedWindingAndNegatedNormal) {
    scene::Scene s = plateScene(true, false);
    ASSERT_EQ(s.patches.size(), 3u);
    const scene::Patch& front = s.patches[1];
    const scene::Patch& back = s.patches[2];
    EXPECT_EQ(front.twin, 2u);
    EXPECT_EQ(back.twin, 1u);
    EXPECT_TRUE(back.backSide);
    EXPECT_FALSE(front.backSide);
    EXPECT_EQ(s.frontOf(2), 1u);
    EXPECT_DOUBLE_EQ(back.normal.z, -1.0);
    EXPECT_DOUBLE_EQ(back.area, front.area);
    // Same polygon: the parametric centre is the same point.
    Vec3 d = back.point(0.5, 0.5) - front.point(0.5, 0.5);
    EXPECT_LT(glm::length(d), 1e-15);
    // The normal computed from the winding agrees with the stored one.
    Vec3 n = glm::normalize(glm::cross(back.v[1] - back.v[0], back.v[3] - back.v[0]));
    EXPECT_NEAR(glm::dot(n, back.normal), 1.0, 1e-12);
    EXPECT_EQ(s.addBackSides(), 0u) << "idempotent";
    EXPECT_EQ(s.numBackSides(), 1u);
}

TEST(TwoSided, IntersectReportsTheSideTheRayMeets) {
    scene::Scene s = plateScene(true, false);
    transport::Visibility vis(s);
    transport::RayHit down = vis.intersect({0.1, 0.1, 1.5}, {0, 0, -1});
    ASSERT_TRUE(down.hit);
    EXPECT_EQ(down.patch, 1u) << "from above: the front";
    transport::RayHit up = vis.intersect({0.1, 0.1, 0.5}, {0, 0, 1});
    ASSERT_TRUE(up.hit);
    EXPECT_EQ(up.patch, 2u) << "from below: the back twin";
    EXPECT_NEAR(up.t, 0.5, 1e-6);
    // A segment from the plate's back (patch 2) down to a point below is not
    // blocked by the plate's own polygon (its twin is ignored with it).
    transport::Segment seg{{0.1, 0.1, 1.0}, {0.1, 0.1, 0.0}, 2u, UINT32_MAX};
    EXPECT_FALSE(vis.occluded(seg));
    // From the lamp to below the plate: blocked, whichever side is named.
    transport::Segment through{{0.1, 0.1, 2.0}, {0.1, 0.1, 0.5}, 0u, UINT32_MAX};
    EXPECT_TRUE(vis.occluded(through));
}

TEST(TwoSided, BackSideDarkWhereNothingLightsIt) {
    // Without a floor nothing faces the plate's back: B = 0 there exactly,
    // in the full matrix and in the hierarchical solve, while the front is lit.
    scene::Scene s = plateScene(true, false);
    auto fm = fullMatrix(s, 2);
    EXPECT_GT(patchAverage(*fm.field, 1).r, 0.05);
    EXPECT_EQ(patchAverage(*fm.field, 2), RGB(0.0));

    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, test::hrSettings("bfa", 1e-4));
    hr::HrResult r = solver.solve();
    ASSERT_TRUE(r.converged);
    EXPECT_EQ(patchAverage(*r.field, 2), RGB(0.0));
    EXPECT_NEAR(patchAverage(*r.field, 1).r, patchAverage(*fm.field, 1).r,
                0.01 * patchAverage(*fm.field, 1).r);
}

TEST(TwoSided, BackSideGathersTheFloorAndFrontIsUnchanged) {
    // With the floor the back side sees only the floor (lit around the plate)
    // and reflects it back onto the floor's shadowed centre. The lamp has
    // rho = 0 and the front sees only the lamp, so the front's radiosity is
    // the same one-sided or two-sided, to the solver tolerance.
    scene::Scene one = plateScene(false, true);
    scene::Scene two = plateScene(true, true);
    ASSERT_EQ(two.patches.size(), one.patches.size() + 1);
    auto f1 = fullMatrix(one, 3);
    auto f2 = fullMatrix(two, 3);
    const double front1 = patchAverage(*f1.field, 1).r, front2 = patchAverage(*f2.field, 1).r;
    EXPECT_NEAR(front2, front1, 1e-8 * front1);
    const double back = patchAverage(*f2.field, 3).r;
    EXPECT_GT(back, 0.0);
    // The floor gains what the back side reflects.
    EXPECT_GT(patchAverage(*f2.field, 2).r, patchAverage(*f1.field, 2).r);

    // Monte Carlo on the two-sided scene agrees on the back side's average
    // within 4 standard errors plus the full matrix's discretisation (1 %).
    transport::Visibility vis(two);
    reference::MonteCarloSettings mc;
    mc.samples = 4096;
    reference::MonteCarloResult m = reference::solveMonteCarlo(two, vis, mc, false);
    const double mcBack = m.field->average(3, scene::kRootKey).r;
    const double se = m.stdError[m.field->offset(3)].r;
    EXPECT_GT(se, 0.0);
    EXPECT_NEAR(mcBack, back, 4 * se + 0.01 * back) << "mc " << mcBack << " +- " << se;

    // The hierarchical solve agrees with the full matrix on both sides.
    hr::HrSolver solver(two, vis, test::hrSettings("bfa", 1e-5));
    hr::HrResult r = solver.solve();
    ASSERT_TRUE(r.converged);
    EXPECT_NEAR(patchAverage(*r.field, 3).r, back, 0.03 * back);
    EXPECT_NEAR(patchAverage(*r.field, 1).r, front2, 0.01 * front2);
}

TEST(TwoSided, FurnaceStaysExactInsideAndOutsideIsDark) {
    // Every wall of the closed box two-sided ("two_sided = all" at load): the
    // inner sides still see a closed box (B = E / (1 - rho) = 2), the outer
    // sides see nothing and do not emit (B = 0).
    scene::Scene s = test::furnaceBox(1.0, 0.5);
    ASSERT_EQ(s.addBackSides(true), 6u);
    s.applyMaterials();
    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, test::hrSettings("uniform", 0));
    hr::HrResult r = solver.solve();
    ASSERT_TRUE(r.converged);
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        RGB b = patchAverage(*r.field, p);
        if (s.patches[p].backSide)
            EXPECT_EQ(b, RGB(0.0)) << "outer side " << p;
        else
            EXPECT_NEAR(b.r, 2.0, 2e-3) << "inner side " << p;
    }
}

TEST(TwoSided, MgfSidesTwoAndSettings) {
    namespace fs = std::filesystem;
    fs::path dir = fs::temp_directory_path() / "hrad_two_sided_test";
    fs::create_directories(dir);
    fs::path file = dir / "slab.mgf";
    {
        std::ofstream o(file);
        o << "m lamp =\n ed 100\n sides 2\n"
             "v a = \n p 0 0 2\nv b =\n p 1 0 2\nv c =\n p 1 1 2\nv d =\n p 0 1 2\n"
             "f d c b a\n"
             "m wall =\n c\n rd 0.5\n sides 2\n"
             "v e =\n p 0 0 1\nv f =\n p 1 0 1\nv g =\n p 1 1 1\nv h =\n p 0 1 1\n"
             "f e f g h\n"
             "m one =\n c\n rd 0.5\n sides 1\n"
             "v i =\n p 0 0 0\nv j =\n p 1 0 0\nv k =\n p 1 1 0\n"
             "f i j k\n"
             "m\n"
             "f i k j\n";
    }
    scene::Scene s = scene::loadScene(file.string());
    // Two two-sided quads get twins; the one-sided triangle does not, nor the
    // face of the unnamed material (no `sides`: mgf.default_sides = 1).
    EXPECT_EQ(s.patches.size(), 6u);
    EXPECT_EQ(s.numBackSides(), 2u);
    // MGF materials are alike on both faces: the lamp's back emits too.
    EXPECT_NEAR(s.emittedPower().r, 2.0 * s.patches[0].emission.r * s.patches[0].area, 1e-9);

    Params none;
    none.set("two_sided", std::string("none"));
    EXPECT_EQ(scene::loadScene(file.string(), none).patches.size(), 4u);
    Params all;
    all.set("two_sided", std::string("all"));
    EXPECT_EQ(scene::loadScene(file.string(), all).patches.size(), 8u);
    Params spec;  // the MGF specification's default: materials are two-sided
    spec.set("mgf.default_sides", int64_t(2));
    EXPECT_EQ(scene::loadScene(file.string(), spec).patches.size(), 7u);

    std::ofstream(dir / "bad.mgf") << "m x =\n rd 0.5\n sides 3\n";
    try {
        scene::loadScene((dir / "bad.mgf").string());
        ADD_FAILURE() << "sides 3 accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.mgf:3:"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}
