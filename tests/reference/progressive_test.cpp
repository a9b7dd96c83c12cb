// Progressive refinement with substructuring (reference/progressive.h): the
// furnace, energy bookkeeping, the ambient term, agreement with the full
// matrix on cornell, O(n) memory and settings.
#include "reference/progressive.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "scene/loader.h"
#include "tests/reference/box_scenes.h"

namespace hrad::reference {
namespace {

/// max over leaves of |B - value|_inf / value.
double worstRel(const scene::RadiosityField& f, double value) {
    double worst = 0;
    for (uint32_t p = 0; p < f.scene().patches.size(); ++p)
        f.forEachLeaf(p, [&](scene::ElementKey, const RGB& b) {
            worst = std::max(worst, maxComponent(glm::abs(b - RGB(value))) / value);
        });
    return worst;
}

TEST(Progressive, FurnaceConvergesToEOverOneMinusRho) {
    // Closed box, E = 1, rho = 0.5: B = 2 everywhere. As for the full matrix
    // (fullmatrix_test), the error is the quadrature's row-sum error, 1e-3.
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    for (int sub : {0, 1}) {
        ProgressiveSettings st;
        st.level = 1;
        st.maxSubdivision = sub;
        st.tolerance = 1e-7;
        st.ambient = false;
        ProgressiveResult r = solveProgressive(s, vis, st, false);
        ASSERT_TRUE(r.converged);
        EXPECT_LE(r.unshotFraction, 1e-7);
        EXPECT_LT(worstRel(*r.field, 2.0), 1e-3) << "max_subdivision " << sub;
    }
}

TEST(Progressive, RegatheringNewElementsRemovesTheInheritanceError) {
    // Without regathering, an element created by substructuring inherits its
    // parent's radiosity from the earlier shots (Cohen et al. 1988), which
    // is wrong where those shots varied across the parent (box corners).
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    ProgressiveSettings st;
    st.level = 1;
    st.maxSubdivision = 1;
    st.tolerance = 1e-7;
    st.ambient = false;
    st.regather = false;
    ProgressiveResult inherit = solveProgressive(s, vis, st, false);
    st.regather = true;
    ProgressiveResult regather = solveProgressive(s, vis, st, false);
    ASSERT_GT(inherit.elements, inherit.patches);  // something was subdivided
    EXPECT_GT(worstRel(*inherit.field, 2.0), 1e-2);
    EXPECT_LT(worstRel(*regather.field, 2.0), 1e-3);
    EXPECT_GT(regather.formFactors, inherit.formFactors);
}

TEST(Progressive, AmbientTermImprovesAnEarlyFurnaceImage) {
    // After a few shots most light is still unshot; the ambient term of
    // Cohen et al. 1988 accounts for it on average, so in the uniform furnace
    // it brings the display field much closer to B = 2.
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    ProgressiveSettings st;
    st.level = 1;
    st.maxSubdivision = 0;
    st.maxShots = 6;  // a quarter of the 24 patches
    st.ambient = false;
    ProgressiveResult plain = solveProgressive(s, vis, st, false);
    st.ambient = true;
    ProgressiveResult amb = solveProgressive(s, vis, st, false);
    EXPECT_FALSE(plain.converged);
    EXPECT_EQ(plain.shots, 6);
    double ePlain = worstRel(*plain.field, 2.0), eAmb = worstRel(*amb.field, 2.0);
    EXPECT_GT(ePlain, 0.3);  // 1 + a few reflections from 6 of 24 patches
    EXPECT_LT(eAmb, 0.5 * ePlain);
}

TEST(Progressive, UnshotPowerFallsMonotonicallyAndPowerBalances) {
    scene::Scene s = test::blockerBox();
    transport::Visibility vis(s);
    ProgressiveSettings st;
    st.level = 1;
    st.maxSubdivision = 2;
    st.tolerance = 1e-4;
    st.historyEvery = 1;
    st.ambient = false;
    int hookCalls = 0;
    ProgressiveResult r = solveProgressive(s, vis, st, false,
                                           [&](const scene::RadiosityField& f, ProgressiveRecord& rec) {
                                               ++hookCalls;
                                               rec.l2Lum = luminance(f.totalPower());
                                           });
    ASSERT_TRUE(r.converged);
    ASSERT_EQ(r.history.size(), size_t(r.shots) + 1);
    EXPECT_EQ(hookCalls, int(r.history.size()));
    EXPECT_DOUBLE_EQ(r.history.front().unshotFraction, 1.0);
    for (size_t k = 1; k < r.history.size(); ++k) {
        // Each shot removes A_j U_j and hands out at most rho_max sum_e F_ej of it.
        EXPECT_LT(r.history[k].unshotFraction, r.history[k - 1].unshotFraction) << k;
        EXPECT_GE(r.history[k].elements, r.history[k - 1].elements);
        EXPECT_GE(r.history[k].l2Lum, r.history[k - 1].l2Lum);  // total power only grows
        EXPECT_EQ(r.history[k].shots, int64_t(k));
    }
    // Substructuring happened (the blocker casts shadows).
    EXPECT_GT(r.elements, r.patches);
    // O(n) memory: a bounded number of bytes per element, no n^2 term.
    EXPECT_LT(double(r.bytes) / double(r.elements), 200.0);
}

TEST(Progressive, AgreesWithFullMatrixOnCornellAsShotsGoUp) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    FullMatrixSettings fm;
    fm.level = 2;
    FullMatrixResult ref = solveFullMatrix(s, vis, fm, false);
    ASSERT_TRUE(ref.stats.converged);
    // The same mesh (level 2, no substructuring) and form-factor rule: the
    // converged progressive solution is the Southwell solution of the same
    // system, up to the visibility samples (seeded by different ids).
    ProgressiveSettings st;
    st.level = 2;
    st.maxSubdivision = 0;
    st.ambient = false;
    std::vector<double> err;
    for (double tol : {3e-1, 1e-1, 1e-2, 1e-5}) {
        st.tolerance = tol;
        ProgressiveResult r = solveProgressive(s, vis, st, false);
        ASSERT_TRUE(r.converged);
        err.push_back(computeError(*r.field, *ref.field).l2Lum);
    }
    // The error falls with the unshot power until it reaches the floor set
    // by the visibility samples: 16 rays per pair at different positions
    // than the full matrix's, 5e-4 (L2 of luminance) on this mesh.
    EXPECT_LT(err[1], 0.5 * err[0]) << err[0] << " " << err[1];
    EXPECT_LT(err[2], 0.5 * err[1]) << err[2];
    EXPECT_LT(err[3], 2e-3) << err[3];
}

TEST(Progressive, SubstructuringApproachesTheFinerFullMatrix) {
    // Patches at level 1 with elements down to level 3 against the level-3
    // full matrix: substructuring resolves the receivers, so the error drops
    // below that of the unsubdivided level-1 solution.
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    FullMatrixSettings fm;
    fm.level = 3;
    FullMatrixResult ref = solveFullMatrix(s, vis, fm, false);
    ProgressiveSettings st;
    st.level = 1;
    st.tolerance = 1e-3;
    st.ambient = false;
    st.maxSubdivision = 0;
    ProgressiveResult coarse = solveProgressive(s, vis, st, false);
    st.maxSubdivision = 2;
    ProgressiveResult sub = solveProgressive(s, vis, st, false);
    double eCoarse = computeError(*coarse.field, *ref.field).l2Lum;
    double eSub = computeError(*sub.field, *ref.field).l2Lum;
    EXPECT_GT(sub.elements, coarse.elements);
    EXPECT_LT(eSub, 0.8 * eCoarse) << eSub << " vs " << eCoarse;
}

TEST(Progressive, SettingsFromParams) {
    Params p;
    p.set("pr.level", int64_t(1));
    p.set("pr.max_subdivision", int64_t(3));
    p.set("pr.subdivide_threshold", 0.2);
    p.set("pr.tolerance", 1e-4);
    p.set("pr.ambient", false);
    p.set("pr.history_every", int64_t(5));
    p.set("pr.ff.points", int64_t(4));
    ProgressiveSettings s = ProgressiveSettings::fromParams(p);
    EXPECT_EQ(s.level, 1);
    EXPECT_EQ(s.maxSubdivision, 3);
    EXPECT_EQ(s.subdivideThreshold, 0.2);
    EXPECT_EQ(s.tolerance, 1e-4);
    EXPECT_FALSE(s.ambient);
    EXPECT_EQ(s.historyEvery, 5);
    EXPECT_EQ(s.ff.points, 4);
    EXPECT_EQ(s.ff.adaptiveDepth, 3);  // the full matrix's default
    EXPECT_NO_THROW(p.reportUnused());
    EXPECT_NE(s.describe().find("max_subdivision=3"), std::string::npos);
    Params bad;
    bad.set("pr.tolerance", -1.0);
    EXPECT_THROW(ProgressiveSettings::fromParams(bad), InputError);
    Params deep;
    deep.set("pr.max_subdivision", int64_t(40));
    EXPECT_THROW(ProgressiveSettings::fromParams(deep), InputError);
    Params deepSum;  // each in range, together too deep
    deepSum.set("pr.level", int64_t(10));
    deepSum.set("pr.max_subdivision", int64_t(6));
    EXPECT_THROW(ProgressiveSettings::fromParams(deepSum), InputError);
}

}  // namespace
}  // namespace hrad::reference

