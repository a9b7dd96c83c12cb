#include <gtest/gtest.h>

#include <set>

#include "cluster/tree.h"
#include "scene/loader.h"
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
    // Leaves hold every patch exactly once.
    std::multiset<uint32_t> seen;
    for (uint32_t c = 0; c < t.size(); ++c) {
        const auto& n = t.node(c);
        for (uint32_t i = n.ownBegin; i < n.ownEnd; ++i) seen.insert(t.patchAt(i));
        if (n.childCount == 0) {
            EXPECT_GT(n.ownEnd, n.ownBegin) << "empty leaf " << c;
        } else {
            EXPECT_EQ(n.ownEnd, n.ownBegin);
            double a = 0;
            for (uint32_t k = 0; k < n.childCount; ++k) {
                uint32_t ch = t.child(c, k);
                EXPECT_GT(ch, c) << "pre-order";
                EXPECT_EQ(t.parents()[ch], c);
                a += t.node(ch).area;
            }
            EXPECT_NEAR(a, n.area, 1e-9 * n.area);
        }
        // The box contains the patches below, the sphere contains the box.
        for (uint32_t i = n.patchBegin; i < n.patchEnd; ++i) {
            const auto& p = s.patches[t.patchAt(i)];
            for (int v = 0; v < p.numVertices(); ++v) {
                for (int k = 0; k < 3; ++k) {
                    EXPECT_GE(p.v[v][k], n.box.lo[k]);
                    EXPECT_LE(p.v[v][k], n.box.hi[k]);
                }
                EXPECT_LE(glm::length(p.v[v] - n.centroid), n.radius * (1 + 1e-12));
            }
        }
    }
    EXPECT_EQ(seen.size(), s.patches.size());
    for (uint32_t p = 0; p < s.patches.size(); ++p) EXPECT_EQ(seen.count(p), 1u);
    EXPECT_NEAR(t.node(0).area, s.totalArea(), 1e-9 * s.totalArea());
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
        s.addQuad(Vec3(2 * i, 0, 0), Vec3(2 * i + 1, 0, 0), Vec3(2 * i + 1, 1, 0), Vec3(2 * i, 1, 0), m);
    ClusterSettings cs;
    cs.leafSize = 8;
    ClusterTree t(s, cs);
    ASSERT_EQ(t.size(), 1u);
    Vec3 d = glm::normalize(Vec3(0.3, -0.2, 0.9));
    EXPECT_NEAR(t.projectedArea(0, d), 3.0 * d.z, 1e-12);  // exact for coplanar surfaces
    EXPECT_EQ(t.projectedArea(0, -d), 0.0);                  // all facing away
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
