// Environments in the random walks and the camera (issue 63 item 1): next-
// event estimation of an importance-sampled envmap with the balance
// heuristic in the Monte Carlo reference (reference/montecarlo.h), the final
// gather and the path tracer (render/final_gather.h), checked against the
// closed-form sum over the map's texels on an open upward plane; a constant
// map stays exact on cosine rays.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <vector>

#include "core/params.h"
#include "core/rng.h"
#include "reference/montecarlo.h"
#include "render/camera.h"
#include "render/error_map.h"
#include "render/final_gather.h"
#include "render/image.h"
#include "render/render.h"
#include "scene/field.h"
#include "scene/lights/light.h"
#include "tests/scene/lat_long_exr.h"
#include "tests/test_util.h"

namespace hrad {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kRho = 0.5;
constexpr int kW = 64, kH = 32;  // pi / 32 per texel both ways

using MapFn = std::function<RGB(int i, int j)>;

/// A kW x kH lat-long map as half-float OpenEXR (the values used are exact in half).
std::filesystem::path writeMap(const std::filesystem::path& file, const MapFn& f) {
    return test::writeLatLongExr(file, kW, kH, f);
}

/// Sky 0.25 above the horizon, ground 0.0625 below, and a sun of 2 x 2
/// texels (i = 10, 11; j = 6, 7: about 40 degrees up, 0.023 sr, 0.3 % of the
/// upper hemisphere) of radiance (2048, 1024, 512): 98 % of the upward
/// plane's irradiance.
RGB sunMap(int i, int j) {
    if ((i == 10 || i == 11) && (j == 6 || j == 7)) return RGB(2048, 1024, 512);
    return j < kH / 2 ? RGB(0.25) : RGB(0.0625);
}

/// Irradiance on a plane facing the map's up axis (+y) with nearest-texel
/// cells: sum L_ij (2 pi / W) (sin^2 theta_j+1 - sin^2 theta_j) / 2 over the
/// rows above the horizon (scene/lights/envmap.cpp's mapping).
RGB closedFormUp(const MapFn& f) {
    RGB E(0.0);
    for (int j = 0; j < kH / 2; ++j)
        for (int i = 0; i < kW; ++i) {
            const double s0 = std::sin(kPi * j / kH), s1 = std::sin(kPi * (j + 1) / kH);
            E += f(i, j) * (2 * kPi / kW) * 0.5 * (s1 * s1 - s0 * s0);
        }
    return E;
}

/// The open floor [-2, 2]^2 in the plane y = 0 facing +y, rho 0.5, under the map.
scene::Scene floorUnder(const std::filesystem::path& map) {
    scene::Scene s;
    scene::Material m;
    m.name = "floor";
    m.rho = RGB(kRho);
    const uint32_t f = s.addMaterial(m);
    s.addQuad(Vec3(-2, 0, 2), Vec3(2, 0, 2), Vec3(2, 0, -2), Vec3(-2, 0, -2), f);
    scene::LightSpec l;
    l.kind = "envmap";
    l.filename = map.string();
    s.lights.push_back(scene::makeLight(l));
    return s;
}

reference::MonteCarloResult monteCarlo(const scene::Scene& s, const transport::Visibility& vis,
                                       bool environmentMis, int samples) {
    reference::MonteCarloSettings ms;
    ms.level = 1;
    ms.samples = samples;
    ms.environmentMis = environmentMis;
    return reference::solveMonteCarlo(s, vis, ms, false);
}

// (a) Every region of the Monte Carlo reference lies within 4 of its own
// standard errors of rho times the closed form, with the light draws (the
// default) and with escaping cosine rays alone. At equal paths (2,000 per
// region) the light draws' standard error is far smaller: measured 0.11
// against 4.5-6.6 in the red channel of the four regions (ratio 40-58; the
// note's section "Environment maps in the random walks"); asserted 10 times
// smaller. What remains is mostly the one draw's chance (6.6 %) of landing
// off the sun, on the sky or below the horizon.
TEST(EnvironmentNee, MonteCarloMatchesTheTexelSumWithSmallerErrors) {
    auto dir = test::tempDir("env_nee_mc");
    scene::Scene s = floorUnder(writeMap(dir / "sun.exr", sunMap));
    ASSERT_TRUE(s.lights[0]->importanceSampled());
    transport::Visibility vis(s);
    const RGB exact = kRho * closedFormUp(sunMap);
    const reference::MonteCarloResult mis = monteCarlo(s, vis, true, 2000);
    const reference::MonteCarloResult cos = monteCarlo(s, vis, false, 2000);
    ASSERT_EQ(mis.field->numElements(), 4u);
    for (size_t k = 0; k < 4; ++k)
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(mis.field->value(k)[c], exact[c], 4 * mis.stdError[k][c]) << k << " " << c;
            EXPECT_NEAR(cos.field->value(k)[c], exact[c], 4 * cos.stdError[k][c]) << k << " " << c;
            EXPECT_GT(mis.stdError[k][c], 0.0);
            EXPECT_LT(10 * mis.stdError[k][c], cos.stdError[k][c])
                << "region " << k << " channel " << c << ": mis " << mis.stdError[k][c]
                << ", cosine " << cos.stdError[k][c];
        }
    // The light draws' standard error is small in absolute terms too:
    // measured 0.57 % of the value, asserted under 1 %.
    for (size_t k = 0; k < 4; ++k) EXPECT_LT(mis.stdError[k].r, 0.01 * exact.r) << k;
}

