// The smooth reconstruction (render/smooth.h): C0 across element borders,
// T-vertices and root-patch borders of one surface; sharp at creases and
// material borders; flat on request.
#include "render/smooth.h"

#include <gtest/gtest.h>

#include <random>

#include "core/params.h"
#include "render/render.h"
#include "scene/element.h"
#include "scene/field.h"

namespace hrad::render {
namespace {

using scene::ElementKey;
using scene::LeafField;

/// Every key of level `level` below `root`.
void keysAt(ElementKey root, int level, std::vector<ElementKey>& out) {
    if (level == 0) {
        out.push_back(root);
        return;
    }
    for (int c = 0; c < 4; ++c) keysAt(scene::childKey(root, c), level - 1, out);
}

struct Fixture {
    scene::Scene s;
    std::unique_ptr<LeafField> field;
    uint32_t A = 0, B = 1, C = 2, D = 3, E = 4, F = 5;  // patch indices
};

/// A: quad [0,1]^2 (z = 0), children 1..3 at level 1 and child 0 split again
/// (T-vertices inside A). B: quad [1,2]x[0,1], level 2 (T-vertices on A's
/// border). C: quad standing on B's far edge (x = 2): a crease. D: quad
/// [-1,0]x[0,1], another material. E, F: two triangles of the square
/// [0,1]^2 at z = 5, E at level 2 and F at level 0 (T-vertices on the
/// diagonal). Values random per leaf.
Fixture makeFixture() {
    Fixture f;
    uint32_t m = f.s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    uint32_t m2 = f.s.addMaterial({"red", RGB(0.6, 0.1, 0.1), RGB(0.0)});
    f.s.addQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m);
    f.s.addQuad({1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, m);
    f.s.addQuad({2, 0, 0}, {2, 0, 1}, {2, 1, 1}, {2, 1, 0}, m);
    f.s.addQuad({-1, 0, 0}, {0, 0, 0}, {0, 1, 0}, {-1, 1, 0}, m2);
    f.s.addTriangle({0, 0, 5}, {1, 0, 5}, {1, 1, 5}, m);
    f.s.addTriangle({0, 0, 5}, {1, 1, 5}, {0, 1, 5}, m);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> val(0.1, 1.0);
    std::vector<std::vector<LeafField::Leaf>> leaves(6);
    auto add = [&](uint32_t p, ElementKey k, double scale = 1.0) {
        leaves[p].push_back({k, RGB(val(rng), val(rng), val(rng)) * scale});
    };
    for (ElementKey k : {ElementKey(4 * 1 + 1), ElementKey(4 * 1 + 2), ElementKey(4 * 1 + 3)})
        add(f.A, k);
    std::vector<ElementKey> ks;
    keysAt(scene::childKey(scene::kRootKey, 0), 1, ks);
    for (ElementKey k : ks) add(f.A, k);
    ks.clear();
    keysAt(scene::kRootKey, 2, ks);
    for (ElementKey k : ks) add(f.B, k), add(f.E, k);
    add(f.C, scene::kRootKey);
    add(f.D, scene::kRootKey, 100.0);  // far brighter: must not leak into A
    add(f.F, scene::kRootKey);
    f.field = std::make_unique<LeafField>(f.s, std::move(leaves));
    return f;
}

RGB valueAt(const VertexInterpolation& vi, const scene::Scene& s, uint32_t p, const Vec3& x) {
    Vec2 uv = scene::patchInverse(s.patches[p], x);
    return vi.at(p, uv.x, uv.y);
}

double maxDiff(const RGB& a, const RGB& b) {
    return std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
}

TEST(Smooth, ContinuousAcrossTVerticesAndPatchBorders) {
    Fixture f = makeFixture();
    VertexInterpolation vi(*f.field);
    EXPECT_EQ(vi.surfaceOf(f.A), vi.surfaceOf(f.B));
    EXPECT_EQ(vi.surfaceOf(f.E), vi.surfaceOf(f.F));
    EXPECT_GT(vi.numAnchored(), 0u);
    const double eps = 1e-9;
    double worst = 0.0;
    for (int i = 1; i < 64; ++i) {
        double t = i / 64.0;
        // A | B along x = 1 (B is finer: T-vertices at y = 1/4, 3/4).
        worst = std::max(worst, maxDiff(valueAt(vi, f.s, f.A, {1, t, 0}), valueAt(vi, f.s, f.B, {1, t, 0})));
        // Inside A: the fine child 0 against children 1 and 3 (x or y = 1/2).
        if (t < 0.5) {
            worst = std::max(worst, maxDiff(valueAt(vi, f.s, f.A, {0.5 - eps, t, 0}),
                                            valueAt(vi, f.s, f.A, {0.5 + eps, t, 0})));
            worst = std::max(worst, maxDiff(valueAt(vi, f.s, f.A, {t, 0.5 - eps, 0}),
                                            valueAt(vi, f.s, f.A, {t, 0.5 + eps, 0})));
        }
        // E | F along the diagonal (E is finer).
        worst = std::max(worst, maxDiff(valueAt(vi, f.s, f.E, {t, t, 5}), valueAt(vi, f.s, f.F, {t, t, 5})));
    }
    // Values are O(1) and the slopes O(10) per unit: 1e-9 steps move them by
    // 1e-8 at most; anything larger is a jump.
    EXPECT_LT(worst, 1e-7);
}

TEST(Smooth, SharpAtCreasesAndMaterialBorders) {
    Fixture f = makeFixture();
    VertexInterpolation vi(*f.field);
    EXPECT_NE(vi.surfaceOf(f.B), vi.surfaceOf(f.C));
    EXPECT_NE(vi.surfaceOf(f.A), vi.surfaceOf(f.D));
    // C is alone on its surface: one leaf, constant, whatever B does.
    RGB c = f.field->at(f.C, 0.5, 0.5);
    for (double t : {0.1, 0.5, 0.9}) EXPECT_LT(maxDiff(valueAt(vi, f.s, f.C, {2, t, 0}), c), 1e-12);
    // D is 100 times brighter; A's border with it keeps A's own range.
    for (double t : {0.1, 0.5, 0.9}) EXPECT_LT(luminance(valueAt(vi, f.s, f.A, {0, t, 0})), 1.0);
    // With a crease angle of 100 degrees, B and C become one surface.
    SmoothSettings wide;
    wide.creaseDegrees = 100.0;
    VertexInterpolation vw(*f.field, wide);
    EXPECT_EQ(vw.surfaceOf(f.B), vw.surfaceOf(f.C));
    EXPECT_LT(maxDiff(valueAt(vw, f.s, f.C, {2, 0.5, 0}), valueAt(vw, f.s, f.B, {2, 0.5, 0})), 1e-9);
}

TEST(Smooth, IsTheDefaultAndFlatIsASetting) {
    Params p;
    RenderSettings d = RenderSettings::fromParams(p);
    EXPECT_TRUE(d.interpolate);
    EXPECT_EQ(d.reconstruction, RenderSettings::Reconstruction::Interpolated);
    EXPECT_EQ(RenderSettings{}.reconstruction, RenderSettings::Reconstruction::Interpolated);
    Params q;
    q.set("render.interpolate", false);
    RenderSettings flat = RenderSettings::fromParams(q);
    EXPECT_FALSE(flat.interpolate);
    EXPECT_EQ(flat.reconstruction, RenderSettings::Reconstruction::Flat);
    Params r;
    r.set("render.reconstruction", std::string("flat"));
    EXPECT_EQ(RenderSettings::fromParams(r).reconstruction, RenderSettings::Reconstruction::Flat);
    Params g;
    g.set("render.reconstruction", std::string("final-gather"));
    EXPECT_EQ(RenderSettings::fromParams(g).reconstruction, RenderSettings::Reconstruction::FinalGather);
}

}  // namespace
}  // namespace hrad::render

