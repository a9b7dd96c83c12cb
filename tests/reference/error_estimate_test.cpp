// The residual error estimate (reference/error_estimate.h): zero for an
// exact solution (furnace), the systematic darkness of a solution made dark
// on purpose, and the error of full-matrix solutions of the Cornell box
// against a Monte Carlo reference whose own noise is removed in quadrature.
#include "reference/error_estimate.h"

#include <gtest/gtest.h>

#include <cmath>

#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "reference/montecarlo.h"
#include "scene/loader.h"
#include "tests/reference/box_scenes.h"

namespace hrad::reference {
namespace {

ErrorEstimateSettings fastEstimate() {
    ErrorEstimateSettings s;
    s.samples = 400000;
    return s;
}

/// The non-emitter L2 against `ref` with the reference's noise removed.
double trueL2(const scene::RadiosityField& f, const MonteCarloResult& ref) {
    const ErrorMetrics m = computeError(f, *ref.field);
    const scene::Scene& sc = f.scene();
    double num = 0, den = 0;
    for (uint32_t p = 0; p < sc.patches.size(); ++p) {
        if (sc.patches[p].isEmitter()) continue;
        const size_t k = ref.field->offset(p);
        const double s = luminance(ref.stdError[k]), v = luminance(ref.field->value(k));
        num += sc.patches[p].area * s * s;
        den += sc.patches[p].area * v * v;
    }
    const double noise2 = num / den;
    return std::sqrt(std::max(0.0, m.l2NonEmitLum * m.l2NonEmitLum - noise2));
}

TEST(ErrorEstimate, ExactFurnaceSolutionHasNoError) {
    // Closed box, E = 1, rho = 0.5: B = 2 everywhere is the exact solution.
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    scene::UniformField f(s, std::vector<uint8_t>(s.patches.size(), 1));
    for (RGB& b : f.values()) b = RGB(2.0);
    ErrorEstimate e = estimateError(s, vis, f, fastEstimate());
    EXPECT_LT(e.l1Reflected, 2e-3);
    for (const RGB& d : e.perPatch) EXPECT_LT(std::fabs(luminance(d)), 2e-3);
    EXPECT_GT(e.rays, 0u);
}

TEST(ErrorEstimate, FurnaceSolutionTooDarkBySixthIsFound) {
    // B = 1.5 instead of 2: the residual is E + rho 1.5 - 1.5 = 0.25 and the
    // error B* - B = 0.5 = 0.25 / (1 - rho): what the propagation must find.
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    scene::UniformField f(s, std::vector<uint8_t>(s.patches.size(), 0));
    for (RGB& b : f.values()) b = RGB(1.5);
    ErrorEstimate e = estimateError(s, vis, f, fastEstimate());
    // Every patch emits here: the reflected L1 is |e| / (B* - E) = 0.5 / 1.
    EXPECT_NEAR(e.l1Reflected, 0.5, 0.01);
    for (const RGB& d : e.perPatch) EXPECT_NEAR(luminance(d), 0.5, 0.02);
}

TEST(ErrorEstimate, CornellFullMatrixErrorWithinCalibrationBand) {
    // Piecewise-constant full-matrix solutions are Galerkin solutions: their
    // residual averages to zero over each element, so only regions finer
    // than the elements see the error (header). Levels 1 and 2 are about
    // 5 % and 3 % off per patch against the reference.
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    MonteCarloSettings mc;
    mc.samples = 4096;
    MonteCarloResult ref = solveMonteCarlo(s, vis, mc, false);
    for (int level : {1, 2}) {
        FullMatrixSettings fm;
        fm.level = level;
        FullMatrixResult sol = solveFullMatrix(s, vis, fm, false);
        const double truth = trueL2(*sol.field, ref);
        ErrorEstimate e = estimateError(s, vis, *sol.field, fastEstimate());
        ASSERT_GT(truth, 0.01) << "level " << level;
        EXPECT_GT(e.l2NonEmitter / truth, 0.67) << "level " << level << " truth " << truth;
        EXPECT_LT(e.l2NonEmitter / truth, 1.5) << "level " << level << " truth " << truth;
        ErrorMetrics m = computeError(*sol.field, *ref.field);
        EXPECT_NEAR(e.meanRatio, m.meanRatioNonEmit, 0.01) << "level " << level;
        // Regions no finer than the patches see a Galerkin solution as
        // nearly exact: the reason the regions exist.
        ErrorEstimateSettings coarse = fastEstimate();
        coarse.maxLevel = level;
        EXPECT_LT(estimateError(s, vis, *sol.field, coarse).l2NonEmitter, 0.5 * e.l2NonEmitter);
    }
}

TEST(ErrorEstimate, SettingsAreReadAndChecked) {
    Params p;
    p.set("estimate.samples", int64_t(20000));
    p.set("estimate.region_samples", int64_t(8));
    ErrorEstimateSettings s = ErrorEstimateSettings::fromParams(p);
    EXPECT_EQ(s.samples, 20000u);
    EXPECT_EQ(s.regionSamples, 8);
    Params bad;
    bad.set("estimate.samples", int64_t(10));
    EXPECT_THROW(ErrorEstimateSettings::fromParams(bad), InputError);
}

}  // namespace
}  // namespace hrad::reference
