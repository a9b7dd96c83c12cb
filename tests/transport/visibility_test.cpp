// Visibility (Embree) and form factors with occlusion: blockers, partial
// visibility statistics, determinism across runs and threads.
#include "transport/visibility.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <thread>
#include <vector>

#include "core/rng.h"
#include "scene/element.h"
#include "scene/scene.h"
#include "transport/formfactor.h"

using namespace hrad;
using namespace hrad::transport;

namespace {

enum class Blocker { None, Full, Half };

/// Receiver (patch 0) unit square at z=0 facing +z, sender (patch 1) at z=2
/// facing -z, and optionally a blocker (patch 2) in the plane z=1:
/// Full covers everything, Half covers x < 0.5 (a segment from (x1,.,0) to
/// (x2,.,2) crosses z=1 at x=(x1+x2)/2, so with x1, x2 uniform exactly half of
/// all segments are blocked, by symmetry).
scene::Scene plates(Blocker b) {
    scene::Scene sc;
    scene::Material m;
    m.rho = RGB(0.5);
    sc.addMaterial(m);
    sc.addQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, 0);
    sc.addQuad({0, 0, 2}, {0, 1, 2}, {1, 1, 2}, {1, 0, 2}, 0);
    if (b == Blocker::Full) sc.addQuad({-10, -10, 1}, {10, -10, 1}, {10, 10, 1}, {-10, 10, 1}, 0);
    if (b == Blocker::Half) sc.addTriangle({-10, -10, 1}, {0.5, -10, 1}, {0.5, 30, 1}, 0);
    return sc;
}

FormFactorSettings settings(int visRays) {
    FormFactorSettings s;
    s.rule = "gauss";
    s.points = 4;
    s.visRays = visRays;
    return s;
}

bool bitwiseEqual(const FormFactorResult& a, const FormFactorResult& b) {
    return std::memcmp(&a.F, &b.F, sizeof(double)) == 0 &&
           std::memcmp(&a.unoccludedF, &b.unoccludedF, sizeof(double)) == 0 &&
           std::memcmp(&a.visibility, &b.visibility, sizeof(double)) == 0 &&
           a.partial == b.partial && a.rays == b.rays;
}

}  // namespace

TEST(Visibility, SegmentsAndEndpointPatches) {
    scene::Scene sc = plates(Blocker::Half);
    Visibility vis(sc);
    EXPECT_GT(vis.memoryBytes(), 0u);
    // Endpoints exactly on their patches (no offsets): only the blocker counts.
    Segment through{{0.2, 0.5, 0}, {0.2, 0.5, 2}, 0, 1};
    Segment beside{{0.8, 0.5, 0}, {0.8, 0.5, 2}, 0, 1};
    EXPECT_TRUE(vis.occluded(through));
    EXPECT_FALSE(vis.occluded(beside));
    // A segment ending on the blocker itself, with the blocker as endpoint patch.
    Segment toBlocker{{0.2, 0.5, 0}, {0.2, 0.5, 1}, 0, 2};
    EXPECT_FALSE(vis.occluded(toBlocker));
    // The same segment with the wrong endpoint patch: the blocker at t = 1 is
    // beyond tfar = 1 - eps and does not count either.
    Segment toBlockerWrong{{0.2, 0.5, 0}, {0.2, 0.5, 1}, 0, 1};
    EXPECT_FALSE(vis.occluded(toBlockerWrong));
    // Passing through the sender (not an endpoint patch) blocks.
    Segment pastSender{{0.8, 0.5, 0}, {0.8, 0.5, 3}, 0, 2};
    EXPECT_TRUE(vis.occluded(pastSender));

    // A large batch (crosses the internal 256-ray batches) with known answers,
    // alternating blocked and free, with the pair ignoring per ray.
    std::vector<Segment> segs;
    std::vector<uint8_t> expect;
    for (int i = 0; i < 1000; ++i) {
        double x = (i % 2 == 0) ? 0.1 + 0.3 * (i % 7) / 7.0 : 0.6 + 0.3 * (i % 5) / 5.0;
        double y = (i % 11) / 11.0;
        if (i % 3 == 0) {
            // Ignore the blocker: receiver to blocker.
            segs.push_back({{x, y, 0}, {x, y, 1}, 0, 2});
            expect.push_back(0);
        } else {
            segs.push_back({{x, y, 0}, {x, y, 2}, 0, 1});
            expect.push_back(x < 0.5 ? 1 : 0);
        }
    }
    std::vector<uint8_t> out(segs.size(), 7);
    vis.occluded(segs.data(), segs.size(), out.data());
    for (size_t i = 0; i < segs.size(); ++i) EXPECT_EQ(out[i], expect[i]) << "segment " << i;
}

