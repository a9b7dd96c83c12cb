// Textures in the picture (render/texturing.h): a textured quad under a known
// light shows rho(texel) x H; a textured furnace is still exact with the
// per-patch mean; the lightmap multiplies the texture in or stores H.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "reference/fullmatrix.h"
#include "render/camera.h"
#include "render/lightmap.h"
#include "render/render.h"
#include "render/texturing.h"
#include "scene/element.h"
#include "scene/texture.h"
#include "tests/gltf_validate.h"
#include "tests/scenes.h"
#include "tests/test_util.h"
#include "transport/formfactor.h"

namespace hrad::render {
namespace {

/// 2 x 2 linear texels, row 0 at the top: (0.9,0.1,0.1) (0.1,0.9,0.1) /
/// (0.1,0.1,0.9) (0.5,0.5,0.5); clamp on both axes.
scene::Texture fourColours() {
    scene::Texture t;
    t.file = "four";
    t.width = t.height = 2;
    t.texels = {0.9f, 0.1f, 0.1f, 0.1f, 0.9f, 0.1f, 0.1f, 0.1f, 0.9f, 0.5f, 0.5f, 0.5f};
    t.wrapU = t.wrapV = scene::TextureWrap::Clamp;
    return t;
}

/// The same bilinear lookup written out: clamp, texel centres at 1/4, 3/4.
RGB expectedTexel(const scene::Texture& t, double u, double v) {
    auto texel = [&](int i, int j) {
        i = std::clamp(i, 0, 1);
        j = std::clamp(j, 0, 1);
        const float* p = &t.texels[size_t(3 * (j * 2 + i))];
        return RGB(p[0], p[1], p[2]);
    };
    const double x = u * 2 - 0.5, y = (1 - v) * 2 - 0.5;
    const int i = int(std::floor(x)), j = int(std::floor(y));
    const double a = x - i, b = y - j;
    return (1 - b) * ((1 - a) * texel(i, j) + a * texel(i + 1, j)) +
           b * ((1 - a) * texel(i, j + 1) + a * texel(i + 1, j + 1));
}

/// A textured unit quad (z = 0, facing +z, UV = (x, y)) under a black
/// emitting unit square at z = 1 facing down (E = 1).
scene::Scene quadUnderLight() {
    scene::Scene s;
    s.name = "textured-quad";
    const uint32_t floor = test::addFloorUnderLamp(s);
    s.materials[floor].diffuseMap.texture = scene::addTexture(s, fourColours());
    s.patches[0].uvs = 0;
    s.cornerUVs.push_back({glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
    scene::applyTextureMeans(s);
    return s;
}

TEST(TexturedRender, QuadShowsTexelTimesIrradiance) {
    scene::Scene s = quadUnderLight();
    // Per axis, the clamped bilinear mean over [0, 1] is the mean of the two
    // texel columns, so the patch mean is the mean of the four texels.
    const RGB rhoBar(0.4, 0.4, 0.4);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(s.patches[0].rho[c], rhoBar[c], 1e-7);
    transport::Visibility vis(s);
    reference::FullMatrixSettings fm;
    fm.level = 3;
    reference::FullMatrixResult sol = reference::solveFullMatrix(s, vis, fm, false);
    // The light is black, so the floor's B is rho_bar E F per element and its
    // patch mean is rho_bar E F(floor -> lamp), F the closed form for two
    // opposed unit squares at distance 1 (0.19982). Tolerance: the full
    // matrix's quadrature, 1e-3 relative on the Cornell tests.
    const double F = transport::parallelRectangles(1, 1, 1);
    const RGB Bmean = sol.field->average(0, scene::kRootKey);
    EXPECT_NEAR(Bmean.g / rhoBar.g, F, 1e-3 * F);

    scene::Camera cam;
    cam.eye = Vec3(0.5, 0.5, 0.6);
    cam.target = Vec3(0.5, 0.5, 0.0);
    cam.up = Vec3(0, 1, 0);
    cam.fovYDegrees = 80.0;
    RenderSettings rs;
    rs.width = rs.height = 24;
    rs.interpolate = false;
    rs.reconstruction = RenderSettings::Reconstruction::Flat;
    Image img = renderField(s, vis, *sol.field, cam, rs);
    rs.textures = false;
    Image plain = renderField(s, vis, *sol.field, cam, rs);
    CameraFrame frame(cam, rs.width, rs.height);
    const scene::Texture& tex = *s.textures[0];
    int checked = 0;
    for (int y = 0; y < rs.height; ++y)
        for (int x = 0; x < rs.width; ++x) {
            // The pixel's ray meets z = 0 at (u, v) = (x, y) of the quad.
            const Vec3 d = frame.direction(x + 0.5, y + 0.5);
            const Vec3 hit = cam.eye + (-cam.eye.z / d.z) * d;
            if (hit.x < 0 || hit.x > 1 || hit.y < 0 || hit.y > 1) continue;
            const RGB H = sol.field->at(0, hit.x, hit.y) / rhoBar;  // E = 0 on the floor
            const RGB want = expectedTexel(tex, hit.x, hit.y) * H;
            // Tolerance: float texels and the ray's hit point (1e-6).
            for (int c = 0; c < 3; ++c) {
                ASSERT_NEAR(img.at(x, y)[c], want[c], 1e-6 * std::max(1.0, want[c])) << x << "," << y;
                ASSERT_NEAR(plain.at(x, y)[c], rhoBar[c] * H[c], 1e-9) << x << "," << y;
            }
            ++checked;
        }
    EXPECT_GT(checked, 24 * 24 / 2);
    // The four quadrants differ in colour: the first texel (top-left, red)
    // shows where y is large and x small.
    const Vec3 d = frame.direction(2.5, 2.5);  // top-left of the image
    const Vec3 hit = cam.eye + (-cam.eye.z / d.z) * d;
    EXPECT_LT(hit.x, 0.5);
    EXPECT_GT(hit.y, 0.5);
    EXPECT_GT(img.at(2, 2).r, 3 * img.at(2, 2).g);
}

/// The furnace box with a checker on every wall whose mean over each wall is
/// 0.4: the solve sees rho_bar = 0.4 everywhere and B = E / (1 - 0.4).
TEST(TexturedRender, FurnaceWithATextureIsStillExact) {
    scene::Scene s = test::furnaceBox(1.0, 0.4);
    scene::Texture t;
    t.file = "checker";
    t.width = t.height = 8;
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i)
            for (int c = 0; c < 3; ++c) t.texels.push_back((i + j) % 2 ? 0.7f : 0.1f);
    s.materials[0].diffuseMap.texture = scene::addTexture(s, std::move(t));
    for (scene::Patch& p : s.patches) {
        p.uvs = uint32_t(s.cornerUVs.size());
        s.cornerUVs.push_back({glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
    }
    EXPECT_EQ(scene::applyTextureMeans(s), 6u);
    for (const scene::Patch& p : s.patches) ASSERT_NEAR(p.rho.r, 0.4, 1e-7);
    scene::Scene plain = test::furnaceBox(1.0, 0.4);
    transport::Visibility vis(s), visPlain(plain);
    reference::FullMatrixSettings fm;
    fm.level = 2;
    auto tex = reference::solveFullMatrix(s, vis, fm, false);
    auto ref = reference::solveFullMatrix(plain, visPlain, fm, false);
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        const RGB a = tex.field->average(p, scene::kRootKey), b = ref.field->average(p, scene::kRootKey);
        // The same solve as the untextured furnace (rho differs by float
        // texels, 1e-7), and within the full matrix's 2e-3 of 1 / (1 - 0.4).
        EXPECT_NEAR(a.r, b.r, 1e-6);
        EXPECT_NEAR(a.r, 1.0 / 0.6, 2e-3);
    }
    // The picture inside: E + (B - E) rho(x) / rho_bar; its mean over a wall
    // is B again (the texture's mean ratio is 1).
    TextureShading shade(s);
    RGB sum(0.0);
    const int n = 64;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) sum += shade.shade(0, (i + 0.5) / n, (j + 0.5) / n, RGB(1.0 / 0.6));
    EXPECT_NEAR(sum.r / (n * n), 1.0 / 0.6, 1e-6);
}

TEST(TexturedLightmap, TexelsHoldRadiosityOrIrradiance) {
    scene::Scene s = quadUnderLight();
    transport::Visibility vis(s);
    reference::FullMatrixSettings fm;
    fm.level = 2;
    auto sol = reference::solveFullMatrix(s, vis, fm, false);
    LightmapSettings ls;
    ls.size = 64;
    Lightmap rad = bakeLightmap(*sol.field, ls, nullptr);
    ls.texels = LightmapSettings::Texels::Irradiance;
    Lightmap irr = bakeLightmap(*sol.field, ls, nullptr);
    const Lightmap::Chart& c = rad.charts[0];
    int checked = 0;
    for (int j = 0; j < c.h; ++j)
        for (int i = 0; i < c.w; ++i) {
            const double u = (i + 0.5) / c.w, v = (j + 0.5) / c.h;
            const RGB B = sol.field->at(0, u, v), H = B / s.patches[0].rho;  // rho_bar as stored
            const RGB rho = expectedTexel(*s.textures[0], u, v);
            for (int k = 0; k < 3; ++k) {
                ASSERT_NEAR(rad.atlas.at(c.x + i, c.y + j)[k], rho[k] * H[k], 1e-6);
                ASSERT_NEAR(irr.atlas.at(c.x + i, c.y + j)[k], H[k], 1e-9);
            }
            ++checked;
        }
    EXPECT_GT(checked, 16);
}

TEST(TexturedLightmap, GlbStaysValidAndTheLightmapPictureMatchesTheTexturedOne) {
    scene::Scene s = quadUnderLight();
    transport::Visibility vis(s);
    reference::FullMatrixSettings fm;
    fm.level = 2;
    auto sol = reference::solveFullMatrix(s, vis, fm, false);
    auto dir = test::tempDir("tex_lightmap");
    LightmapSettings ls;
    ls.size = 256;
    ls.texels = LightmapSettings::Texels::Irradiance;  // the glb still shows radiosity
    ToneMap tone;
    tone.exposure = 1.0;
    writeLightmapFiles(*sol.field, ls, nullptr, tone, dir.string());
    HRAD_EXPECT_VALID_GLTF((dir / "lightmap.glb").string());
    // The picture from the lightmap (the smooth field baked into a 256^2
    // atlas, one chart of about 250 texels a side) against the direct smooth
    // textured picture: they differ by the atlas's bilinear resampling of the
    // texture (linear inside its texel centres here) and of the field, well
    // under a texel: measured 3.9e-6 of the image's mean; bound 1e-4.
    scene::Camera cam;
    cam.eye = Vec3(0.5, 0.5, 0.6);
    cam.target = Vec3(0.5, 0.5, 0.0);
    cam.up = Vec3(0, 1, 0);
    cam.fovYDegrees = 80.0;
    RenderSettings rs;
    rs.width = rs.height = 32;
    rs.lightmap.size = 256;
    rs.reconstruction = RenderSettings::Reconstruction::Lightmap;
    rs.interpolate = false;
    Image fromMap = renderField(s, vis, *sol.field, cam, rs);
    rs.reconstruction = RenderSettings::Reconstruction::Interpolated;
    rs.interpolate = true;
    Image direct = renderField(s, vis, *sol.field, cam, rs);
    double diff = 0, mean = 0;
    for (size_t i = 0; i < direct.pixels.size(); ++i) {
        diff += maxComponent(glm::abs(fromMap.pixels[i] - direct.pixels[i]));
        mean += maxComponent(direct.pixels[i]);
    }
    EXPECT_GT(mean, 0);
    EXPECT_LT(diff, 1e-4 * mean) << "relative difference " << diff / mean;
    std::printf("lightmap vs direct textured picture: mean |difference| / mean = %.3g\n", diff / mean);
}

}  // namespace
}  // namespace hrad::render
