// Mip-mapped texture lookups in the picture (render/texturing.h,
// render.texture_filter): the pyramid's levels are box means, a fine checker
// far from the camera shows its mean instead of noise, and a magnified
// texture is the bilinear lookup exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/params.h"
#include "render/camera.h"
#include "render/lightmap.h"
#include "render/render.h"
#include "render/texturing.h"
#include "scene/field.h"
#include "scene/texture.h"
#include "transport/visibility.h"

namespace hrad::render {
namespace {

/// An n x n checker of one-texel cells, a where i + j is even, else b.
scene::Texture checker(int n, float a, float b) {
    scene::Texture t;
    t.file = "checker";
    t.width = t.height = n;
    t.texels.resize(size_t(3 * n * n));
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) t.texels[size_t(3 * (j * n + i) + c)] = (i + j) % 2 ? b : a;
    return t;
}

TEST(TextureFilter, MipLevelsAreBoxMeansAndTheLevelFollowsTheFootprint) {
    scene::Texture t;
    t.width = t.height = 4;
    for (int k = 0; k < 16; ++k)
        for (int c = 0; c < 3; ++c) t.texels.push_back(float(k));
    MipChain mip(t);
    ASSERT_EQ(mip.numLevels(), 3u);
    ASSERT_EQ(mip.level(1).width, 2);
    // Level 1's top-left texel: the mean of texels 0, 1, 4, 5.
    EXPECT_FLOAT_EQ(mip.level(1).texels[0], 2.5f);
    EXPECT_FLOAT_EQ(mip.level(2).texels[0], 7.5f);  // the mean of all sixteen
    // A footprint of one texel or less is level 0's bilinear lookup; two
    // texels is level 1; 2^1.5 is halfway between levels 1 and 2; wider than
    // the texture is the coarsest level.
    const double s = 0.125, v = 0.875;  // texel (0, 0)'s centre
    EXPECT_DOUBLE_EQ(mip.lookup(s, v, 0.5).r, t.lookup(s, v).r);
    EXPECT_DOUBLE_EQ(mip.lookup(s, v, 1.0).r, t.lookup(s, v).r);
    EXPECT_DOUBLE_EQ(mip.lookup(s, v, 2.0).r, mip.level(1).lookup(s, v).r);
    EXPECT_NEAR(mip.lookup(s, v, std::pow(2.0, 1.5)).r,
                0.5 * (mip.level(1).lookup(s, v).r + 7.5), 1e-12);
    EXPECT_DOUBLE_EQ(mip.lookup(s, v, 1e6).r, 7.5);
    // Odd sizes round up; the missing texel wraps (repeat: column 0 again).
    scene::Texture odd;
    odd.width = 3;
    odd.height = 1;
    odd.texels = {1, 1, 1, 2, 2, 2, 6, 6, 6};
    MipChain o(odd);
    ASSERT_EQ(o.level(1).width, 2);
    EXPECT_EQ(o.level(1).height, 1);
    EXPECT_FLOAT_EQ(o.level(1).texels[0], 1.5f);
    EXPECT_FLOAT_EQ(o.level(1).texels[3], 3.5f);  // (6 + 1) / 2
}

/// A 4 x 4 ground quad (z = 0, facing +z) with a 256 x 256 one-texel checker
/// of (a, b) = (0.1, 0.7) repeated `repeats` times across, and a uniform field
/// B = rho_bar (H = 1): every pixel shows rho(x) itself.
/// With `lamp`, also an emitting 8 x 8 m quad (E = 1) at z = 3 facing down.
struct Ground {
    scene::Scene scene;
    std::unique_ptr<scene::UniformField> field;
    explicit Ground(float repeats, bool lamp = false) {
        const uint32_t m = scene.addMaterial({"ground", RGB(0.4), RGB(0.0)});
        scene.addQuad(Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(4, 4, 0), Vec3(0, 4, 0), m);
        scene.materials[m].diffuseMap.texture = scene::addTexture(scene, checker(256, 0.1f, 0.7f));
        scene.patches[0].uvs = 0;
        scene.cornerUVs.push_back({glm::vec2(0, 0), {repeats, 0}, {repeats, repeats}, {0, repeats}});
        scene::applyTextureMeans(scene);
        if (lamp) {
            const uint32_t l = scene.addMaterial({"lamp", RGB(0.0), RGB(1.0)});
            scene.addQuad(Vec3(-2, -2, 3), Vec3(-2, 6, 3), Vec3(6, 6, 3), Vec3(6, -2, 3), l);
        }
        field = std::make_unique<scene::UniformField>(scene, std::vector<uint8_t>(scene.patches.size(), 0));
        field->values()[0] = scene.patches[0].rho;
        if (lamp) field->values()[1] = scene.patches[1].emission;
    }
};

/// Mean and variance (red channel) of the pixels whose centre ray meets the ground.
struct Stats {
    double mean = 0, variance = 0;
    int n = 0;
};
/// With `ref`: also the mean absolute difference to it over the same pixels.
/// From 1 m above the ground, looking along it: a grazing footprint.
scene::Camera grazingCamera() {
    scene::Camera cam;
    cam.eye = Vec3(2, -1, 1);
    cam.target = Vec3(2, 2, 0);
    cam.up = Vec3(0, 0, 1);
    cam.fovYDegrees = 40;
    return cam;
}

Stats groundStats(const Image& img, const scene::Camera& cam, int w, int h, const Image* ref = nullptr,
                  double* meanAbs = nullptr) {
    CameraFrame frame(cam, w, h);
    double s = 0, s2 = 0, ad = 0;
    int n = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3 d = frame.direction(x + 0.5, y + 0.5);
            if (!(d.z < 0)) continue;
            const Vec3 p = cam.eye + (-cam.eye.z / d.z) * d;
            // Away from the quad's edges, where pixels straddle the border.
            if (p.x < 0.1 || p.x > 3.9 || p.y < 0.1 || p.y > 3.9) continue;
            s += img.at(x, y).r;
            s2 += img.at(x, y).r * img.at(x, y).r;
            if (ref) ad += std::fabs(img.at(x, y).r - ref->at(x, y).r);
            ++n;
        }
    if (meanAbs) *meanAbs = ad / n;
    Stats st;
    st.n = n;
    st.mean = s / n;
    st.variance = s2 / n - st.mean * st.mean;
    return st;
}

