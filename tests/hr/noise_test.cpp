// The solve's own ray noise (hr/noise.h): the light each link brings adds up
// to what the solution reflects, and the noise one solve estimates of itself
// is the spread that solves with other ray seeds show.
#include "hr/noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/scenes.h"
#include "tests/test_util.h"

using namespace hrad;
using namespace hrad::hr;

namespace {
HrSettings settings(Params p) {
    HrSettings s = HrSettings::fromParams(p);
    p.reportUnused();
    return s;
}

// Sum over links of Hierarchy::linkLight against the reflected power of one
// more gather and push-pull from the same radiosities: equal up to rounding
// (`tolerance`, relative).
void expectLinkLightAddsUp(const scene::Scene& sc, Params p, const std::string& what,
                           double tolerance = 1e-9) {
    transport::Visibility vis(sc);
    HrSolver solver(sc, vis, settings(p));
    HrResult r = solver.solve();
    Hierarchy& h = *r.hierarchy;
    std::vector<RGB> reflected;
    h.linkLight(reflected);
    RGB sum(0.0);
    for (const RGB& v : reflected) sum += v;
    h.gather();
    h.pushPull();
    const RGB next = h.reflectedPower();
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(sum[c], next[c], tolerance * next[c]) << what << ", channel " << c;
    std::cout << what << ": " << h.numLinks() << " links, reflected " << next.g << " (green)\n";
}
}  // namespace

TEST(LinkLight, AddsUpToWhatTheNextIterationReflects) {
    Params cornell;
    expectLinkLightAddsUp(scene::loadScene("cornell"), cornell, "cornell");
    Params linear;
    linear.set("hr.basis", std::string("linear"));
    // A polynomial push hands a parent's higher terms to its children over
    // the parametric domain; Cornell's walls are not exact parallelograms,
    // so the leaves' areas differ from a quarter of their parent's a little
    // and the power by about 1e-6 of it, with a sign and size that depend on
    // which leaves the solve made (measured per channel: eps 1e-3 of the
    // emitted power -9.6e-7 .. 3.0e-7, of 3e-4 1.0e-6 .. 1.3e-6; under the
    // default eps power, 1e-3 -1.7e-6 .. -2.7e-7, 3e-4 1.0e-6 .. 1.4e-6).
    // The squares of the furnace below add up to 1e-9.
    expectLinkLightAddsUp(scene::loadScene("cornell"), linear, "cornell, linear basis", 3e-6);
    linear.set("oracle.eps", 1e-4);
    expectLinkLightAddsUp(test::furnaceBox(1.0, 0.5), linear, "furnace (squares), linear basis");
    // Oriented clusters: links into clusters handed over by cosine and
    // openness; the capped solve adds stand-ins, by area and handed over.
    scene::Scene office = scene::loadScene("office:2");
    for (const char* model : {"oriented", "isotropic"}) {
        Params p;
        p.set("cluster.model", std::string(model));
        expectLinkLightAddsUp(office, p, std::string("office:2, ") + model);
        p.set("hr.max_links", int64_t(20000));
        expectLinkLightAddsUp(office, p, std::string("office:2 capped, ") + model);
    }
}

// Twelve solves of Cornell with ray seeds 1..12: the spread of their
// reflected power (per channel) against the noise each estimated of itself
// (root mean square over the solves). With 64 visibility rays per estimate
// the two agree within the band below; with the default 16 the spread is
// about twice the estimate (bench/results/solver_noise.md).
TEST(SolverNoise, PredictsTheSpreadBetweenSeedsOnCornell) {
    scene::Scene sc = scene::loadScene("cornell");
    transport::Visibility vis(sc);
    const int seeds = 12;
    std::vector<RGB> power;
    RGB predicted2(0.0);
    for (int seed = 1; seed <= seeds; ++seed) {
        Params p;
        p.set("hr.seed", int64_t(seed));
        p.set("ff.vis_rays", int64_t(64));
        HrSolver solver(sc, vis, settings(p));
        HrResult r = solver.solve();
        const RGB total = r.hierarchy->reflectedPower();
        power.push_back(total);
        const RGB rel = r.noise.powerSd / total;
        predicted2 += rel * rel;
        EXPECT_GT(r.noise.links, 0u);
    }
    for (int c = 0; c < 3; ++c) {
        double mean = 0.0, var = 0.0;
        for (const RGB& v : power) mean += v[c] / seeds;
        for (const RGB& v : power) var += (v[c] - mean) * (v[c] - mean) / (seeds - 1);
        const double measured = std::sqrt(var) / mean;
        const double predicted = std::sqrt(predicted2[c] / seeds);
        std::cout << "channel " << c << ": spread between seeds " << 100 * measured
                  << " %, estimated " << 100 * predicted << " %\n";
        EXPECT_GT(measured / predicted, 0.5) << "channel " << c;
        EXPECT_LT(measured / predicted, 2.0) << "channel " << c;
    }
}

