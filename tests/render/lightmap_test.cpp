// Lightmaps (render/lightmap.h): charts packed without overlap, the atlas
// continuous across chart borders of one surface, and a valid .glb.
#include "render/lightmap.h"

#include <gtest/gtest.h>

#include <random>

#include <tiny_gltf.h>

#include "scene/element.h"
#include "scene/field.h"
#include "tests/gltf_validate.h"
#include "tests/test_util.h"

namespace hrad::render {
namespace {

using scene::ElementKey;
using scene::LeafField;

void keysAt(ElementKey root, int level, std::vector<ElementKey>& out) {
    if (level == 0) {
        out.push_back(root);
        return;
    }
    for (int c = 0; c < 4; ++c) keysAt(scene::childKey(root, c), level - 1, out);
}

/// Two coplanar quads A = [0,1]^2, B = [1,2] x [0,1] (one surface; A at
/// level 1, B at level 3, so B has T-vertices on the border), a triangle pair
/// at z = 3 sharing a diagonal, and a quad on a crease. Random leaf values.
struct Scene2 {
    scene::Scene s;
    std::unique_ptr<LeafField> field;
};

Scene2 makeScene() {
    Scene2 f;
    uint32_t m = f.s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    f.s.addQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m);
    f.s.addQuad({1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, m);
    f.s.addTriangle({0, 0, 3}, {1, 0, 3}, {1, 1, 3}, m);
    f.s.addTriangle({0, 0, 3}, {1, 1, 3}, {0, 1, 3}, m);
    f.s.addQuad({2, 0, 0}, {2, 0, 1}, {2, 1, 1}, {2, 1, 0}, m);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> val(0.2, 1.0);
    std::vector<std::vector<LeafField::Leaf>> leaves(5);
    int levels[5] = {1, 3, 2, 1, 0};
    for (uint32_t p = 0; p < 5; ++p) {
        std::vector<ElementKey> ks;
        keysAt(scene::kRootKey, levels[p], ks);
        for (ElementKey k : ks) leaves[p].push_back({k, RGB(val(rng), val(rng), val(rng))});
    }
    f.field = std::make_unique<LeafField>(f.s, std::move(leaves));
    return f;
}

double maxDiff(const RGB& a, const RGB& b) {
    return std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
}

TEST(Lightmap, ChartsArePackedWithoutOverlap) {
    Scene2 f = makeScene();
    LightmapSettings ls;
    ls.size = 128;
    Lightmap lm = bakeLightmap(*f.field, ls, nullptr);
    ASSERT_EQ(lm.charts.size(), f.s.patches.size());
    EXPECT_GT(lm.density, 10.0);
    EXPECT_GT(lm.fill(), 0.2);
    for (size_t i = 0; i < lm.charts.size(); ++i) {
        const auto& a = lm.charts[i];
        EXPECT_GE(a.x - lm.gutter, 0);
        EXPECT_LE(a.x + a.w + lm.gutter, lm.size);
        for (size_t j = i + 1; j < lm.charts.size(); ++j) {
            const auto& b = lm.charts[j];
            bool apart = a.x + a.w + lm.gutter <= b.x - lm.gutter || b.x + b.w + lm.gutter <= a.x - lm.gutter ||
                         a.y + a.h + lm.gutter <= b.y - lm.gutter || b.y + b.h + lm.gutter <= a.y - lm.gutter;
            EXPECT_TRUE(apart) << i << " " << j;
        }
    }
    // A fixed density grows the atlas instead.
    LightmapSettings dense;
    dense.size = 64;
    dense.density = 100.0;
    Lightmap big = bakeLightmap(*f.field, dense, nullptr);
    EXPECT_EQ(big.density, 100.0);
    EXPECT_GE(big.size, 256);
}

// The seam test of issue 60: along every border of one smooth surface, the
// bilinearly filtered lightmap read from either chart agrees within the
// field's own change over one texel (the largest difference between
// neighbouring texels inside the two charts); without gutters the charts would
// bleed into their neighbours and the difference would be of the values'
// order (0.2..1).
TEST(Lightmap, ContinuousAcrossChartBorders) {
    Scene2 f = makeScene();
    VertexInterpolation vi(*f.field);
    LightmapSettings ls;
    ls.size = 256;
    Lightmap lm = bakeLightmap(*f.field, ls, &vi);
    auto texelStep = [&](uint32_t p) {
        const auto& c = lm.charts[p];
        double step = 0.0;
        for (int j = 0; j < c.h; ++j)
            for (int i = 0; i + 1 < c.w; ++i)
                step = std::max({step, maxDiff(lm.atlas.at(c.x + i, c.y + j), lm.atlas.at(c.x + i + 1, c.y + j)),
                                 j + 1 < c.h ? maxDiff(lm.atlas.at(c.x + i, c.y + j), lm.atlas.at(c.x + i, c.y + j + 1)) : 0.0});
        return step;
    };
    struct Border {
        uint32_t p, q;
        Vec3 a, b;
    } borders[] = {{0, 1, {1, 0, 0}, {1, 1, 0}}, {2, 3, {0, 0, 3}, {1, 1, 3}}};
    for (const Border& br : borders) {
        const double tol = std::max(texelStep(br.p), texelStep(br.q));
        ASSERT_GT(tol, 0.0);
        ASSERT_LT(tol, 0.2);  // fine enough to tell a seam from the field's slope
        double worst = 0.0;
        for (int i = 1; i < 50; ++i) {
            Vec3 x = br.a + (br.b - br.a) * (i / 50.0);
            Vec2 up = scene::patchInverse(f.s.patches[br.p], x), uq = scene::patchInverse(f.s.patches[br.q], x);
            RGB sp = lm.sample(lm.uv(br.p, up.x, up.y)), sq = lm.sample(lm.uv(br.q, uq.x, uq.y));
            worst = std::max(worst, maxDiff(sp, sq));
        }
        EXPECT_LE(worst, tol) << "border " << br.p << "|" << br.q;
    }
}

TEST(Lightmap, GlbCarriesTheAtlasAsTexcoord1) {
    auto dir = test::tempDir("lightmap_glb");
    Scene2 f = makeScene();
    LightmapSettings ls;
    ls.size = 64;
    ToneMap tone;
    Lightmap lm = writeLightmapFiles(*f.field, ls, nullptr, tone, dir.string());
    const std::string path = (dir / "lightmap.glb").string();
    tinygltf::TinyGLTF loader;
    tinygltf::Model m;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err;
    const auto& prim = m.meshes.at(0).primitives.at(0);
    EXPECT_TRUE(prim.attributes.count("TEXCOORD_0"));
    EXPECT_TRUE(prim.attributes.count("TEXCOORD_1"));
    ASSERT_EQ(m.materials.size(), 1u);
    EXPECT_EQ(m.materials[0].pbrMetallicRoughness.baseColorTexture.texCoord, 1);
    EXPECT_TRUE(m.materials[0].extensions.count("KHR_materials_unlit"));
    ASSERT_EQ(m.images.size(), 1u);
    EXPECT_EQ(m.images[0].width, lm.size);  // tinygltf decodes the embedded PNG
    EXPECT_TRUE(std::filesystem::exists(dir / "lightmap.exr"));
    EXPECT_TRUE(std::filesystem::exists(dir / "lightmap.png"));
    HRAD_EXPECT_VALID_GLTF(path);
}

}  // namespace
}  // namespace hrad::render
