// Error metrics: exact region averages and the L1/L2/Linf definitions.
#include "reference/metrics.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "tests/reference/box_scenes.h"

namespace hrad::reference {
namespace {

scene::Scene unitSquare() {
    scene::Scene s;
    uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(1.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), m);
    return s;
}

TEST(Metrics, FieldAgainstItselfIsZero) {
    scene::Scene s = test::furnaceBox();
    scene::UniformField f(s, scene::uniformLevels(s, 2, 0));
    for (size_t i = 0; i < f.numElements(); ++i)
        f.value(i) = RGB(0.1 * double(i % 7) + 0.5, 1.0, double(i));
    ErrorMetrics e = computeError(f, f);
    EXPECT_EQ(e.l1Lum, 0);
    EXPECT_EQ(e.l2Lum, 0);
    EXPECT_EQ(e.linfLum, 0);
    EXPECT_EQ(e.l1Rgb, 0);
    EXPECT_EQ(e.l2Rgb, 0);
    EXPECT_EQ(e.linfRgb, 0);
    EXPECT_EQ(e.regions, f.numElements());
    EXPECT_NEAR(e.refArea, 6.0, 1e-12);
}

TEST(Metrics, ScaledFieldGivesTenPercentInEveryNorm) {
    scene::Scene s = test::blockerBox();
    scene::UniformField ref(s, scene::uniformLevels(s, 2, 0));
    scene::UniformField sol(s, scene::uniformLevels(s, 3, 0));  // finer solution
    for (size_t i = 0; i < ref.numElements(); ++i)
        ref.value(i) = RGB(1.0 + double(i % 5), 2.0, 0.5 + double(i % 3));
    // Each fine element copies its parent reference value times 1.1, so its
    // exact average over a reference region is 1.1 R_k.
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        for (size_t l = 0; l < sol.count(p); ++l)
            sol.value(sol.offset(p) + l) = 1.1 * ref.average(p, scene::parentKey(sol.key(p, l)));
    ErrorMetrics e = computeError(sol, ref);
    for (double v : {e.l1Lum, e.l2Lum, e.linfLum, e.l1Rgb, e.l2Rgb, e.linfRgb})
        EXPECT_NEAR(v, 0.1, 1e-12);
}

TEST(Metrics, CoarseSolutionAgainstFineReferenceHandComputed) {
    // One unit square. Reference at level 1: grey values 1, 2, 3, 4 on the
    // four quarters (area 1/4 each); solution: level 0 with 2.5.
    // |S-R| = 1.5, 0.5, 0.5, 1.5:
    //   L1 = (1.5+0.5+0.5+1.5)/(1+2+3+4) = 0.4
    //   L2 = sqrt(2.25+0.25+0.25+2.25)/sqrt(1+4+9+16) = sqrt(5/30)
    //   Linf = 1.5/4
    // Grey: luminance = value (the Rec.709 weights sum to 1) and the RGB norm
    // is sqrt(3) value, so the RGB ratios are the same.
    scene::Scene s = unitSquare();
    scene::UniformField ref(s, {1});
    for (int i = 0; i < 4; ++i) ref.value(size_t(i)) = RGB(double(i + 1));
    scene::UniformField sol(s, {0});
    sol.value(0) = RGB(2.5);
    ErrorMetrics e = computeError(sol, ref);
    EXPECT_NEAR(e.l1Lum, 0.4, 1e-12);
    EXPECT_NEAR(e.l2Lum, std::sqrt(5.0 / 30.0), 1e-12);
    EXPECT_NEAR(e.linfLum, 0.375, 1e-12);
    EXPECT_NEAR(e.l1Rgb, 0.4, 1e-12);
    EXPECT_NEAR(e.l2Rgb, std::sqrt(5.0 / 30.0), 1e-12);
    EXPECT_NEAR(e.linfRgb, 0.375, 1e-12);
    EXPECT_EQ(e.regions, 4u);
    EXPECT_NEAR(e.refArea, 1.0, 1e-15);

    // The other way round: a finer solution is averaged exactly over a
    // coarser reference region (mean of 1..4 = 2.5): zero error.
    ErrorMetrics back = computeError(ref, sol);
    EXPECT_NEAR(back.l1Lum, 0.0, 1e-15);
    EXPECT_NEAR(back.linfRgb, 0.0, 1e-15);
}

TEST(Metrics, ColourErrorDiffersFromLuminanceError) {
    // A pure hue shift at constant luminance: zero luminance error, non-zero RGB error.
    scene::Scene s = unitSquare();
    scene::UniformField ref(s, {0}), sol(s, {0});
    ref.value(0) = RGB(1.0, 1.0, 1.0);
    double g = (1.0 - 0.2126 * 1.1 - 0.0722 * 1.0) / 0.7152;  // luminance stays 1
    sol.value(0) = RGB(1.1, g, 1.0);
    ErrorMetrics e = computeError(sol, ref);
    EXPECT_NEAR(e.l1Lum, 0.0, 1e-12);
    double d = glm::length(sol.value(0) - ref.value(0)) / std::sqrt(3.0);
    EXPECT_NEAR(e.l1Rgb, d, 1e-12);
    EXPECT_NEAR(e.linfRgb, d, 1e-12);
}

TEST(Metrics, RegionsAreAreaWeighted) {
    // Two patches of areas 1 and 3, reference 1 on both, solution 2 on the
    // small one: L1 = 1*1 / (1*1 + 3*1) = 0.25 (0.5 if unweighted),
    // L2 = sqrt(1) / sqrt(4) = 0.5, Linf = 1.
    scene::Scene s;
    uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(1.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), m);
    s.addQuad(Vec3(2, 0, 0), Vec3(5, 0, 0), Vec3(5, 1, 0), Vec3(2, 1, 0), m);
    scene::UniformField ref(s, {0, 0}), sol(s, {0, 0});
    ref.value(0) = ref.value(1) = RGB(1.0);
    sol.value(0) = RGB(2.0);
    sol.value(1) = RGB(1.0);
    ErrorMetrics e = computeError(sol, ref);
    EXPECT_NEAR(e.l1Lum, 0.25, 1e-12);
    EXPECT_NEAR(e.l2Lum, 0.5, 1e-12);
    EXPECT_NEAR(e.linfLum, 1.0, 1e-12);
    EXPECT_NEAR(e.refArea, 4.0, 1e-12);
}

