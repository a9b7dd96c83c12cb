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
#include "tests/scenes.h"
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

// The two sides of a sheet: a label facing +y lies on a larger face of
// opposite normal in the same plane (graz.mgf: a binder's spine label on the
// spine's inner face). A face in the plane of a segment's end point never
// blocks, so the label and a point in front of it see each other whichever
// end the ray starts from, and whichever face has the lower index. A nearest
// hit arriving from the front meets the label, not the back of the other
// face at the same depth.
TEST(Visibility, TheOtherSideOfASheetBlocksNeitherWay) {
    for (bool labelFirst : {true, false}) {
        scene::Scene s;
        uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
        auto label = [&] {
            test::addQuadFacing(s, Vec3(-0.2, 0, -0.3), Vec3(0.2, 0, -0.3), Vec3(0.2, 0, 0.3),
                                Vec3(-0.2, 0, 0.3), m, Vec3(0, 1, 0));
            return uint32_t(s.patches.size() - 1);
        };
        auto spine = [&] {
            test::addQuadFacing(s, Vec3(-0.5, 0, -0.5), Vec3(0.5, 0, -0.5), Vec3(0.5, 0, 0.5),
                                Vec3(-0.5, 0, 0.5), m, Vec3(0, -1, 0));
            return uint32_t(s.patches.size() - 1);
        };
        uint32_t l = 0, sp = 0;
        if (labelFirst) {
            l = label();
            sp = spine();
        } else {
            sp = spine();
            l = label();
        }
        // A lamp-like patch in front of the label, so segments have two end patches.
        test::addQuadFacing(s, Vec3(-1, 2, -1), Vec3(1, 2, -1), Vec3(1, 2, 1), Vec3(-1, 2, 1), m,
                            Vec3(0, 0, 0));
        const uint32_t lamp = uint32_t(s.patches.size() - 1);
        Visibility vis(s);
        Pcg32 rng(3);
        int blocked = 0;
        for (int i = 0; i < 256; ++i) {
            Vec3 x = s.patches[l].point(rng.nextDouble(), rng.nextDouble());
            Vec3 y = s.patches[lamp].point(rng.nextDouble(), rng.nextDouble());
            blocked += vis.occluded(Segment{x, y, l, lamp});
            blocked += vis.occluded(Segment{y, x, lamp, l});
            // From the label into its hemisphere: the lamp, not the spine at t = 0.
            RayHit out = vis.intersect(x, y - x, 0.0, 1e300, l);
            ASSERT_TRUE(out.hit);
            EXPECT_EQ(out.patch, lamp);
            // From the lamp to the label: the label, not the spine's back.
            RayHit in = vis.intersect(y, x - y, 0.0, 1e300, lamp);
            ASSERT_TRUE(in.hit);
            EXPECT_EQ(in.patch, l) << "label first " << labelFirst;
            EXPECT_NEAR(in.t, 1.0, 1e-5);
        }
        EXPECT_EQ(blocked, 0) << "label first " << labelFirst;
        // Behind the sheet, the spine's side sees a point below it; the label
        // stands in the way of nothing there either, and a segment crossing
        // the sheet away from its end points is blocked by it.
        Vec3 below(0.1, -1, 0.05);
        Vec3 onSpine = s.patches[sp].point(0.9, 0.9);
        EXPECT_FALSE(vis.occluded(Segment{onSpine, below, sp, UINT32_MAX}));
        EXPECT_TRUE(vis.occluded(Segment{Vec3(0, 1, 0), below, UINT32_MAX, UINT32_MAX}));
    }
}

// Two floor tiles sharing an edge, a wall standing on the edge's far side:
// a segment from a point on the shared edge (it belongs to tile A) is not
// blocked by tile B, in the same plane; the wall, in another plane, still
// closes the room behind it.
TEST(Visibility, ATileBesideTheEndPointDoesNotBlockAWallDoes) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    s.addQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m);  // tile A, facing +z
    s.addQuad({1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, m);  // tile B
    test::addQuadFacing(s, Vec3(2, -1, 0), Vec3(2, 2, 0), Vec3(2, 2, 2), Vec3(2, -1, 2), m,
                        Vec3(0, 0, 1));  // a wall at x = 2
    ASSERT_GT(s.patches[0].normal.z, 0.0);
    Visibility vis(s);
    Pcg32 rng(5);
    int blocked = 0, walled = 0;
    for (int i = 0; i < 256; ++i) {
        Vec3 edge(1.0, rng.nextDouble(), 0.0);
        Vec3 up(rng.nextDouble() * 1.9, rng.nextDouble(), 0.2 + rng.nextDouble());
        blocked += vis.occluded(Segment{edge, up, 0, UINT32_MAX});
        blocked += vis.occluded(Segment{up, edge, UINT32_MAX, 0});
        Vec3 behind(3.0, rng.nextDouble(), 0.5 + rng.nextDouble());
        Vec3 floor(1.999, rng.nextDouble(), 0.0);
        walled += vis.occluded(Segment{floor, behind, 1, UINT32_MAX});
    }
    EXPECT_EQ(blocked, 0);
    EXPECT_EQ(walled, 256);
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
