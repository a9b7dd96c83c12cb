// What cluster/tree.h promises for any builder, checked on a built tree (the
// tests of every builder and of face clusters share it).
#pragma once

#include <gtest/gtest.h>

#include <set>

#include "cluster/tree.h"
#include "scene/scene.h"

namespace hrad::test {

/// Pre-order, contiguous patch ranges, every patch once, areas,
/// bounding spheres, parents and patchCluster: what tree.h promises for any builder.
inline void expectTreeInvariants(const scene::Scene& s, const cluster::ClusterTree& t) {
    std::multiset<uint32_t> seen;
    for (uint32_t c = 0; c < t.size(); ++c) {
        const auto& n = t.node(c);
        ASSERT_LE(n.patchBegin, n.patchEnd);
        for (uint32_t i = n.ownBegin(); i < n.ownEnd(); ++i) seen.insert(t.patchAt(i));
        if (n.childCount == 0) {
            EXPECT_GT(n.ownEnd(), n.ownBegin()) << "empty leaf " << c;
            EXPECT_EQ(n.ownBegin(), n.patchBegin);
            EXPECT_EQ(n.ownEnd(), n.patchEnd);
        } else {
            EXPECT_EQ(n.ownEnd(), n.ownBegin());
            double a = 0;
            uint32_t next = n.patchBegin;
            for (uint32_t k = 0; k < n.childCount; ++k) {
                uint32_t ch = t.child(c, k);
                EXPECT_GT(ch, c) << "pre-order";
                EXPECT_EQ(t.parents()[ch], c);
                EXPECT_EQ(t.node(ch).patchBegin, next) << "children's ranges tile the parent's";
                next = t.node(ch).patchEnd;
                a += t.node(ch).area;
                // A face cluster's sub-clusters are face clusters.
                if (n.face) {
                    EXPECT_TRUE(t.node(ch).face);
                }
            }
            EXPECT_EQ(next, n.patchEnd);
            EXPECT_NEAR(a, n.area, 1e-9 * n.area);
        }
        for (uint32_t i = n.patchBegin; i < n.patchEnd; ++i) {
            const auto& p = s.patches[t.patchAt(i)];
            // Nodes no longer store a box (it was read only to make the
            // sphere); the sphere, which the solver reads, must hold them.
            for (int v = 0; v < p.numVertices(); ++v) {
                EXPECT_LE(glm::length(p.v[v] - n.centroid), n.radius * (1 + 1e-12));
            }
            if (n.face) {
                EXPECT_GE(glm::dot(p.normal, t.faceShape(c).coneAxis),
                          t.faceShape(c).coneCos - 1e-12);
            }
        }
    }
    EXPECT_EQ(seen.size(), s.patches.size());
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        EXPECT_EQ(seen.count(p), 1u);
        uint32_t c = t.patchCluster()[p];
        ASSERT_LT(c, t.size());
        const auto& n = t.node(c);
        bool own = false;
        for (uint32_t i = n.ownBegin(); i < n.ownEnd(); ++i) own |= t.patchAt(i) == p;
        EXPECT_TRUE(own) << "patchCluster of " << p;
    }
    EXPECT_NEAR(t.node(0).area, s.totalArea(), 1e-9 * s.totalArea());
}

}  // namespace hrad::test
