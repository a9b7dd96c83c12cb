// Pictures of solves whose textured leaves carry their own reflectance
// (hr.texture_rho = element; render/texturing.h LeafReflectance): the
// picture divides each leaf's B - E by the rho the solve gave it and
// smooths the irradiance H, so a floor half black and half 0.8 shows, on its
// bright half, the picture of a plain 0.8 floor and, on its black half,
// black; where every leaf's rho is the patch mean, the picture is the patch
// solve's. The old picture (B - E) rho(x) / rho_patch showed the bright half
// 0.8 / 0.4 = 2 times too bright.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>

#include "hr/solver.h"
#include "reference/cache.h"
#include "render/camera.h"
#include "render/render.h"
#include "render/texturing.h"
#include "scene/texture.h"
#include "tests/scenes.h"
#include "tests/test_util.h"
#include "transport/visibility.h"

namespace hrad::render {
namespace {

/// A 256 x 256 checker of single texels 0.2 / 0.6: every element down to
/// 2 x 2 texels has the patch mean.
scene::Texture fineChecker() {
    scene::Texture t;
    t.file = "checker";
    t.width = t.height = 256;
    for (int j = 0; j < 256; ++j)
        for (int i = 0; i < 256; ++i)
            for (int c = 0; c < 3; ++c) t.texels.push_back((i + j) % 2 ? 0.6f : 0.2f);
    return t;
}

/// The uniform oracle at level 3 (the same links whatever rho is).
hr::HrResult solve(const scene::Scene& s, const transport::Visibility& vis, bool elementRho) {
    Params p;
    p.set("hr.oracle", std::string("uniform"));
    p.set("oracle.level", int64_t(3));
    p.set("hr.tolerance", 1e-9);
    p.set("hr.max_iterations", int64_t(400));
    p.set("cluster.model", std::string("none"));
    p.set("hr.texture_rho", std::string(elementRho ? "element" : "patch"));
    hr::HrSettings settings = hr::HrSettings::fromParams(p);
    p.reportUnused();
    hr::HrResult r = hr::HrSolver(s, vis, settings).solve();
    EXPECT_TRUE(r.converged);
    // As experiments/solvers.cpp does for hr.texture_rho = element.
    r.field->setLeafTextureRho(r.hierarchy->elementRhoBytes() > 0);
    return r;
}

scene::Camera downOnTheFloor() {
    scene::Camera cam;
    cam.eye = Vec3(0.5, 0.5, 0.6);
    cam.target = Vec3(0.5, 0.5, 0.0);
    cam.up = Vec3(0, 1, 0);
    cam.fovYDegrees = 80.0;
    return cam;
}

RenderSettings settingsFor(RenderSettings::Reconstruction rec, TextureFilter filter) {
    RenderSettings rs;
    rs.width = rs.height = 40;
    rs.reconstruction = rec;
    rs.interpolate = rec == RenderSettings::Reconstruction::Interpolated;
    rs.textureFilter = filter;
    return rs;
}

/// Where pixel (x, y)'s centre ray meets the floor (z = 0): its (u, v).
Vec2 floorHit(const scene::Camera& cam, const RenderSettings& rs, int x, int y) {
    const Vec3 d = CameraFrame(cam, rs.width, rs.height).direction(x + 0.5, y + 0.5);
    const Vec3 hit = cam.eye + (-cam.eye.z / d.z) * d;
    return {hit.x, hit.y};
}

constexpr RenderSettings::Reconstruction kRecs[] = {RenderSettings::Reconstruction::Flat,
                                                   RenderSettings::Reconstruction::Interpolated,
                                                   RenderSettings::Reconstruction::Lightmap};

TEST(TextureRhoRender, HalfBlackFloorShowsEachLeafsIrradiance) {
    const scene::Scene half = test::floorUnderLamp(test::halfBlackTexture(0.8f));
    // The texels are floats: the plain floor's rho is the float 0.8f.
    const scene::Scene plain = test::floorUnderLamp(std::nullopt, double(0.8f));
    ASSERT_NEAR(half.patches[0].rho.g, 0.4, 1e-7);
    transport::Visibility visHalf(half), visPlain(plain);
    hr::HrResult el = solve(half, visHalf, true), pl = solve(plain, visPlain, false);
    ASSERT_TRUE(el.field->leafTextureRho());
    ASSERT_FALSE(pl.field->leafTextureRho());
    const scene::Camera cam = downOnTheFloor();
    for (TextureFilter filter : {TextureFilter::Bilinear, TextureFilter::Mip})
        for (RenderSettings::Reconstruction rec : kRecs) {
            const RenderSettings rs = settingsFor(rec, filter);
            const Image got = renderField(half, visHalf, *el.field, cam, rs);
            const Image want = renderField(plain, visPlain, *pl.field, cam, rs);
            int bright = 0, black = 0;
            for (int y = 0; y < rs.height; ++y)
                for (int x = 0; x < rs.width; ++x) {
                    const Vec2 uv = floorHit(cam, rs, x, y);
                    if (uv.x < 0 || uv.x > 1 || uv.y < 0 || uv.y > 1) continue;
                    // The texture's step (1/512 wide, wider through mip and
                    // the lightmap's texels) is left out.
                    if (std::fabs(uv.x - 0.5) < 0.03) continue;
                    for (int c = 0; c < 3; ++c) {
                        if (uv.x < 0.5) {
                            // rho(x) = 0: E (0), whatever H is.
                            ASSERT_EQ(got.at(x, y)[c], 0.0) << x << "," << y;
                            continue;
                        }
                        // The same links, so the same H per leaf; smooth H at
                        // the border vertices takes the bright leaves alone,
                        // which equal their mirror images across u = 1/2
                        // (the lamp is symmetric): rounding only.
                        const double w = want.at(x, y)[c];
                        ASSERT_GT(w, 0.0);
                        ASSERT_NEAR(got.at(x, y)[c], w, 1e-9 * w)
                            << int(rec) << " " << int(filter) << " at " << x << "," << y;
                    }
                    ++(uv.x < 0.5 ? black : bright);
                }
            EXPECT_GT(bright, 300);
            EXPECT_GT(black, 300);
        }
}

TEST(TextureRhoRender, LeavesAtThePatchMeanShowThePatchPicture) {
    const scene::Scene s = test::floorUnderLamp(fineChecker());
    transport::Visibility vis(s);
    hr::HrResult el = solve(s, vis, true), pa = solve(s, vis, false);
    ASSERT_TRUE(el.field->leafTextureRho());
    const scene::Camera cam = downOnTheFloor();
    for (TextureFilter filter : {TextureFilter::Bilinear, TextureFilter::Mip})
        for (RenderSettings::Reconstruction rec : kRecs) {
            const RenderSettings rs = settingsFor(rec, filter);
            const Image a = renderField(s, vis, *el.field, cam, rs);
            const Image b = renderField(s, vis, *pa.field, cam, rs);
            double sum = 0;
            for (int y = 0; y < rs.height; ++y)
                for (int x = 0; x < rs.width; ++x)
                    for (int c = 0; c < 3; ++c) {
                        // Leaf and patch means differ by the sums' rounding.
                        const double w = b.at(x, y)[c];
                        ASSERT_NEAR(a.at(x, y)[c], w, 1e-9 * std::max(w, 1e-3)) << x << "," << y;
                        sum += w;
                    }
            EXPECT_GT(sum, 0.0);
        }
}

/// A solution file keeps the flag (version 3), so `hrad render` of a saved
/// element-mode solve draws the same picture; patch-mode files stay version 1.
TEST(TextureRhoRender, SolutionFilesKeepTheLeavesReflectance) {
    const scene::Scene half = test::floorUnderLamp(test::halfBlackTexture(0.8f));
    transport::Visibility vis(half);
    hr::HrResult el = solve(half, vis, true), pa = solve(half, vis, false);
    const test::TempDir dir = test::tempDir("texture_rho_solution");
    auto version = [](const std::filesystem::path& f) {
        std::ifstream in(f, std::ios::binary);
        char head[12];
        in.read(head, 12);
        uint32_t v = 0;
        std::memcpy(&v, head + 8, 4);
        return v;
    };
    reference::saveSolution((dir / "el.hrsol").string(), *el.field);
    reference::saveSolution((dir / "pa.hrsol").string(), *pa.field);
    EXPECT_EQ(version(dir / "el.hrsol"), 3u);
    EXPECT_EQ(version(dir / "pa.hrsol"), 1u);
    auto loaded = reference::loadSolution((dir / "el.hrsol").string(), half);
    EXPECT_TRUE(loaded->leafTextureRho());
    EXPECT_FALSE(reference::loadSolution((dir / "pa.hrsol").string(), half)->leafTextureRho());
    const scene::Camera cam = downOnTheFloor();
    for (RenderSettings::Reconstruction rec : kRecs) {
        const RenderSettings rs = settingsFor(rec, TextureFilter::Mip);
        const Image a = renderField(half, vis, *loaded, cam, rs);
        const Image b = renderField(half, vis, *el.field, cam, rs);
        for (size_t i = 0; i < a.pixels.size(); ++i)
            for (int c = 0; c < 3; ++c) ASSERT_NEAR(a.pixels[i][c], b.pixels[i][c], 1e-12) << i;
    }
}

}  // namespace
}  // namespace hrad::render
