#include <gtest/gtest.h>

#include "core/rng.h"
#include "hr/hierarchy.h"
#include "tests/scenes.h"

using namespace hrad;
using namespace hrad::hr;

namespace {
// Subdivides a few elements at random, to depth 4.
void randomRefine(Hierarchy& h, uint64_t seed) {
    Pcg32 rng(seed);
    for (int i = 0; i < 60; ++i) {
        uint32_t e = rng.nextU32() % h.numElements();
        if (h.isLeaf(e) && h.level(e) < 4) h.subdivide(e);
    }
}
}  // namespace

TEST(PushPull, ConservesPower) {
    scene::Scene s = test::closedRoom();
    Hierarchy h(s);
    randomRefine(h, 7);
    Pcg32 rng(11);
    // Arbitrary gathered radiosity on every element (leaves and inner nodes).
    RGB expected = s.emittedPower();
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        h.gathered(e) = RGB(rng.nextDouble(), rng.nextDouble(), rng.nextDouble());
        expected += h.area(e) * h.gathered(e);
    }
    h.pushPull();
    RGB leaves = h.radiosityPower();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(leaves[c], expected[c], 1e-12 * expected[c]);
    // Every inner node holds the area-weighted average of its children.
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (h.isLeaf(e)) continue;
        RGB avg(0.0);
        for (uint32_t c = h.firstChild(e); c < h.firstChild(e) + 4; ++c) avg += h.area(c) * h.B(c);
        avg /= h.area(e);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(h.B(e)[k], avg[k], 1e-12 * (1 + avg[k]));
    }
}

TEST(Hierarchy, ChildrenAreasSumToParent) {
    scene::Scene s = test::closedRoom();
    Hierarchy h(s);
    randomRefine(h, 3);
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (h.isLeaf(e)) continue;
        double a = 0;
        for (uint32_t c = h.firstChild(e); c < h.firstChild(e) + 4; ++c) a += h.area(c);
        EXPECT_NEAR(a, h.area(e), 1e-13 * h.area(e));
    }
}

TEST(HierarchyField, AverageMatchesLeaves) {
    scene::Scene s = test::closedRoom();
    Hierarchy h(s);
    randomRefine(h, 5);
    Pcg32 rng(1);
    for (uint32_t e = 0; e < h.numElements(); ++e) h.gathered(e) = RGB(rng.nextDouble());
    h.pushPull();
    HierarchyField f(h);
    for (uint32_t p = 0; p < h.numPatches(); ++p) {
        // The root average equals the area-weighted mean of the leaves.
        RGB sum(0.0);
        double a = 0;
        f.forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) {
            double ak = scene::elementArea(s.patches[p], scene::keyDomain(s.patches[p].kind, k));
            sum += ak * b;
            a += ak;
        });
        EXPECT_NEAR(a, s.patches[p].area, 1e-12 * a);
        RGB avg = f.average(p, scene::kRootKey);
        EXPECT_NEAR(avg.r, sum.r / a, 1e-12 * (1 + avg.r));
        // A region deeper than the leaves gets the leaf value.
        scene::ElementKey deep = scene::keyAt(s.patches[p].kind, 0.1, 0.1, 8);
        EXPECT_EQ(f.average(p, deep), f.at(p, 0.1, 0.1));
    }
}

TEST(Hierarchy, SetLinksBuildsRowsByReceiver) {
    scene::Scene s = test::closedRoom();
    Hierarchy h(s);
    std::vector<uint32_t> recv = {3, 1, 3, 0};
    std::vector<Link> links(4);
    for (int i = 0; i < 4; ++i) links[i].sender = uint32_t(10 + i);
    h.setLinks(recv, std::move(links));
    ASSERT_EQ(h.numLinks(), 4u);
    EXPECT_EQ(h.linkEnd(0) - h.linkBegin(0), 1u);
    EXPECT_EQ(h.link(h.linkBegin(0)).sender, 13u);
    EXPECT_EQ(h.linkEnd(3) - h.linkBegin(3), 2u);
    EXPECT_EQ(h.link(h.linkBegin(3)).sender, 10u);  // stable within a row
    EXPECT_EQ(h.link(h.linkBegin(3) + 1).sender, 12u);
    EXPECT_EQ(sizeof(Link), 16u);
}

// Kernel samples are stored as a float mean and 16-bit deviations scaled per
// link (hr/hierarchy.h): every sample comes back within 1/32767 of the link's
// largest deviation from the mean, whatever the magnitude of the values,
// including a link whose kernel hardly varies (deviations 1e-7 of the mean,
// below a float's resolution of the values themselves) and zero deviation.
TEST(KernelSamples, RoundTripWithinTheStatedPrecision) {
    Pcg32 rng(3);
    auto check = [](const double* v, int m) {
        KernelSamples ks(v, m);
        double mean = 0.0;
        for (int k = 0; k < m; ++k) mean += v[k] / m;
        double largest = 0.0;
        for (int k = 0; k < m; ++k) largest = std::max(largest, std::fabs(v[k] - mean));
        for (int k = 0; k < m; ++k) {
            // The stated bound; the deviations are from the stored (float)
            // mean, at most a float's rounding (6e-8) of the mean away.
            double tol = (largest + 6e-8 * std::fabs(mean)) / 32767.0;
            EXPECT_NEAR(ks[k], v[k], tol) << "sample " << k << " of " << m;
            EXPECT_NEAR(ks.mean() + ks.deviation(k) * ks.step(), v[k], tol);
        }
        for (int k = m; k < KernelSamples::kCount; ++k) EXPECT_EQ(ks[k], ks.mean());
    };
    double v[KernelSamples::kCount];
    for (int trial = 0; trial < 2000; ++trial) {
        const int m = trial % 3 == 0 ? 7 : 9;
        const double scale = std::ldexp(1.0, int(rng.nextU32() % 60) - 50);
        const double spread = trial % 4 == 0 ? 1e-7 : (trial % 4 == 1 ? 10.0 : 0.5);
        for (int k = 0; k < m; ++k) v[k] = scale * (1.0 + spread * (rng.nextDouble() - 0.3));
        check(v, m);
    }
    // Constant samples, all zero, and none.
    for (double& x : v) x = 0.25;
    check(v, 9);
    KernelSamples flat(v, 9);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(flat[k], 0.25);
    for (double& x : v) x = 0.0;
    KernelSamples zero(v, 9), none(v, 0), dflt;
    for (int k = 0; k < 9; ++k) {
        EXPECT_EQ(zero[k], 0.0);
        EXPECT_EQ(none[k], 0.0);
        EXPECT_EQ(dflt[k], 0.0);
    }
    // One sample far from the others: they keep 1/32767 of its deviation.
    for (int k = 0; k < 9; ++k) v[k] = 1e-3 * (1.0 + 0.01 * k);
    v[4] = 0.5;
    check(v, 9);
}