// (b) A constant map is not importance-sampled: every walk keeps cosine rays
// alone, which score pi L on each escape, so the open plane's B is rho pi L
// to rounding in the Monte Carlo reference, the final gather and the path tracer.
TEST(EnvironmentNee, ConstantMapStillGivesPiL) {
    auto dir = test::tempDir("env_nee_const");
    const double L = 0.375;
    scene::Scene s = floorUnder(writeMap(dir / "c.exr", [&](int, int) { return RGB(L); }));
    ASSERT_FALSE(s.lights[0]->importanceSampled());
    transport::Visibility vis(s);
    const double exact = kRho * kPi * L;
    const reference::MonteCarloResult mc = monteCarlo(s, vis, true, 64);
    for (size_t k = 0; k < mc.field->numElements(); ++k)
        EXPECT_NEAR(mc.field->value(k).r, exact, 1e-12 * exact);
    render::Gatherer g(s, vis, render::GatherSettings{});
    scene::UniformField zero(s, scene::uniformLevels(s, 0, 0.0, 0));
    for (int k = 0; k < 20; ++k) {
        Pcg32 a(100 + k), b(200 + k);
        const Vec3 x(0.1 * k - 1, 0, 0.3);
        EXPECT_NEAR(g.pathTraced(0, x, a).r, exact, 1e-12 * exact);
        EXPECT_NEAR(g.finalGather(zero, 0, x, b).r, exact, 1e-12 * exact);
    }
}

/// Looks straight down at the floor's middle: every pixel sees the floor.
Params downwardCamera(const std::string& reconstruction, int spp) {
    Params p;
    p.set("render.width", int64_t(16));
    p.set("render.height", int64_t(16));
    p.set("render.spp", int64_t(spp));
    p.set("render.reconstruction", reconstruction);
    p.set("render.eye", std::string("0, 3, 0"));
    p.set("render.target", std::string("0, 0, 0"));
    p.set("render.up", std::string("0, 0, -1"));
    return p;
}

/// Per channel, \int L^2 cos t dw over the upper hemisphere (closed form per
/// texel as closedFormUp): the second moment of a cosine ray's score pi L
/// is pi times it.
RGB closedFormUpSquared(const MapFn& f) { return closedFormUp([&](int i, int j) { return f(i, j) * f(i, j); }); }