TEST(Visibility, IntersectIgnoresPatch) {
    scene::Scene sc = plates(Blocker::Full);
    Visibility vis(sc);
    RayHit h = vis.intersect({0.5, 0.5, 5}, {0, 0, -1});
    ASSERT_TRUE(h.hit);
    EXPECT_EQ(h.patch, 1u);
    EXPECT_NEAR(h.t, 3.0, 1e-5);
    h = vis.intersect({0.5, 0.5, 5}, {0, 0, -1}, 0.0, 1e300, 1);
    ASSERT_TRUE(h.hit);
    EXPECT_EQ(h.patch, 2u);
    EXPECT_NEAR(h.point.z, 1.0, 1e-5);
    h = vis.intersect({0.5, 0.5, 5}, {0, 0, -1}, 0.0, 3.5, 1);
    EXPECT_FALSE(h.hit);
    h = vis.intersect({0.5, 0.5, 5}, {0, 0, 1});
    EXPECT_FALSE(h.hit);
}

TEST(Visibility, ConcurrentQueriesAgree) {
    scene::Scene sc = plates(Blocker::Half);
    Visibility vis(sc);
    Pcg32 rng(3);
    std::vector<Segment> segs(4000);
    for (auto& s : segs)
        s = {
            {rng.nextDouble(), rng.nextDouble(), 0}, {rng.nextDouble(), rng.nextDouble(), 2}, 0, 1};
    std::vector<uint8_t> serial(segs.size());
    vis.occluded(segs.data(), segs.size(), serial.data());
    size_t blocked = 0;
    for (size_t i = 0; i < segs.size(); ++i) {
        bool ref = 0.5 * (segs[i].a.x + segs[i].b.x) < 0.5;
        // Float geometry: only segments crossing within 1e-5 of the edge may differ.
        if (std::fabs(0.5 * (segs[i].a.x + segs[i].b.x) - 0.5) > 1e-5) {
            EXPECT_EQ(serial[i], ref ? 1 : 0);
        }
        blocked += serial[i];
    }
    EXPECT_GT(blocked, 1500u);
    std::vector<uint8_t> par(segs.size());
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            for (size_t i = size_t(t) * 1000; i < size_t(t + 1) * 1000; i += 50)
                vis.occluded(segs.data() + i, 50, par.data() + i);
        });
    for (auto& th : threads) th.join();
    EXPECT_EQ(par, serial);
}

TEST(FormFactorVisibility, UnblockedPlates) {
    scene::Scene sc = plates(Blocker::None);
    Visibility vis(sc);
    FormFactorEngine eng(sc, &vis, settings(16));
    FormFactorResult r = eng.compute({0, {}, 1}, {1, {}, 2});
    EXPECT_EQ(r.visibility, 1.0);
    EXPECT_FALSE(r.partial);
    EXPECT_EQ(r.rays, 16u);
    EXPECT_EQ(r.F, r.unoccludedF);
    EXPECT_NEAR(r.F, parallelRectangles(1, 1, 2), 1e-6);
    // vis_rays = 0: no rays, visibility 1.
    FormFactorEngine eng0(sc, &vis, settings(0));
    FormFactorResult r0 = eng0.compute({0, {}, 1}, {1, {}, 2});
    EXPECT_EQ(r0.rays, 0u);
    EXPECT_EQ(r0.visibility, 1.0);
    EXPECT_EQ(r0.F, r.F);
    // Back-facing pair: F = 0, no rays.
    scene::Scene sc2 = plates(Blocker::None);
    sc2.addQuad({0, 0, 3}, {1, 0, 3}, {1, 1, 3}, {0, 1, 3}, 0);  // faces away (+z) from patch 0
    Visibility vis2(sc2);
    FormFactorEngine eng2(sc2, &vis2, settings(16));
    FormFactorResult rb = eng2.compute({0, {}, 1}, {2, {}, 3});
    EXPECT_EQ(rb.F, 0.0);
    EXPECT_EQ(rb.rays, 0u);
    EXPECT_FALSE(eng2.facing({0, {}, 1}, {2, {}, 3}));
    EXPECT_TRUE(eng2.facing({0, {}, 1}, {1, {}, 2}));
    EXPECT_EQ(eng2.upperBound({0, {}, 1}, {2, {}, 3}), 0.0);
}