namespace hrad::reference {
namespace {

TEST(Progressive, HemicubeShootingApproachesTheQuadratureOnCornell) {
    // Shooting with hemicubes on the shooter (Cohen et al. 1988) instead of
    // the element-to-patch quadrature: as the resolution grows the solution
    // approaches the quadrature's (both against the level-2 full matrix).
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    FullMatrixSettings fm;
    fm.level = 2;
    FullMatrixResult ref = solveFullMatrix(s, vis, fm, false);
    ProgressiveSettings st;
    st.level = 2;
    st.maxSubdivision = 0;
    st.ambient = false;
    st.tolerance = 1e-3;
    st.hemicube.enabled = true;
    st.hemicube.points = 1;
    std::vector<double> err;
    for (int res : {4, 16, 64}) {
        st.hemicube.res = res;
        ProgressiveResult r = solveProgressive(s, vis, st, false);
        ASSERT_TRUE(r.converged);
        err.push_back(computeError(*r.field, *ref.field).l2Lum);
    }
    for (size_t k = 0; k < err.size(); ++k) RecordProperty("l2_res_" + std::to_string(k), std::to_string(err[k]));
    EXPECT_LT(err[2], err[0]) << err[0] << " " << err[1] << " " << err[2];
    EXPECT_LT(err[2], 0.02) << err[0] << " " << err[1] << " " << err[2];
    // With substructuring the hits are binned onto the finer elements too.
    st.maxSubdivision = 1;
    st.hemicube.res = 32;
    ProgressiveResult sub = solveProgressive(s, vis, st, false);
    EXPECT_GT(sub.elements, sub.patches);
    EXPECT_LT(computeError(*sub.field, *ref.field).l2Lum, 0.05) << computeError(*sub.field, *ref.field).l2Lum;
}

}  // namespace
}  // namespace hrad::reference