TEST(TextureFilter, FarCheckerShowsItsMeanInsteadOfNoise) {
    // 64 repeats of 256 texels over 4 m: 4096 texels a metre. The camera
    // looks along the ground from 1 m up: the nearest visible texels are
    // about 60 to a pixel, the farthest thousands (a grazing footprint).
    Ground g(64);
    transport::Visibility vis(g.scene);
    const scene::Camera cam = grazingCamera();
    RenderSettings rs;
    rs.width = rs.height = 64;
    rs.reconstruction = RenderSettings::Reconstruction::Flat;
    rs.interpolate = false;
    // A supersampled reference: bilinear at 16 x 16 stratified samples a
    // pixel, the box-filtered pixel up to its sampling noise.
    rs.textureFilter = TextureFilter::Bilinear;
    rs.spp = 256;
    const Image ref = renderField(g.scene, vis, *g.field, cam, rs);
    const Stats super = groundStats(ref, cam, 64, 64);
    rs.spp = 1;
    double errBilinear = 0, errMip = 0;
    const Stats bilinear =
        groundStats(renderField(g.scene, vis, *g.field, cam, rs), cam, 64, 64, &ref, &errBilinear);
    rs.textureFilter = TextureFilter::Mip;
    const Stats mip = groundStats(renderField(g.scene, vis, *g.field, cam, rs), cam, 64, 64, &ref, &errMip);
    std::printf("far checker (mean 0.4): bilinear mean %.5f var %.3g |ref| %.3g | mip mean %.7f var %.3g "
                "|ref| %.3g | bilinear 256 spp mean %.5f var %.3g (%d pixels)\n",
                bilinear.mean, bilinear.variance, errBilinear, mip.mean, mip.variance, errMip,
                super.mean, super.variance, mip.n);
    ASSERT_GT(mip.n, 1000);
    // Every probe filters a square over two texels wide, where every level of a one-texel
    // checker is its mean: the mip picture is 0.4 up to the float texels and
    // the patch mean's quadrature (1e-6).
    EXPECT_NEAR(mip.mean, 0.4, 1e-6);
    EXPECT_LT(mip.variance, 1e-10);
    // Unfiltered, each pixel is the bilinear checker at an unrelated phase
    // (a, b) in its texel: 0.4 + 0.3 (1 - 2a)(1 - 2b) up to sign, of variance
    // 0.09 E[(1 - 2a)^2] E[(1 - 2b)^2] = 0.09 / 9 = 0.01 for uniform phases
    // (measured 0.0097); the filtered one is far below it.
    EXPECT_GT(bilinear.variance, 0.005);
    EXPECT_LT(mip.variance, 1e-6 * bilinear.variance);
    // The supersampled reference agrees with the mip picture's mean to its
    // own noise (256 samples a pixel, ~1400 pixels: 0.3 / sqrt(256 * 1400) = 5e-4).
    EXPECT_NEAR(super.mean, mip.mean, 3e-3);
    // Per pixel, the mip picture is closer to the reference than the
    // unfiltered one by more than a factor of 10 (measured 0.0049 against 0.074).
    EXPECT_LT(errMip, 0.1 * errBilinear);
}