TEST(Metrics, ReflectedPowerOnRegionsTheReferenceHasDark) {
    // Unit square, E = 1. Reference at level 1: 1, 1, 3, 5 (two quarters
    // without reflected light, R = E); solution level 0 with 2.5: each quarter
    // holds A (S - E) = 0.25 * 1.5 of reflected power, half of it on the two
    // dark quarters.
    scene::Scene s = unitSquare();
    scene::UniformField ref(s, scene::uniformLevels(s, 1, 0));
    const double r[4] = {1, 1, 3, 5};
    for (size_t i = 0; i < 4; ++i) ref.value(i) = RGB(r[i]);
    scene::UniformField sol(s, scene::uniformLevels(s, 0, 0));
    sol.value(0) = RGB(2.5);
    ErrorMetrics e = computeError(sol, ref);
    EXPECT_EQ(e.darkRegions, 2u);
    EXPECT_NEAR(e.darkReflectedFraction, 0.5, 1e-12);
    // A reference value only close to E is not dark.
    ref.value(0) = RGB(1.0 + 1e-9);
    EXPECT_EQ(computeError(sol, ref).darkRegions, 1u);
}

TEST(Metrics, ReflectedPowerByMaterial) {
    // Two materials: "a" on a unit square (E = 0), "b" on a 1 x 3 rectangle
    // (E = 1). Solution 2 and 3, reference 2 and 4: material a holds 2 in
    // both; material b 3 * (3 - 1) = 6 against 3 * (4 - 1) = 9, so it comes
    // first (largest difference).
    scene::Scene s;
    uint32_t a = s.addMaterial({"a", RGB(0.5), RGB(0.0)});
    uint32_t b = s.addMaterial({"b", RGB(0.5), RGB(1.0)});
    s.addMaterial({"unused", RGB(0.5), RGB(0.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), a);
    s.addQuad(Vec3(2, 0, 0), Vec3(5, 0, 0), Vec3(5, 1, 0), Vec3(2, 1, 0), b);
    scene::UniformField ref(s, {0, 0}), sol(s, {0, 0});
    sol.value(0) = RGB(2.0);
    sol.value(1) = RGB(3.0);
    ref.value(0) = RGB(2.0);
    ref.value(1) = RGB(4.0);
    ErrorMetrics e = computeError(sol, ref);
    ASSERT_EQ(e.byMaterial.size(), 2u);  // the unused material has no area
    EXPECT_EQ(e.byMaterial[0].material, b);
    EXPECT_NEAR(e.byMaterial[0].area, 3.0, 1e-12);
    EXPECT_NEAR(e.byMaterial[0].solution, 6.0, 1e-12);
    EXPECT_NEAR(e.byMaterial[0].reference, 9.0, 1e-12);
    EXPECT_EQ(e.byMaterial[1].material, a);
    EXPECT_NEAR(e.byMaterial[1].solution, 2.0, 1e-12);
    EXPECT_NEAR(e.byMaterial[1].reference, 2.0, 1e-12);
}

TEST(Metrics, MismatchedScenesThrow) {
    scene::Scene a = unitSquare(), b = test::furnaceBox();
    scene::UniformField fa(a, {0}), fb(b, scene::uniformLevels(b, 0, 0));
    EXPECT_THROW(computeError(fa, fb), Error);
}

}  // namespace
}  // namespace hrad::reference