// Per root patch: the spread between seeds of the luminance of the patches
// that do not emit (area-weighted relative L2 between two solves, over
// sqrt 2, pooled over the pairs of four solves) against the direct
// per-patch figure each solve estimates (root mean square): 2.44 % against
// 1.99 % when this test was written.
TEST(SolverNoise, PerPatchSpreadOnTheClassroom) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes is absent";
    scene::Scene sc = scene::loadScene((*dir / "renderpark-mgf/salon/classroom.mgf").string());
    transport::Visibility vis(sc);
    std::vector<std::vector<double>> Y;
    double est2 = 0.0;
    const int seeds = 4;
    for (int seed = 1; seed <= seeds; ++seed) {
        Params p;
        p.set("hr.seed", int64_t(seed));
        p.set("cluster.model", std::string("oriented"));
        HrSolver solver(sc, vis, settings(p));
        HrResult r = solver.solve();
        std::vector<double> y(sc.patches.size());
        for (uint32_t q = 0; q < sc.patches.size(); ++q) y[q] = luminance(r.hierarchy->B(q));
        Y.push_back(y);
        est2 += r.noise.l2NonEmitter * r.noise.l2NonEmitter / seeds;
    }
    double num = 0.0, den = 0.0;
    int pairs = 0;
    for (int a = 0; a < seeds; ++a)
        for (int b = a + 1; b < seeds; ++b, ++pairs)
            for (uint32_t q = 0; q < sc.patches.size(); ++q) {
                if (maxComponent(sc.patches[q].emission) > 0.0) continue;
                const double d = Y[a][q] - Y[b][q];
                num += sc.patches[q].area * d * d / 2.0;
                den += sc.patches[q].area * 0.5 * (Y[a][q] * Y[a][q] + Y[b][q] * Y[b][q]);
            }
    const double measured = std::sqrt(num / den), estimated = std::sqrt(est2);
    std::cout << "per-patch spread between seeds " << 100 * measured << " %, estimated (direct) "
              << 100 * estimated << " % over " << pairs << " pairs\n";
    EXPECT_GT(measured / estimated, 0.5);
    EXPECT_LT(measured / estimated, 2.0);
}

// hr.noise_target: a solve whose own noise estimate is above the target is
// solved again with more rays, until the estimate is within it; the rays'
// growth is capped by hr.noise_max_factor, and a cap that stops it short says
// so (met = false in the summary: the returned noise stays above).
TEST(SolverNoise, TargetSolvesAgainWithMoreRaysUntilMet) {
    scene::Scene sc = scene::loadScene("cornell");
    transport::Visibility vis(sc);
    Params off;
    off.set("hr.seed", int64_t(1));
    HrResult first = HrSolver(sc, vis, settings(off)).solve();
    const double noise = first.noise.relative;
    ASSERT_GT(noise, 0.0);
    EXPECT_EQ(first.noiseRounds, 0);

    Params on = off;
    on.set("hr.noise_target", noise / 2);
    HrResult r = HrSolver(sc, vis, settings(on)).solve();
    std::cout << "noise " << noise << " -> " << r.noise.relative << " with " << r.noiseRayFactor
              << "x the rays, " << r.noiseRounds << " re-solve(s)\n";
    EXPECT_EQ(r.noiseFirst, noise);
    EXPECT_GE(r.noiseRounds, 1);
    EXPECT_GT(r.noiseRayFactor, 1.0);
    EXPECT_LE(r.noise.relative, noise / 2);

    // Capped at twice the rays: one re-solve, and the target (a hundredth)
    // is not met.
    Params capped = off;
    capped.set("hr.noise_target", noise / 100);
    capped.set("hr.noise_max_factor", 2.0);
    HrResult c = HrSolver(sc, vis, settings(capped)).solve();
    EXPECT_EQ(c.noiseRounds, 1);
    EXPECT_EQ(c.noiseRayFactor, 2.0);
    EXPECT_GT(c.noise.relative, noise / 100);

    // A solve stopped early (here by hr.max_links) is not solved again.
    Params stopped = capped;
    stopped.set("hr.noise_max_factor", 64.0);
    stopped.set("hr.max_links", int64_t(2000));
    HrResult t = HrSolver(sc, vis, settings(stopped)).solve();
    EXPECT_TRUE(t.linkCapHit);
    EXPECT_GT(t.noise.relative, noise / 100);
    EXPECT_EQ(t.noiseRounds, 0);
}
