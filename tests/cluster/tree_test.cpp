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