namespace hrad::render {
namespace {

// A patch far smaller than the vertex quantum (1e-7 of the scene diagonal):
// its edges' midpoints fall on their end points' keys. They are not
// T-vertices; before this was checked, each such edge recursed to level 30
// on both halves (2^30 anchors: the bathroom's smooth render ran out of
// memory in VertexInterpolation).
TEST(Smooth, EdgesShorterThanTheQuantumHaveNoTVertices) {
    scene::Scene s;
    const uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    s.addQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m);
    const double h = 1e-8;
    s.addQuad({0.3, 0.3, 0.5}, {0.3 + h, 0.3, 0.5}, {0.3 + h, 0.3 + h, 0.5}, {0.3, 0.3 + h, 0.5}, m);
    ASSERT_EQ(s.patches.size(), 2u);
    std::vector<std::vector<LeafField::Leaf>> leaves(2);
    leaves[0].push_back({scene::kRootKey, RGB(1.0)});
    for (int c = 0; c < 4; ++c) leaves[1].push_back({scene::childKey(scene::kRootKey, c), RGB(0.2 * (c + 1))});
    LeafField field(s, std::move(leaves));
    VertexInterpolation vi(field, SmoothSettings{});
    EXPECT_LT(vi.numAnchored(), 16u);
}

}  // namespace
}  // namespace hrad::render
