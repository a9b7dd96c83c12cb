// Parametric sub-elements (scene/element.h) and UniformField averages.
#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"
#include "scene/element.h"
#include "scene/field.h"
#include "scene/scene.h"

namespace hrad::scene {
namespace {

Scene testPatches() {
    Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(1.0)});
    // A tilted unit-ish square, a planar trapezoid in a tilted plane, a triangle.
    EXPECT_TRUE(s.addQuad({0, 0, 0}, {1, 0, 0.2}, {1, 1, 0.2}, {0, 1, 0}, m));
    Vec3 a(0.3, 0.1, 0.5), e1 = glm::normalize(Vec3(1, 0.2, -0.3)), e2 = glm::normalize(glm::cross(Vec3(0.1, 0.4, 1), e1));
    EXPECT_TRUE(s.addQuad(a, a + 4.0 * e1, a + 3.0 * e1 + 2.0 * e2, a + 0.5 * e1 + 2.0 * e2, m));
    EXPECT_TRUE(s.addTriangle({0, 0, 1}, {2, 0.5, 1.3}, {0.2, 1.7, 0.9}, m));
    return s;
}

double childSum(const Patch& p, const Domain& d) {
    double sum = 0;
    for (int c = 0; c < 4; ++c) sum += elementArea(p, childDomain(p.kind, d, c));
    return sum;
}

TEST(Element, RootAreaEqualsPatchArea) {
    Scene s = testPatches();
    for (const Patch& p : s.patches) EXPECT_NEAR(elementArea(p, Domain{}), p.area, 1e-12 * p.area);
}

TEST(Element, ChildAreasSumToParentAtEveryLevelAlongRandomPaths) {
    Scene s = testPatches();
    Pcg32 rng(42);
    for (const Patch& p : s.patches) {
        // All elements of levels 0..3, then 200 random paths down to level 10.
        for (int level = 0; level <= 3; ++level)
            for (ElementKey k = ElementKey(1) << (2 * level); k < ElementKey(2) << (2 * level); ++k) {
                Domain d = keyDomain(p.kind, k);
                double a = elementArea(p, d);
                EXPECT_NEAR(childSum(p, d), a, 1e-12 * a) << "level " << level;
            }
        for (int path = 0; path < 200; ++path) {
            ElementKey k = kRootKey;
            for (int level = 0; level < 10; ++level) {
                Domain d = keyDomain(p.kind, k);
                double a = elementArea(p, d);
                ASSERT_GT(a, 0.0);
                EXPECT_NEAR(childSum(p, d), a, 1e-12 * a) << "level " << level;
                k = childKey(k, int(rng.nextU32() & 3u));
            }
            // Level-10 area is the root area / 4^10 for parallelograms and
            // triangles only; for all shapes it is positive and tiny.
            EXPECT_LT(elementArea(p, keyDomain(p.kind, k)), p.area * 1e-4);
        }
    }
}

TEST(Element, TriangleChildrenHaveEqualAreas) {
    Scene s = testPatches();
    const Patch& t = s.patches[2];
    for (int c = 0; c < 4; ++c)
        EXPECT_NEAR(elementArea(t, childDomain(t.kind, Domain{}, c)), t.area / 4, 1e-12 * t.area);
}

TEST(Element, KeyDomainChildContainingKeyAtRoundTrip) {
    Scene s = testPatches();
    Pcg32 rng(7);
    for (const Patch& p : s.patches) {
        for (int trial = 0; trial < 300; ++trial) {
            // Random key at a random level; its centroid maps back to the key.
            int level = 1 + int(rng.nextU32() % 10);
            ElementKey k = kRootKey;
            for (int l = 0; l < level; ++l) k = childKey(k, int(rng.nextU32() & 3u));
            Domain d = keyDomain(p.kind, k);
            Vec2 uv = p.kind == PatchKind::Quad ? domainParam(d, 0.5, 0.5) : domainParam(d, 1.0 / 3, 1.0 / 3);
            EXPECT_EQ(keyAt(p.kind, uv.x, uv.y, level), k);
            EXPECT_EQ(keyLevel(k), level);
            EXPECT_TRUE(keyContains(kRootKey, k));
            EXPECT_TRUE(keyContains(parentKey(k), k));
            EXPECT_EQ(childContaining(p.kind, keyDomain(p.kind, parentKey(k)), uv.x, uv.y), childIndexOf(k));
            // patchInverse(point(u, v)) == (u, v).
            Vec3 x = p.point(uv.x, uv.y);
            Vec2 back = patchInverse(p, x);
            EXPECT_NEAR(back.x, uv.x, 1e-9);
            EXPECT_NEAR(back.y, uv.y, 1e-9);
            // The element centroid lies in the element.
            Vec2 cuv = patchInverse(p, elementCentroid(p, d));
            EXPECT_EQ(keyAt(p.kind, cuv.x, cuv.y, level), k);
        }
    }
}

TEST(UniformField, AverageOverCoarserKeyIsAreaWeightedMean) {
    Scene s = testPatches();
    UniformField f(s, {4, 4, 3});
    Pcg32 rng(3);
    for (size_t i = 0; i < f.numElements(); ++i) f.value(i) = RGB(rng.nextDouble(), rng.nextDouble(), 2 * rng.nextDouble());
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        const Patch& patch = s.patches[p];
        for (ElementKey coarse : {kRootKey, ElementKey(6), ElementKey(27)}) {
            RGB sum(0.0);
            double area = 0;
            for (size_t i = 0; i < f.count(p); ++i) {
                ElementKey k = f.key(p, i);
                if (!keyContains(coarse, k)) continue;
                double a = elementArea(patch, keyDomain(patch.kind, k));
                sum += a * f.value(f.offset(p) + i);
                area += a;
            }
            RGB expected = sum / area;
            RGB got = f.average(p, coarse);
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-12 * std::fabs(expected[c]) + 1e-15);
            if (coarse == kRootKey) {
                EXPECT_NEAR(area, patch.area, 1e-12 * patch.area);
            }
        }
    }
}

}  // namespace
}  // namespace hrad::scene