// (c) The path-traced and the final-gathered images of the floor under the
// sun map: every pixel has the expectation rho E (the floor is open and the
// map at infinity), so the pixels' mean lies within 4 standard errors
// (their spread / sqrt(256)) of rho times the closed form, and every pixel
// within 5 spreads of it (256 pixels of 16 samples each; the power
// heuristic bounds each sample's score, so the tails are short). The path
// tracer's spread against what cosine rays alone would give, rho
// sqrt((pi \int L^2 cos - E^2) / 16) (62.0 in red): measured 0.55, ratio
// 113; asserted 20 times smaller. (The final gather's 64 stratified cosine
// rays have no such closed form; its spread was 0.61.)
TEST(EnvironmentNee, PathTracedAndGatheredImagesMatchTheTexelSum) {
    auto dir = test::tempDir("env_nee_image");
    scene::Scene s = floorUnder(writeMap(dir / "sun.exr", sunMap));
    transport::Visibility vis(s);
    const RGB exact = kRho * closedFormUp(sunMap);
    scene::UniformField zero(s, scene::uniformLevels(s, 0, 0.0, 0));
    for (const std::string rec : {"path-traced", "final-gather"}) {
        const Params p = downwardCamera(rec, 16);
        const render::RenderSettings rs = render::RenderSettings::fromParams(p);
        const render::Image img =
            render::renderField(s, vis, zero, render::chooseCamera(s, vis, rs), rs);
        for (int c = 0; c < 3; ++c) {
            double s1 = 0, s2 = 0;
            for (const RGB& v : img.pixels) s1 += v[c], s2 += v[c] * v[c];
            const double n = double(img.pixels.size()), mean = s1 / n;
            const double sd = std::sqrt((s2 / n - mean * mean) * n / (n - 1));
            EXPECT_GT(sd, 0.0) << rec;
            EXPECT_NEAR(mean, exact[c], 4 * sd / std::sqrt(n)) << rec << " channel " << c;
            for (const RGB& v : img.pixels) ASSERT_NEAR(v[c], exact[c], 5 * sd) << rec;
            if (rec == "path-traced") {
                const double E = exact[c] / kRho, m2 = kPi * closedFormUpSquared(sunMap)[c];
                const double cosineSd = kRho * std::sqrt((m2 - E * E) / 16);
                EXPECT_LT(20 * sd, cosineSd) << "channel " << c;
            }
        }
    }
}

// ---- the sky seen by the camera (render.background) ---------------------------

/// The floor under a constant sky of radiance L, rho `rho`, seen from above
/// its near edge looking down at its middle: the top rows of the 24 x 16
/// image miss it (the sky above the horizon).
struct SkyView {
    scene::Scene scene;
    double L;
};
SkyView constantSky(double L, double rho) {
    SkyView v;
    v.L = L;
    scene::Material m;
    m.name = "floor";
    m.rho = RGB(rho);
    const uint32_t f = v.scene.addMaterial(m);
    v.scene.addQuad(Vec3(-2, 0, 2), Vec3(2, 0, 2), Vec3(2, 0, -2), Vec3(-2, 0, -2), f);
    scene::LightSpec l;
    l.kind = "constant";
    l.value = RGB(L);
    v.scene.lights.push_back(scene::makeLight(l));
    return v;
}

render::RenderSettings skySettings(const std::string& rec, const std::string& background) {
    Params p;
    p.set("render.width", int64_t(24));
    p.set("render.height", int64_t(16));
    p.set("render.reconstruction", rec);
    p.set("render.background", background);
    p.set("render.gather_rays", int64_t(4));
    p.set("render.eye", std::string("0, 1, 3"));
    p.set("render.target", std::string("0, 0, 0"));
    return render::RenderSettings::fromParams(p);
}

