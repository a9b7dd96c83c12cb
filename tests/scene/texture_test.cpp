// Diffuse textures (scene/texture.h): lookups, per-patch means against their
// analytic values, and UVs and textures kept by the OBJ and Mitsuba loaders
// (small fixtures written into a temporary folder; glTF: gltf_loader_test).
#include <stb/stb_image_write.h>  // Debian libstb-dev; implementation in libstb

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "scene/loader.h"
#include "scene/element.h"
#include "scene/texture.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

double srgbDecode(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

/// An n x n checker of linear values a (texels with i + j even) and b.
Texture checker(int n, double a, double b) {
    Texture t;
    t.file = "checker";
    t.width = t.height = n;
    t.texels.resize(size_t(3 * n * n));
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) t.texels[size_t(3 * (j * n + i) + c)] = float((i + j) % 2 ? b : a);
    return t;
}

/// One quad [0,1]^2 (z = 0) with corner UVs `uv` and the checker as texture.
Scene texturedQuad(const Texture& t, const std::array<glm::vec2, 4>& uv, PatchKind kind = PatchKind::Quad) {
    Scene s;
    Material m{"tex", RGB(0.5), RGB(0.0)};
    s.addMaterial(m);
    if (kind == PatchKind::Quad) {
        s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), 0);
    } else {
        s.addTriangle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), 0);
    }
    s.materials[0].diffuseMap.texture = addTexture(s, t);
    s.patches[0].uvs = 0;
    s.cornerUVs.push_back(uv);
    return s;
}

/// A triangle whose UVs (0.25, 0.5), (0.75, 0.5), (0.25, 1) straddle the
/// border u = 1/2 of the two texels of a clamped 2 x 1 texture (0.1, 0.7).
Scene rampTriangle() {
    Texture ramp = checker(2, 0, 0);
    ramp.height = 1;
    ramp.texels = {0.1f, 0.1f, 0.1f, 0.7f, 0.7f, 0.7f};
    ramp.wrapU = ramp.wrapV = TextureWrap::Clamp;
    return texturedQuad(ramp, {glm::vec2(0.25, 0.5), {0.75, 0.5}, {0.25, 1.0}, {0.25, 1.0}},
                        PatchKind::Triangle);
}

TEST(Texture, LookupHitsTexelCentresAndWraps) {
    Texture t = checker(4, 0.2, 0.6);
    // Texel (0, 0) is the top-left: u = 1/8, v = 1 - 1/8.
    EXPECT_NEAR(t.lookup(0.125, 0.875).r, 0.2, 1e-7);
    EXPECT_NEAR(t.lookup(0.375, 0.875).r, 0.6, 1e-7);
    // Halfway between two centres: the mean; repeat wraps to the far column.
    EXPECT_NEAR(t.lookup(0.25, 0.875).r, 0.4, 1e-7);
    EXPECT_NEAR(t.lookup(1.125, 0.875).r, 0.2, 1e-7);
    EXPECT_NEAR(t.lookup(0.0, 0.875).r, 0.4, 1e-7);  // between texel 3 (b) and 0 (a)
    t.wrapU = TextureWrap::Clamp;
    EXPECT_NEAR(t.lookup(0.0, 0.875).r, 0.2, 1e-7);
    EXPECT_NEAR(t.lookup(-3.0, 0.875).r, 0.2, 1e-7);
    t.wrapU = TextureWrap::Mirror;
    EXPECT_NEAR(t.lookup(-0.125, 0.875).r, 0.2, 1e-7);  // mirrored texel 0
}

