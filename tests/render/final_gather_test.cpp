// Final gather and the path-traced reference image (render/final_gather.h).
#include "render/final_gather.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "reference/fullmatrix.h"
#include "render/render.h"
#include "scene/loader.h"

namespace hrad::render {
namespace {

/// Mean absolute luminance difference per pixel.
double meanAbsError(const Image& a, const Image& b) {
    double s = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) s += std::fabs(luminance(a.pixels[i] - b.pixels[i]));
    return s / double(a.pixels.size());
}

RenderSettings settingsFor(RenderSettings::Reconstruction r, int spp) {
    RenderSettings s;
    s.width = 48;
    s.height = 48;
    s.spp = spp;
    s.reconstruction = r;
    s.interpolate = r == RenderSettings::Reconstruction::Interpolated;
    return s;
}

TEST(FinalGather, CornellCoarseSolveIsCloserToThePathTracedImageThanFlatAndInterpolated) {
    scene::Scene sc = scene::loadScene("cornell");
    transport::Visibility vis(sc);
    reference::FullMatrixSettings fm;
    fm.level = 1;  // coarse: 4 elements per patch
    reference::FullMatrixResult coarse = reference::solveFullMatrix(sc, vis, fm, false);
    scene::Camera cam = chooseCamera(sc, vis, RenderSettings{});
    using R = RenderSettings::Reconstruction;
    RenderSettings mc = settingsFor(R::PathTraced, 256);
    mc.gather.seed = 7;
    Image ref = renderField(sc, vis, *coarse.field, cam, mc);
    Image flat = renderField(sc, vis, *coarse.field, cam, settingsFor(R::Flat, 4));
    Image interp = renderField(sc, vis, *coarse.field, cam, settingsFor(R::Interpolated, 4));
    RenderSettings fg = settingsFor(R::FinalGather, 4);
    fg.gather.gatherRays = 64;
    Image gathered = renderField(sc, vis, *coarse.field, cam, fg);
    double eFlat = meanAbsError(flat, ref), eInterp = meanAbsError(interp, ref),
           eFg = meanAbsError(gathered, ref);
    RecordProperty("mae_flat", std::to_string(eFlat));
    RecordProperty("mae_interpolated", std::to_string(eInterp));
    RecordProperty("mae_final_gather", std::to_string(eFg));
    EXPECT_LT(eFg, eFlat) << eFg << " " << eFlat << " " << eInterp;
    EXPECT_LT(eFg, eInterp) << eFg << " " << eFlat << " " << eInterp;
}

TEST(FinalGather, DeterministicPerSeed) {
    scene::Scene sc = scene::loadScene("cornell");
    transport::Visibility vis(sc);
    reference::FullMatrixSettings fm;
    fm.level = 0;
    reference::FullMatrixResult coarse = reference::solveFullMatrix(sc, vis, fm, false);
    scene::Camera cam = chooseCamera(sc, vis, RenderSettings{});
    RenderSettings s = settingsFor(RenderSettings::Reconstruction::FinalGather, 1);
    s.width = s.height = 24;
    s.gather.gatherRays = 16;
    Image a = renderField(sc, vis, *coarse.field, cam, s);
    Image b = renderField(sc, vis, *coarse.field, cam, s);
    EXPECT_EQ(meanAbsError(a, b), 0.0);
    s.gather.seed = 1;
    Image c = renderField(sc, vis, *coarse.field, cam, s);
    EXPECT_GT(meanAbsError(a, c), 0.0);
}

TEST(FinalGather, PathTracedFurnaceIsEOverOneMinusRho) {
    // Closed furnace, E = 1, rho = 0.5 everywhere: every pixel's expectation
    // is B = 2. 48 x 48 pixels x 64 paths: the image mean has a standard
    // error far below the 2 % allowed.
    scene::Scene sc = scene::loadScene("furnace");
    transport::Visibility vis(sc);
    reference::FullMatrixSettings fm;
    fm.level = 0;
    reference::FullMatrixResult sol = reference::solveFullMatrix(sc, vis, fm, false);
    scene::Camera cam = chooseCamera(sc, vis, RenderSettings{});
    Image img = renderField(sc, vis, *sol.field, cam,
                            settingsFor(RenderSettings::Reconstruction::PathTraced, 64));
    double mean = 0;
    int lit = 0;
    for (const RGB& p : img.pixels)
        if (p.r > 0) {
            mean += p.r;
            ++lit;
        }
    ASSERT_GT(lit, 0);
    EXPECT_NEAR(mean / lit, 2.0, 0.04);
}

TEST(FinalGather, SettingsFromParams) {
    Params p;
    p.set("render.reconstruction", std::string("final-gather"));
    p.set("render.gather_rays", int64_t(100));
    p.set("render.seed", int64_t(3));
    RenderSettings s = RenderSettings::fromParams(p);
    EXPECT_EQ(s.reconstruction, RenderSettings::Reconstruction::FinalGather);
    EXPECT_EQ(s.gather.gatherRays, 100);
    EXPECT_EQ(s.gather.seed, 3u);
    EXPECT_NE(s.describe().find("final-gather"), std::string::npos);
    Params clash;
    clash.set("render.interpolate", true);
    clash.set("render.reconstruction", std::string("final-gather"));
    EXPECT_THROW(RenderSettings::fromParams(clash), InputError);
    Params bad;
    bad.set("render.reconstruction", std::string("photon-map"));
    EXPECT_THROW(RenderSettings::fromParams(bad), InputError);
}

}  // namespace
}  // namespace hrad::render