TEST(FormFactorVisibility, FullyBlockedIsExactlyZero) {
    scene::Scene sc = plates(Blocker::Full);
    Visibility vis(sc);
    FormFactorEngine eng(sc, &vis, settings(64));
    for (uint64_t id = 0; id < 20; ++id) {
        FormFactorResult r = eng.compute({0, {}, id}, {1, {}, 1000 + id});
        EXPECT_EQ(r.F, 0.0);
        EXPECT_EQ(r.visibility, 0.0);
        EXPECT_FALSE(r.partial);
        EXPECT_GT(r.unoccludedF, 0.0);
        EXPECT_EQ(r.rays, 64u);
    }
}

TEST(FormFactorVisibility, HalfBlockedIsHalfOnAverage) {
    // Each pair's visibility is a stratified estimate of 1/2. Without
    // stratification each of the 16 rays is a Bernoulli(1/2) trial, so the
    // per-pair standard deviation is at most 0.125; over K = 400 id pairs the
    // mean has standard error <= 0.125/20 = 0.00625 and we allow 4 of them
    // (0.025). Every pair must be partial (all-or-nothing would need all 16
    // stratified rays on one side).
    scene::Scene sc = plates(Blocker::Half);
    Visibility vis(sc);
    FormFactorEngine eng(sc, &vis, settings(16));
    const int K = 400;
    double mean = 0.0, m2 = 0.0;
    int partial = 0;
    for (int k = 0; k < K; ++k) {
        FormFactorResult r = eng.compute({0, {}, uint64_t(k)}, {1, {}, uint64_t(100000 + k)});
        EXPECT_NEAR(r.F, r.unoccludedF * r.visibility, 1e-15);
        mean += r.visibility;
        m2 += r.visibility * r.visibility;
        partial += r.partial;
    }
    mean /= K;
    double sd = std::sqrt(std::max(0.0, m2 / K - mean * mean));
    std::cout << "[half blocker] mean visibility " << mean << ", per-pair sd " << sd
              << " (16 rays, " << K << " pairs)\n";
    EXPECT_NEAR(mean, 0.5, 0.025);
    EXPECT_EQ(partial, K);
    // More rays per pair: each single estimate is closer to 1/2.
    double v = eng.visibilityFraction({0, {}, 1}, {1, {}, 2}, 1024);
    EXPECT_NEAR(v, 0.5, 0.05);  // sd <= 0.5/sqrt(1024) = 0.016; 3 sd
}

TEST(FormFactorVisibility, DeterministicAcrossRunsThreadsAndOrder) {
    scene::Scene sc = plates(Blocker::Half);
    Visibility vis(sc);
    FormFactorEngine eng(sc, &vis, settings(37));  // not a multiple of the batch size
    const int K = 256;
    std::vector<FormFactorResult> serial(K), again(K);
    auto refs = [](int k) {
        ElementRef r{0, scene::keyDomain(scene::PatchKind::Quad, 4 + k % 4), uint64_t(k)};
        ElementRef s{1, scene::keyDomain(scene::PatchKind::Quad, 16 + k % 16), uint64_t(5000 + k)};
        return std::pair{r, s};
    };
    for (int k = 0; k < K; ++k) {
        auto [r, s] = refs(k);
        serial[k] = eng.compute(r, s);
    }
    for (int k = K - 1; k >= 0; --k) {
        auto [r, s] = refs(k);
        again[k] = eng.compute(r, s);
    }
    for (int k = 0; k < K; ++k) EXPECT_TRUE(bitwiseEqual(serial[k], again[k])) << k;
    for (int threads : {2, 3, 4}) {
        std::vector<FormFactorResult> par(K);
        std::vector<std::thread> pool;
        for (int t = 0; t < threads; ++t)
            pool.emplace_back([&, t] {
                for (int k = t; k < K; k += threads) {
                    auto [r, s] = refs(k);
                    par[k] = eng.compute(r, s);
                }
            });
        for (auto& th : pool) th.join();
        for (int k = 0; k < K; ++k)
            EXPECT_TRUE(bitwiseEqual(serial[k], par[k])) << threads << " " << k;
    }
    // Swapping receiver and sender gives bitwise the same visibility.
    for (int k = 0; k < K; k += 17) {
        auto [r, s] = refs(k);
        FormFactorResult a = eng.compute(r, s), b = eng.compute(s, r);
        EXPECT_EQ(std::memcmp(&a.visibility, &b.visibility, sizeof(double)), 0);
    }
}