TEST(Texture, PatchMeanOfACheckerIsItsAnalyticMean) {
    const double a = 0.2, b = 0.6;
    const Texture t = checker(8, a, b);
    // Whole periods: the bilinear checker's mean is (a + b) / 2.
    {
        Scene s = texturedQuad(t, {glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
        EXPECT_NEAR(patchTextureMean(s, s.patches[0]).r, 0.5 * (a + b), 1e-7);
        Scene twice = texturedQuad(t, {glm::vec2(0, 0), {2, 0}, {2, 2}, {0, 2}});
        EXPECT_NEAR(patchTextureMean(twice, twice.patches[0]).g, 0.5 * (a + b), 1e-7);
    }
    // One texel cell (the top-left, value a): the mean of the texels as
    // squares is that texel's value (the bilinear picture's mean over the
    // cell would be (10 a + 6 b) / 16: the two differ within half a texel of
    // a patch's UV border, texture.h); a quarter of it, too. The tolerance
    // is the float storage of the texels.
    {
        const float h = 1.0f / 8;
        Scene s = texturedQuad(t, {glm::vec2(0, 1 - h), {h, 1 - h}, {h, 1}, {0, 1}});
        EXPECT_NEAR(patchTextureMean(s, s.patches[0]).b, a, 1e-7);
        Scene q = texturedQuad(t, {glm::vec2(h / 4, 1 - h / 2), {h / 2, 1 - h / 2}, {h / 2, 1 - h / 4}, {h / 4, 1 - h / 4}});
        EXPECT_NEAR(patchTextureMean(q, q.patches[0]).b, a, 1e-7);
    }
    // A triangle over two texels: a quarter of its area lies at u >= 1/2
    // (the part of a right triangle beyond half its leg), so its mean is
    // 0.75 c0 + 0.25 c1. The texel border falls on the quadrature's grid, so
    // every sub-triangle lies in one texel and the quadrature is exact.
    {
        Scene s = rampTriangle();
        EXPECT_NEAR(patchTextureMean(s, s.patches[0]).r, 0.75 * 0.1 + 0.25 * 0.7, 1e-7);
    }
}

/// The exact mean of the texels as squares over the texel box [x0, x1] x
/// [y0, y1], by brute force over every lattice texel the box touches, with
/// the test's own wrap arithmetic (Texture::boxMean's definition).
RGB bruteBoxMean(const Texture& t, double x0, double x1, double y0, double y1) {
    auto wrap = [](int64_t i, int n, TextureWrap m) -> int64_t {
        if (m == TextureWrap::Clamp) return std::clamp<int64_t>(i, 0, n - 1);
        if (m == TextureWrap::Repeat) return ((i % n) + n) % n;
        const int64_t q = ((i % (2 * n)) + 2 * n) % (2 * n);
        return q < n ? q : 2 * n - 1 - q;
    };
    RGB sum(0.0);
    for (int64_t j = int64_t(std::floor(y0)); double(j) < y1; ++j) {
        const double cy = std::min(y1, double(j + 1)) - std::max(y0, double(j));
        const int64_t row = wrap(j, t.height, t.wrapV);
        for (int64_t i = int64_t(std::floor(x0)); double(i) < x1; ++i) {
            const double cx = std::min(x1, double(i + 1)) - std::max(x0, double(i));
            const float* p = &t.texels[size_t(3 * (row * t.width + wrap(i, t.width, t.wrapU)))];
            sum += (cx * cy) * RGB(p[0], p[1], p[2]);
        }
    }
    return sum / ((x1 - x0) * (y1 - y0));
}

/// A large UV footprint (issue 60; papers/notes/2026-12-02-textures.md: the
/// capped 64 x 64 point grid aliased patch means by some 30 %): a 512 x 512
/// grid of one-texel lines (1 every 8th column and 16th row, 0.05 between)
/// over a quad whose UVs span 37.3 x 3.2 repeats, the lines 300 texels apart
/// between grid points. The patch mean, and a child element's, is the exact
/// area mean of the texels (brute force, double sums over float texels:
/// 1e-9) for repeat, mirror and clamp. A square takes one box; a quad skewed
/// by eps = 1e-6 (Jacobian 1 + c eps) takes the 64 x 64 grid of boxes, whose
/// Jacobian weights then differ from uniform by at most eps: within 2 eps
/// (max - min) = 1.9e-6 of the exact unweighted mean.
TEST(Texture, PatchMeanOnALargeFootprintIsTheExactTexelMean) {
    Texture lines;
    lines.file = "lines";
    lines.width = lines.height = 512;
    for (int j = 0; j < 512; ++j)
        for (int i = 0; i < 512; ++i)
            for (int c = 0; c < 3; ++c) lines.texels.push_back(i % 8 == 0 || j % 16 == 0 ? 1.f : 0.05f);
    const glm::vec2 lo(0.013f, 0.2f), hi(37.3f, 3.41f);
    for (TextureWrap mode : {TextureWrap::Repeat, TextureWrap::Mirror, TextureWrap::Clamp}) {
        lines.wrapU = lines.wrapV = mode;
        Scene s = texturedQuad(lines, {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}});
        auto exact = [&](const Domain& d) {
            // The domain's UV rectangle in texel coordinates (y = (1 - v) 512).
            const Vec2 l(lo), e = Vec2(hi) - Vec2(lo);  // in double, as uvAt
            const double u0 = l.x + d.u0 * e.x, u1 = l.x + (d.u0 + d.h) * e.x;
            const double v0 = l.y + d.v0 * e.y, v1 = l.y + (d.v0 + d.h) * e.y;
            return bruteBoxMean(lines, 512 * u0, 512 * u1, 512 * (1 - v1), 512 * (1 - v0));
        };
        const RGB want = exact(Domain{});
        const RGB got = patchTextureMean(s, s.patches[0]);
        EXPECT_NEAR(got.g, want.g, 1e-9) << int(mode);
        Scene skewed = s;
        skewed.patches[0].v[2].x += 1e-6;
        EXPECT_NEAR(patchTextureMean(skewed, skewed.patches[0]).g, want.g, 2e-6 * 0.95 + 1e-9) << int(mode);
        const Domain child{0.5, 0.25, 0.25};
        EXPECT_NEAR(elementTextureMean(s, s.patches[0], child).r, exact(child).r, 1e-9) << int(mode);
        // Not the texture's own mean: the rectangle holds no whole periods.
        if (mode == TextureWrap::Repeat) {
            EXPECT_GT(std::fabs(want.g - s.textures[0]->mean.g), 1e-5);
        }
    }
}

/// elementTextureMean (hr.texture_rho = element): the root domain is the
/// patch mean bit for bit; each child triangle's mean is that of the texel
/// it lies in, the inverted middle child included; a child brighter than 1
/// is clamped as the loader clamps patch means.
TEST(Texture, ElementMeansFollowEachElementsOwnDomain) {
    // Children 0, 2 and the inverted 3 lie at u <= 1/2 (texel 0.1), child 1
    // beyond it (0.7).
    Scene s = rampTriangle();
    const Patch& p = s.patches[0];
    const RGB root = elementTextureMean(s, p, Domain{});
    const RGB patch = patchTextureMean(s, p);
    EXPECT_EQ(root.r, patch.r);
    EXPECT_EQ(root.b, patch.b);
    for (int c = 0; c < 4; ++c) {
        const Domain d = childDomain(p.kind, Domain{}, c);
        EXPECT_NEAR(elementTextureMean(s, p, d).r, c == 1 ? 0.7 : 0.1, 1e-7) << c;
    }
    // A half-white quad: the white child's mean 1 becomes clamp_rho.
    Texture half = checker(2, 0.0, 1.0);
    half.height = 1;
    half.texels = {0.f, 0.f, 0.f, 1.f, 1.f, 1.f};
    half.wrapU = half.wrapV = TextureWrap::Clamp;
    Scene q = texturedQuad(half, {glm::vec2(0.75, 0), {1, 0}, {1, 1}, {0.75, 1}});
    q.materials[0].diffuseMap.clampRho = 0.95;
    EXPECT_NEAR(elementTextureMean(q, q.patches[0], Domain{0, 0, 0.5}).g, 1.0, 1e-7);
    EXPECT_EQ(elementRho(q, q.patches[0], Domain{0, 0, 0.5}).g, 0.95);
}

TEST(Texture, MeansAreAppliedPerPatchAndClamped) {
    Texture white = checker(2, 1.0, 1.0);
    Scene s = texturedQuad(white, {glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
    s.materials[0].diffuseMap.clampRho = 0.95;
    EXPECT_EQ(applyTextureMeans(s), 1u);
    EXPECT_NEAR(s.patches[0].rho.r, 0.95, 1e-12);
    s.materials[0].diffuseMap.clampRho = 0.0;
    s.materials[0].diffuseMap.clampKey = "obj.clamp_rho";
    try {
        applyTextureMeans(s);
        FAIL() << "a white texture with clamp 0 must be an error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("obj.clamp_rho"), std::string::npos) << e.what();
    }
}

TEST(Texture, BudgetIsCheckedBeforeDecodingAndNamed) {
    TextureBudget budget;
    budget.maxBytes = 1 << 20;
    budget.reserve(256, 256, SourceLocation{"a.mtl", 3, 0});  // 768 KiB
    try {
        budget.reserve(160, 160, SourceLocation{"a.mtl", 7, 0});  // 300 KiB more
        FAIL() << "over budget";
    } catch (const InputError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("texture.max_mb"), std::string::npos) << m;
        EXPECT_NE(m.find("a.mtl:7"), std::string::npos) << m;
    }
}

/// A 2 x 2 sRGB PNG: top row red, green; bottom row blue, white.
void writePng2x2(const std::filesystem::path& file) {
    const unsigned char px[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
    ASSERT_TRUE(stbi_write_png(file.c_str(), 2, 2, 3, px, 6));
}

const char* kObj = R"(mtllib scene.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 0 1 1
v 1 1 1
v 1 0 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl tex
f 1/1 2/2 3/3 4/4
usemtl lamp
f 5 6 7 8
usemtl missing
f 1/1 2/2 3/3
)";

const char* kMtl = R"(newmtl tex
Kd 0.8 0.8 0.8
map_Kd tex.png
newmtl lamp
Kd 0 0 0
Ke 1 1 1
newmtl missing
Kd 0.3 0.4 0.5
map_Kd nowhere.png
)";

TEST(ObjTextures, UVsAndMapKdAreKept) {
    auto dir = test::tempDir("tex_obj");
    writePng2x2(dir / "tex.png");
    test::writeFile(dir / "scene.mtl", kMtl);
    auto obj = test::writeFile(dir / "scene.obj", kObj);
    Scene s = loadScene(obj.string());
    ASSERT_EQ(s.textures.size(), 1u);
    const Patch& quad = s.patches[0];
    ASSERT_EQ(quad.kind, PatchKind::Quad);
    const auto* uv = patchUVs(s, quad);
    ASSERT_TRUE(uv);
    EXPECT_EQ((*uv)[0], glm::vec2(0, 0));
    EXPECT_EQ((*uv)[2], glm::vec2(1, 1));
    // The 2 x 2 texture over the whole quad (repeat): per axis the bilinear
    // mean over a full period is the texels' mean, so the patch mean is
    // Kd x (the mean of the four sRGB-decoded texels) = 0.8 x (2/4, 2/4, 2/4).
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(quad.rho[c], 0.8 * 0.5, 1e-6) << c;
    // Texel (0,0) (red) at the top-left: u = 1/4, v = 3/4.
    const RGB red = textureRho(s, quad, 0.25, 0.75);
    EXPECT_NEAR(red.r, 0.8, 1e-6);
    EXPECT_NEAR(red.g, 0.0, 1e-6);
    // The lamp has no texture and no UVs; the third material's file is missing:
    // a warning naming it, and Kd.
    EXPECT_EQ(patchUVs(s, s.patches[1]), nullptr);
    const Patch& miss = s.patches[2];
    EXPECT_EQ(patchTexture(s, miss), nullptr);
    EXPECT_NEAR(miss.rho.b, 0.5, 1e-12);
    bool warned = false;
    for (const auto& w : s.stats.warnings) warned = warned || w.find("nowhere.png") != std::string::npos;
    EXPECT_TRUE(warned);
}

TEST(ObjTextures, BackSidesFollowTheirWindingAndReplaceDropsKd) {
    auto dir = test::tempDir("tex_obj2");
    writePng2x2(dir / "tex.png");
    test::writeFile(dir / "scene.mtl", kMtl);
    auto obj = test::writeFile(dir / "scene.obj", kObj);
    Params p;
    p.set("obj.two_sided", true);
    p.set("obj.texture_kd", std::string("replace"));
    Scene s = loadScene(obj.string(), p);
    const Patch& front = s.patches[0];
    ASSERT_NE(front.twin, UINT32_MAX);
    const Patch& back = s.patches[front.twin];
    // The same point of the surface has the same texel from both sides.
    const Vec3 x(0.3, 0.7, 0.0);
    const Vec2 a = patchInverse(front, x), b = patchInverse(back, x);
    const RGB fa = textureRho(s, front, a.x, a.y), fb = textureRho(s, back, b.x, b.y);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(fa[c], fb[c], 1e-6);
    EXPECT_NEAR(front.rho.r, 0.5, 1e-6);  // the texel mean alone
    EXPECT_NEAR(back.rho.r, 0.5, 1e-6);
}

TEST(ObjTextures, OverBudgetIsAnErrorNamingTheSetting) {
    auto dir = test::tempDir("tex_obj3");
    std::vector<unsigned char> px(size_t(512) * 512 * 3, 128);
    ASSERT_TRUE(stbi_write_png((dir / "tex.png").c_str(), 512, 512, 3, px.data(), 512 * 3));
    test::writeFile(dir / "scene.mtl", kMtl);
    auto obj = test::writeFile(dir / "scene.obj", kObj);
    Params p;
    p.set("texture.max_mb", int64_t(1));  // 512 x 512 x 12 bytes = 3 MiB
    try {
        loadScene(obj.string(), p);
        FAIL() << "over budget";
    } catch (const InputError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("texture.max_mb"), std::string::npos) << m;
        EXPECT_NE(m.find("scene.mtl:1"), std::string::npos) << m;  // the newmtl line
    }
}