// In every reconstruction a pixel whose ray hits nothing shows the sky as
// radiosity, pi L (an image holds B = pi x radiance: a white floor under
// the sky would show the same), exactly; with background = black it shows
// 0; the pixels on the floor are the same bit for bit either way.
TEST(EnvironmentBackground, MissedPixelsShowTheSkyInEveryReconstruction) {
    const SkyView v = constantSky(0.75, 0.5);
    transport::Visibility vis(v.scene);
    scene::UniformField field(v.scene, scene::uniformLevels(v.scene, 2, 0.0, 2));
    for (size_t i = 0; i < field.numElements(); ++i) field.value(i) = RGB(0.5 * kPi * v.L);
    for (const std::string rec :
         {"flat", "interpolated", "final-gather", "path-traced", "lightmap"}) {
        const render::RenderSettings env = skySettings(rec, "environment"),
                                     black = skySettings(rec, "black");
        const scene::Camera cam = render::chooseCamera(v.scene, vis, env);
        const render::Image a = render::renderField(v.scene, vis, field, cam, env);
        const render::Image b = render::renderField(v.scene, vis, field, cam, black);
        ASSERT_EQ(a.surface.size(), a.pixels.size()) << rec;
        EXPECT_TRUE(b.surface.empty()) << rec;
        const render::CameraFrame frame(cam, a.width, a.height);
        int sky = 0, ground = 0;
        for (int y = 0; y < a.height; ++y)
            for (int x = 0; x < a.width; ++x) {
                const bool miss = !vis.intersect(frame.eye, frame.direction(x + 0.5, y + 0.5)).hit;
                if (miss) {
                    ++sky;
                    EXPECT_EQ(a.at(x, y), RGB(kPi * v.L)) << rec << " " << x << "," << y;
                    EXPECT_EQ(b.at(x, y), RGB(0.0)) << rec;
                    EXPECT_EQ(a.surface[size_t(y * a.width + x)], 0.0f);
                } else {
                    ++ground;
                    EXPECT_EQ(a.at(x, y), b.at(x, y)) << rec << " " << x << "," << y;
                    EXPECT_GT(a.at(x, y).r, 0.0) << rec;
                    EXPECT_EQ(a.surface[size_t(y * a.width + x)], 1.0f);
                }
            }
        EXPECT_GT(sky, 24) << rec;  // at least the top row
        EXPECT_GT(ground, 24 * 8) << rec;
    }
}

// A sky 100 times brighter than the floor (rho 0.01) would set the key and
// the clip quantile of the automatic exposure and leave the floor nearly
// black: the exposure counts surface pixels only, so it is the one of the
// image with a black background, to the bit (one sample per pixel: every
// pixel is all sky or all floor), and the sky clips. The error map of the
// image against itself with the sky changed finds no error on sky pixels.
TEST(EnvironmentBackground, AutoExposureIsSetByTheSurfacesNotTheSky) {
    const SkyView v = constantSky(4.0, 0.01);
    transport::Visibility vis(v.scene);
    scene::UniformField field(v.scene, scene::uniformLevels(v.scene, 0, 0.0, 0));
    field.value(0) = RGB(0.01 * kPi * v.L);
    const render::RenderSettings env = skySettings("flat", "environment"),
                                 black = skySettings("flat", "black");
    const scene::Camera cam = render::chooseCamera(v.scene, vis, env);
    const render::Image a = render::renderField(v.scene, vis, field, cam, env);
    const render::Image b = render::renderField(v.scene, vis, field, cam, black);
    const render::ToneMap ta = render::ToneSettings{}.choose(a), tb = render::ToneSettings{}.choose(b);
    EXPECT_EQ(ta.exposure, tb.exposure);
    EXPECT_TRUE(ta.clips(a.at(12, 0)));  // the top row is sky
    // Without the mask the sky would have set it: the clip rule maps the sky
    // (more than 1 % of the pixels) to 1, 1 / (4 pi), 18 times lower.
    const render::ToneMap unmasked = render::ToneSettings{}.choose(a.pixels);
    EXPECT_DOUBLE_EQ(unmasked.exposure, 1.0 / (kPi * v.L));
    EXPECT_LT(10 * unmasked.exposure, ta.exposure);
    render::Image c = a;
    for (size_t i = 0; i < c.pixels.size(); ++i)
        if (c.surface[i] == 0) c.pixels[i] *= 2.0;
    const render::ErrorMap m = render::computeErrorMap(c, a);
    EXPECT_EQ(m.maxAbs, 0.0);
    size_t floorPixels = 0;
    for (float f : a.surface) floorPixels += f > 0 ? 1 : 0;
    EXPECT_EQ(m.pixels, floorPixels);
}

}  // namespace
}  // namespace hrad