/// Final gather (render/final_gather.h): at the pixel's hit the texel is
/// filtered over the camera's footprint, so the far checker under a lamp
/// shows rho = 0.4, the picture with textures off (the patch mean) up to the
/// float texels (1e-6); both draw the same rays (seeded per pixel). The
/// bilinear texel differs from it by up to 0.3 / 0.4.
TEST(TextureFilter, FinalGatherFiltersTheTexelAtItsPixel) {
    Ground g(64, true);
    transport::Visibility vis(g.scene);
    const scene::Camera cam = grazingCamera();
    RenderSettings rs;
    rs.width = rs.height = 48;
    rs.reconstruction = RenderSettings::Reconstruction::FinalGather;
    rs.interpolate = false;
    rs.gather.gatherRays = 4;
    rs.gather.shadowRays = 2;
    rs.textureFilter = TextureFilter::Mip;
    const Image mip = renderField(g.scene, vis, *g.field, cam, rs);
    rs.textureFilter = TextureFilter::Bilinear;
    const Image bilinear = renderField(g.scene, vis, *g.field, cam, rs);
    rs.textures = rs.gather.textures = false;
    const Image plain = renderField(g.scene, vis, *g.field, cam, rs);
    CameraFrame frame(cam, rs.width, rs.height);
    double worstBilinear = 0;
    int n = 0;
    for (int y = 0; y < rs.height; ++y)
        for (int x = 0; x < rs.width; ++x) {
            const Vec3 d = frame.direction(x + 0.5, y + 0.5);
            if (!(d.z < 0)) continue;
            const Vec3 p = cam.eye + (-cam.eye.z / d.z) * d;
            if (p.x < 0.1 || p.x > 3.9 || p.y < 0.1 || p.y > 3.9) continue;
            const double want = plain.at(x, y).r;
            ASSERT_GT(want, 0.0);
            ASSERT_NEAR(mip.at(x, y).r, want, 1e-6 * want) << x << "," << y;
            worstBilinear = std::max(worstBilinear, std::fabs(bilinear.at(x, y).r - want) / want);
            ++n;
        }
    EXPECT_GT(n, 500);
    EXPECT_GT(worstBilinear, 0.3);
}

/// Lightmap texels (render/lightmap.h): each is filtered over its own
/// footprint, 273 texels of the checker to an atlas texel here: every texel
/// of the ground's chart is B = rho_bar (H = 1) up to the float texels; the
/// bilinear texel at the atlas texel's centre is off by up to 0.3 / 0.4.
TEST(TextureFilter, LightmapTexelsAreFilteredOverTheirFootprint) {
    Ground g(64);
    LightmapSettings ls;
    ls.size = 128;
    // 60 atlas texels over 4 m, 4096 / 15 = 273.07 checker texels each: the
    // atlas texels' centres fall at unrelated phases of the checker.
    ls.density = 15;
    ls.filter = TextureFilter::Mip;
    const Lightmap mip = bakeLightmap(*g.field, ls, nullptr);
    ls.filter = TextureFilter::Bilinear;
    const Lightmap bilinear = bakeLightmap(*g.field, ls, nullptr);
    const double rhoBar = g.scene.patches[0].rho.r;
    const Lightmap::Chart& c = mip.charts[0];
    ASSERT_EQ(c.w, 60);
    double worstBilinear = 0;
    for (int j = 0; j < c.h; ++j)
        for (int i = 0; i < c.w; ++i) {
            ASSERT_NEAR(mip.atlas.at(c.x + i, c.y + j).r, rhoBar, 1e-6) << i << "," << j;
            worstBilinear = std::max(worstBilinear, std::fabs(bilinear.atlas.at(c.x + i, c.y + j).r - rhoBar) / rhoBar);
        }
    EXPECT_GT(worstBilinear, 0.3);
}

TEST(TextureFilter, MagnifiedTextureIsTheBilinearLookup) {
    // One repeat of 256 texels over 4 m, seen from 0.3 m: a texel spans
    // several pixels, the footprint is under one texel, the level is 0.
    Ground g(1);
    transport::Visibility vis(g.scene);
    scene::Camera cam;
    cam.eye = Vec3(2, 2, 0.3);
    cam.target = Vec3(2, 2.3, 0);
    cam.up = Vec3(0, 0, 1);
    cam.fovYDegrees = 30;
    RenderSettings rs;
    rs.width = rs.height = 48;
    rs.reconstruction = RenderSettings::Reconstruction::Flat;
    rs.interpolate = false;
    rs.textureFilter = TextureFilter::Bilinear;
    const Image a = renderField(g.scene, vis, *g.field, cam, rs);
    rs.textureFilter = TextureFilter::Mip;
    const Image b = renderField(g.scene, vis, *g.field, cam, rs);
    int lit = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) {
        EXPECT_EQ(a.pixels[i].r, b.pixels[i].r) << i;
        lit += a.pixels[i].r > 0;
    }
    EXPECT_GT(lit, 48 * 40);
}

TEST(TextureFilter, SettingIsReadAndMipByDefault) {
    Params p;
    EXPECT_EQ(RenderSettings::fromParams(p).textureFilter, TextureFilter::Mip);
    Params q;
    q.set("render.texture_filter", std::string("bilinear"));
    const RenderSettings rs = RenderSettings::fromParams(q);
    EXPECT_EQ(rs.textureFilter, TextureFilter::Bilinear);
    EXPECT_NE(rs.describe().find("texture_filter=bilinear"), std::string::npos);
}

}  // namespace
}  // namespace hrad::render
