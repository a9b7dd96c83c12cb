// Relaxation of the few patches that carry an iteration's change
// (hr.relax_share, hr/solver.h "Relaxation"): two plates of reflectance 0.99
// facing each other a hundredth of their width apart, in a lit room. Light
// enters the gap only at its edges and bounces between the plates, whose
// pair gives the gather iteration a mode of ratio about -0.97 (the light
// alternates from one plate to the other) under the room's fast ones; the
// Jacobi iteration crawls and the one-step extrapolation never sees a steady
// ratio. Relaxing the two plates alone must reach the same solution in far
// fewer iterations.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "hr/solver.h"
#include "tests/scenes.h"
#include "transport/visibility.h"

namespace hrad {
namespace {

constexpr int kGrid = 6;  // 6 x 6 quads per wall: 216 + 4 patches

/// The room [0,1]^3 facing inwards, each wall a kGrid x kGrid grid, the four
/// central ceiling quads emitting; the plates [0.3,0.7]^2 at z 0.300 (facing
/// up) and 0.304 (facing down), each with a backing of reflectance 0.5 1 cm
/// behind it facing away.
scene::Scene gapRoom() {
    scene::Scene s;
    s.name = "gap-room";
    const uint32_t wall = s.addMaterial({"wall", RGB(0.5), RGB(0.0)});
    const uint32_t lamp = s.addMaterial({"lamp", RGB(0.5), RGB(1.0)});
    const uint32_t mirror = s.addMaterial({"mirror", RGB(0.99), RGB(0.0)});
    const Vec3 centre(0.5);
    // Face f spanned by axes (u, v) at fixed coordinate w = 0 or 1.
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int i = 0; i < kGrid; ++i) {
                for (int j = 0; j < kGrid; ++j) {
                    auto P = [&](int di, int dj) {
                        Vec3 p(0.0);
                        p[axis] = side;
                        p[u] = double(i + di) / kGrid;
                        p[v] = double(j + dj) / kGrid;
                        return p;
                    };
                    const bool central = i >= 2 && i <= 3 && j >= 2 && j <= 3;
                    const uint32_t m = axis == 2 && side == 1 && central ? lamp : wall;
                    test::addQuadFacing(s, P(0, 0), P(1, 0), P(1, 1), P(0, 1), m, centre);
                }
            }
        }
    }
    auto plate = [&](double z, double towards, uint32_t m) {
        test::addQuadFacing(s, Vec3(0.3, 0.3, z), Vec3(0.7, 0.3, z), Vec3(0.7, 0.7, z),
                            Vec3(0.3, 0.7, z), m, Vec3(0.5, 0.5, z + towards));
    };
    plate(0.300, +1, mirror);
    plate(0.290, -1, wall);
    plate(0.304, -1, mirror);
    plate(0.314, +1, wall);
    s.applyMaterials();
    return s;
}

hr::HrResult solve(const scene::Scene& s, const transport::Visibility& vis, double relaxShare,
                   bool extrapolate, double tolerance, int maxIterations) {
    Params p;
    p.set("hr.oracle", std::string("uniform"));  // the same links whatever B is
    p.set("oracle.level", int64_t(0));
    p.set("cluster.model", std::string("none"));
    p.set("hr.relax_share", relaxShare);
    p.set("hr.extrapolate", extrapolate);
    p.set("hr.tolerance", tolerance);
    p.set("hr.max_iterations", int64_t(maxIterations));
    hr::HrSettings settings = hr::HrSettings::fromParams(p);
    p.reportUnused();
    return hr::HrSolver(s, vis, settings).solve();
}

TEST(Relaxation, TheGapBetweenTwoMirrorsConvergesFast) {
    scene::Scene s = gapRoom();
    ASSERT_EQ(s.patches.size(), 220u);
    transport::Visibility vis(s);
    // The fixed point, to a change of 1e-11 per iteration: Jacobi alone.
    hr::HrResult exact = solve(s, vis, 0.0, false, 1e-11, 5000);
    ASSERT_TRUE(exact.converged);
    hr::HrResult plain = solve(s, vis, 0.0, true, 1e-4, 1000);
    hr::HrResult relaxed = solve(s, vis, 0.8, true, 1e-4, 1000);
    ASSERT_TRUE(plain.converged);
    ASSERT_TRUE(relaxed.converged);
    // The plates are the patches relaxed, alone.
    bool relaxedPlates = false;
    for (const hr::IterationRecord& it : relaxed.history) {
        if (it.relaxedPatches == 0) continue;
        EXPECT_LE(it.relaxedPatches, 2u);
        EXPECT_GT(it.relaxSweeps, 0);
        relaxedPlates = true;
    }
    EXPECT_TRUE(relaxedPlates);
    for (const hr::IterationRecord& it : plain.history) EXPECT_EQ(it.relaxedPatches, 0u);
    std::printf("iterations: exact %zu, plain %zu, relaxed %zu\n", exact.history.size(),
                plain.history.size(), relaxed.history.size());
    // Far fewer iterations for the same answer.
    EXPECT_LT(10 * relaxed.history.size(), plain.history.size())
        << relaxed.history.size() << " against " << plain.history.size();
    const RGB pe = exact.hierarchy->reflectedPower();
    std::printf("reflected power / exact: plain %.6f relaxed %.6f\n",
                plain.hierarchy->reflectedPower().g / pe.g,
                relaxed.hierarchy->reflectedPower().g / pe.g);
    const RGB pr = relaxed.hierarchy->reflectedPower();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(pr[c] / pe[c], 1.0, 1e-4) << c;
    // And the plates themselves (the mirror sides: patches 216 and 218).
    for (uint32_t p : {216u, 218u}) {
        const double be = exact.hierarchy->B(p).g, br = relaxed.hierarchy->B(p).g;
        EXPECT_NEAR(br / be, 1.0, 1e-3) << p;
    }
}

// A relaxation may read as many links as one iteration does. With oriented
// clusters the push reads each link into a cluster once for every surface
// below it, so the budget counts those reads, walked here patch by patch.
TEST(Relaxation, TheBudgetCountsTheLinksThePushReads) {
    scene::Scene s = gapRoom();
    transport::Visibility vis(s);
    for (const char* model : {"oriented", "isotropic"}) {
        Params p;
        p.set("cluster.model", std::string(model));
        p.set("hr.max_iterations", int64_t(3));
        hr::HrSettings settings = hr::HrSettings::fromParams(p);
        hr::HrResult res = hr::HrSolver(s, vis, settings).solve();
        const hr::Hierarchy& h = *res.hierarchy;
        uint64_t intoClusters = 0, reads = h.numLinks();
        for (uint32_t e = 0; e < h.numElements(); ++e)
            if (h.isCluster(e)) intoClusters += h.linkEnd(e) - h.linkBegin(e);
        ASSERT_GT(intoClusters, 0u) << model;
        if (std::string(model) == "oriented")
            for (uint32_t root = 0; root < h.numPatches(); ++root)
                for (uint32_t c = h.parent(root); c != hr::kNone; c = h.parent(c))
                    reads += h.linkEnd(c) - h.linkBegin(c);
        EXPECT_EQ(h.iterationLinkReads(), reads) << model;
    }
}

}  // namespace
}  // namespace hrad