TEST(MitsubaTextures, ObjShapeUVsAndBitmapUnderTwosided) {
    auto dir = test::tempDir("tex_mts");
    writePng2x2(dir / "tex.png");
    // The OBJ's own .mtl is not read (the XML's BSDF is the material).
    test::writeFile(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                      "f 1/1 2/2 3/3 4/4\n");
    auto xml = test::writeFile(dir / "scene.xml", R"(<scene version="3.0.0">
  <shape type="rectangle">
    <transform name="to_world"><translate value="0, 0, 10"/></transform>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
  <shape type="obj"><string name="filename" value="quad.obj"/>
    <bsdf type="twosided"><bsdf type="diffuse">
      <texture name="reflectance" type="bitmap"><string name="filename" value="tex.png"/>
        <boolean name="raw" value="true"/></texture>
    </bsdf></bsdf>
  </shape>
  <shape type="rectangle"><transform name="to_world"><translate value="0, 0, 5"/></transform>
    <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="tex.png"/>
      <string name="wrap_mode" value="clamp"/></texture></bsdf>
  </shape>
</scene>
)");
    Scene s = loadScene(xml.string());
    ASSERT_EQ(s.textures.size(), 2u);  // raw/repeat and sRGB/clamp are two decodes
    const Patch* quad = nullptr;
    const Patch* rect = nullptr;
    for (const Patch& p : s.patches) {
        if (p.backSide) continue;
        if (std::fabs(p.v[0].z) < 1e-9) quad = &p;
        if (std::fabs(p.v[0].z - 5) < 1e-9) rect = &p;
    }
    ASSERT_TRUE(quad && rect);
    ASSERT_TRUE(patchTexture(s, *quad));
    EXPECT_NE(quad->twin, UINT32_MAX);  // twosided
    // raw: texel values as stored, mean of (1,0,0) (0,1,0) (0,0,1) (1,1,1) = 0.5.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(quad->rho[c], 0.5, 1e-6);
    // The top-left texel (red) at OBJ uv (1/4, 3/4): Mitsuba's OBJ reader
    // flips v, and so does its image lookup, so OBJ UVs keep the OpenGL sense.
    const Vec2 at = patchInverse(*quad, Vec3(0.25, 0.75, 0));
    EXPECT_NEAR(textureRho(s, *quad, at.x, at.y).r, 1.0, 1e-6);
    EXPECT_NEAR(textureRho(s, *quad, at.x, at.y).g, 0.0, 1e-6);
    // The rectangle: sRGB-decoded (same texels: 0 and 1 decode to 0 and 1),
    // its uv (0,0) at the corner (-1,-1) and image row 0 there.
    ASSERT_TRUE(patchTexture(s, *rect));
    const Vec2 corner = patchInverse(*rect, Vec3(-0.5, -0.5, 5));
    EXPECT_NEAR(textureRho(s, *rect, corner.x, corner.y).r, 1.0, 1e-6);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rect->rho[c], 0.5, 1e-6);
    EXPECT_NEAR(srgbDecode(1.0), 1.0, 1e-12);
}

}  // namespace
}  // namespace hrad::scene
