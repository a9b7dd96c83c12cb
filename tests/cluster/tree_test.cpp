#include "cluster/tree.h"

#include <gtest/gtest.h>

#include "scene/loader.h"
#include "tests/cluster/tree_invariants.h"
#include "tests/scenes.h"

using namespace hrad;
using namespace hrad::cluster;

class Builders : public ::testing::TestWithParam<std::string> {};

TEST_P(Builders, EveryPatchOnceAndNodesConsistent) {
    scene::Scene s = scene::loadScene("office:2");
    ClusterSettings cs;
    cs.builder = GetParam();
    cs.leafSize = 4;
    ClusterTree t(s, cs);
    ASSERT_GT(t.size(), 1u);
    test::expectTreeInvariants(s, t);
    std::cout << GetParam() << ": " << t.size() << " clusters, depth " << t.depth() << ", "
              << t.memoryBytes() << " bytes, " << t.buildSeconds() << " s\n";
}

INSTANTIATE_TEST_SUITE_P(Cluster, Builders, ::testing::Values("bvh", "octree"));

TEST(ClusterTree, UnknownBuilderListsValidOnes) {
    Params p;
    p.set("cluster.builder", std::string("kdtree"), {"study.toml", 9});
    try {
        ClusterSettings::fromParams(p);
        FAIL();
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_NE(m.find("study.toml:9"), std::string::npos) << m;
        EXPECT_NE(m.find("bvh"), std::string::npos) << m;
        EXPECT_NE(m.find("octree"), std::string::npos) << m;
    }
}

TEST(ClusterTree, ProjectedAreaOfCoplanarAndFacingAwaySurfaces) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(1.0)});
    // Three coplanar quads facing +z, total area 3.
    for (int i = 0; i < 3; ++i)
        s.addQuad(Vec3(2 * i, 0, 0), Vec3(2 * i + 1, 0, 0), Vec3(2 * i + 1, 1, 0),
                  Vec3(2 * i, 1, 0), m);
    ClusterSettings cs;
    cs.leafSize = 8;
    ClusterTree t(s, cs);
    ASSERT_EQ(t.size(), 1u);
    Vec3 d = glm::normalize(Vec3(0.3, -0.2, 0.9));
    EXPECT_NEAR(t.projectedArea(0, d), 3.0 * d.z, 1e-12);  // exact for coplanar surfaces
    EXPECT_EQ(t.projectedArea(0, -d), 0.0);                // all facing away
    EXPECT_NEAR(t.projectedArea(0, Vec3(0, 0, 1)), 3.0, 1e-12);
}

TEST(ClusterTree, SamplePointLiesOnAPatchOfTheCluster) {
    scene::Scene s = scene::loadScene("office:1");
    ClusterTree t(s, ClusterSettings{});
    Pcg32 rng(3);
    for (uint32_t c = 0; c < t.size(); c += 7) {
        for (int i = 0; i < 20; ++i) {
            uint32_t patch = 0;
            Vec3 x = t.samplePoint(c, rng.nextDouble(), rng.nextDouble(), rng.nextDouble(), patch);
            const auto& n = t.node(c);
            bool inside = false;
            for (uint32_t k = n.patchBegin; k < n.patchEnd; ++k) inside |= t.patchAt(k) == patch;
            EXPECT_TRUE(inside);
            const auto& p = s.patches[patch];
            EXPECT_NEAR(glm::dot(x - p.v[0], p.normal), 0.0, 1e-9);
        }
    }
}

// A quad's two triangle areas are stored where quads are at least a quarter
// of the patches and computed per point elsewhere (ClusterTree::halves_): the
// same arithmetic, so a quad gives the same points either way, and they lie
// on it with each triangle drawn by its area.
TEST(ClusterTree, QuadPointsTheSameWithAndWithoutStoredHalves) {
    auto make = [](int triangles) {
        scene::Scene s;
        uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
        // A trapezoid: its triangles v0 v1 v2 and v0 v2 v3 differ in area (3 : 1).
        s.addQuad(Vec3(0, 0, 0), Vec3(3, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), m);
        for (int i = 0; i < triangles; ++i)
            s.addTriangle(Vec3(5 + i, 0, 0), Vec3(6 + i, 0, 0), Vec3(5 + i, 1, 0), m);
        return s;
    };
    // One quad in 2 patches: stored; one in 8: computed.
    scene::Scene dense = make(1), sparse = make(7);
    ClusterTree td(dense, ClusterSettings{}), ts(sparse, ClusterSettings{});
    Pcg32 rng(11);
    int first = 0;
    const int n = 4000;
    for (int i = 0; i < n; ++i) {
        double u1 = rng.nextDouble(), u2 = rng.nextDouble();
        Vec3 a = td.pointOnPatch(0, u1, u2), b = ts.pointOnPatch(0, u1, u2);
        ASSERT_EQ(a, b) << "u = (" << u1 << ", " << u2 << ")";
        EXPECT_NEAR(a.z, 0.0, 1e-15);
        EXPECT_GE(a.y, -1e-15);
        EXPECT_LE(a.y, 1.0 + 1e-15);
        // Below the diagonal v0 v2 (y < x / 2) lies the first triangle.
        first += a.y < 0.5 * a.x ? 1 : 0;
    }
    // Three quarters of the area: a binomial proportion, 5 standard errors.
    const double p = double(first) / n, se = std::sqrt(0.75 * 0.25 / n);
    EXPECT_NEAR(p, 0.75, 5 * se);
}
