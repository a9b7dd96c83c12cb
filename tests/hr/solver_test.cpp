// The hierarchical solver on analytic and closed scenes, for every oracle.
#include "hr/solver.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>

#include "core/memory.h"
#include "scene/builtin.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"

using namespace hrad;
using namespace hrad::hr;

namespace {
HrSettings settingsFor(const std::string& oracle, double eps) {
    return test::hrSettings(oracle, eps, "none", 1e-4);
}
}  // namespace

class FurnaceAllOracles : public ::testing::TestWithParam<std::string> {};

// Closed box, uniform E and rho: B = E / (1 - rho) everywhere.
//
// With the `uniform` oracle every leaf gathers from a partition of the box at
// its own level, and the rows of exact form factors sum to one, so every
// element must match to 1e-3 (it does to ~1e-7).
//
// A leaf also gathers through the links of its ancestors, whose coefficients
// are averages over the larger receiver. The error oracles (`error`, `kv`)
// judge a receiver by the error of all its links together
// (hr/receiver_error.h): in a closed box the point form factors to all
// senders sum to one at every point, so nothing needs refining and the
// solve stays exact (L1 <= 0.5 %; per-link criteria gave 7.1 % and 7.5 % at
// eps 1e-3). `bfa` and `ff` judge links one by one, by power or form factor:
// links accepted on coarse receivers next to finely linked walls add up. As
// published (hr.receiver_eps = off) bfa leaves 11 % of the reflected
// radiosity wrong at eps 1e-3 and 8.7 % at 1e-4, and ff diverges at rho 0.9.
// With the receiver check (hr.receiver_eps = auto, the default) both are
// held by the receivers' aggregate error too: bfa within 1 % of the
// reflected radiosity at eps 1e-3 and 1e-4, ff converges at rho 0.9. The
// check holds each receiver, not the sum over the leaves; the balanced leaf
// budget (hr.leaf_budget, the default) holds the sum too, which brings bfa
// at eps 1e-2 and ff at F_eps 0.1 within 1 % (issue 10, item 2).
// The error is over the reflected radiosity B - E, per leaf.
namespace {
struct FurnaceRun {
    double worst = 0, l1 = 0;
    uint64_t links = 0, elements = 0, patches = 0;
    double estimateLeaves = 0, estimatePoints = 0, estimate = 0;
};
using LeafBudget = HrSettings::LeafBudget;
FurnaceRun runFurnace(const std::string& oracle, double eps, double rho, double receiverEps = -1,
                      LeafBudget leafBudget = HrSettings{}.leafBudget) {
    scene::Scene s = test::furnaceBox(1.0, rho);
    transport::Visibility vis(s);
    HrSettings st = settingsFor(oracle, eps);
    st.receiverEps = receiverEps;
    st.leafBudget = leafBudget;
    // The Jacobi gather converges like rho^n: rho 0.9 needs ~150 iterations
    // for the tolerance 1e-7 of these tests.
    st.maxIterations = 400;
    HrSolver solver(s, vis, st);
    HrResult r = solver.solve();
    EXPECT_TRUE(r.converged);
    const Hierarchy& h = *r.hierarchy;
    const double exact = 1.0 / (1.0 - rho);
    FurnaceRun out;
    double area = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e)) continue;
        double d = 0;
        for (int c = 0; c < 3; ++c) d = std::max(d, std::fabs(h.B(e)[c] - exact) / (exact - 1.0));
        out.worst = std::max(out.worst, d);
        out.l1 += h.area(e) * d;
        area += h.area(e);
    }
    out.l1 /= area;
    out.estimateLeaves = r.errorEstimateLeaves;
    out.estimatePoints = r.errorEstimatePoints;
    out.estimate = r.errorEstimate;
    out.links = h.numLinks();
    out.elements = h.numElements();
    out.patches = h.numPatches();
    std::cout << oracle << " eps " << eps << " rho " << rho << " receiver_eps " << receiverEps
              << " leaf budget "
              << (leafBudget == LeafBudget::Off    ? "off"
                  : leafBudget == LeafBudget::Full ? "full"
                                                   : "balanced")
              << ": elements " << out.elements
              << ", links " << out.links
              << ", worst relative error " << out.worst << ", L1 " << out.l1
              << ", estimates: leaves " << out.estimateLeaves << ", points " << out.estimatePoints
              << ", receivers " << out.estimate << "\n";
    return out;
}
}  // namespace

TEST_P(FurnaceAllOracles, RadiosityIsEOverOneMinusRho) {
    const std::string oracle = GetParam();
    if (oracle == "uniform") {
        EXPECT_LT(runFurnace(oracle, 0.0, 0.5).worst, 1e-3);
        return;
    }
    if (oracle == "error" || oracle == "kv") {
        for (double rho : {0.5, 0.9})
            for (double eps : {1e-3, 1e-4}) {
                FurnaceRun f = runFurnace(oracle, eps, rho);
                EXPECT_LT(f.l1, 0.005) << "rho " << rho << " eps " << eps;
                EXPECT_LE(f.links, 20000u);
            }
        return;
    }
    if (oracle == "bfa") {
        // At the defaults (receiver check and balanced leaf budget), measured
        // reflected L1 per leaf, rho 0.5: 0.49 % (1,785 links), 0.076 %
        // (27 k) and 0.0055 % (326 k) at eps 1e-2, 1e-3 and 1e-4; rho 0.9,
        // eps 1e-3: 0.007 % (131 k). Without the budget: 1.30 %, 0.99 % (19 k)
        // and 0.72 % (165 k); link by link as published (hr.receiver_eps =
        // off), eps 1e-3: 11.3 % (2,208).
        double coarser = 1.0;
        for (double eps : {1e-2, 1e-3, 1e-4}) {
            FurnaceRun c = runFurnace(oracle, eps, 0.5);
            EXPECT_GT(c.elements, c.patches) << "the oracle refined nothing";
            EXPECT_LT(c.l1, std::min(0.01, 2.0 * eps)) << "eps " << eps;
            EXPECT_LT(c.l1, coarser) << "eps " << eps << ": the error must fall with eps";
            coarser = c.l1;
        }
        EXPECT_LT(runFurnace(oracle, 1e-3, 0.9).l1, 0.01);
        // The receiver check alone leaves eps 1e-2 above 1 %.
        EXPECT_GT(runFurnace(oracle, 1e-2, 0.5, -1, LeafBudget::Off).l1, 0.01);
        // As published, link by link: several per cent (the check's reason).
        EXPECT_GT(runFurnace(oracle, 1e-3, 0.5, 0.0, LeafBudget::Off).l1, 0.05);
        return;
    }
    // ff: its eps is a form factor; the check's follows it (F_eps / 100 of
    // the emitted power), and so does the leaf budget, which keeps the
    // gather from diverging at rho 0.9 (as published: reflected power 90
    // times the exact value at the 100-iteration cap). Measured per leaf
    // (minimum area 1e-4 of the box) at the defaults: F_eps 0.1, rho 0.5
    // 0.067 % (135 k links), rho 0.9 0.015 % (283 k); F_eps 0.02, rho 0.5
    // 0.016 % (533 k); with the receiver check alone, rho 0.5: 3.5 % at 0.1
    // (31 k) and 1.2 % at 0.02.
    for (double rho : {0.5, 0.9}) {
        FurnaceRun f = runFurnace(oracle, 0.1, rho);
        EXPECT_GT(f.elements, f.patches) << "the oracle refined nothing";
        EXPECT_LT(f.l1, 0.01) << "rho " << rho;
        if (rho == 0.5) {
            // The error falls with ff's eps (the budget's is F_eps / 100).
            FurnaceRun g = runFurnace(oracle, 0.02, rho);
            EXPECT_LT(g.l1, 0.5 * f.l1);
        }
    }
    EXPECT_GT(runFurnace(oracle, 0.1, 0.5, -1, LeafBudget::Off).l1, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Oracles, FurnaceAllOracles,
                         ::testing::Values("bfa", "ff", "uniform", "error", "kv"));

// The error of the leaves' averages, estimated after the solve
// (hr/receiver_error.h leafAverageError: the push of each ancestor link to
// each leaf, signed, summed over links). In the furnace the exact irradiance
// is the same at every point, so the error of a leaf is its coefficients'
// sum less one, which the estimate takes link by link with the point form
// factors at the leaf's own points: one bounce of the error, against the
// solution's error per leaf. Measured (rho 0.5): bfa 1e-2 estimate 1.30 %
// against 1.30 %, 1e-3 0.93 % against 0.99 %; the receiver-by-receiver
// error_estimate, which adds each receiver's range, gave 3-5 times the
// error. Unrefined (error oracle, 30 links) the furnace is exact and so is
// the estimate.
// hr.leaf_budget: the receivers whose links make most of the leaves' error
// (the estimate below) have their links pushed down until that estimate is
// within the check's eps of the emitted power (bfa: eps; ff: F_eps / 100),
// which in the furnace (rho 0.5: emitted = reflected power) is the one-bounce
// reflected L1; the solution's error may be up to 1 / (1 - rho) of it.
// Measured per leaf, full / balanced: bfa 1e-2 0.98 % / 0.49 % (1,650 /
// 1,785 links; without the budget 1.30 %, 1,560), bfa 1e-3 0.097 % / 0.076 %
// (29 k / 27 k; 0.99 %, 19 k), ff 0.1 0.12 % / 0.067 % (108 k / 135 k;
// 3.5 %, 31 k): issue 10's "within 1 % for every adaptive oracle" at every
// eps.
TEST(HrSolver, LeafBudgetHoldsTheFurnaceWithinEps) {
    struct Case {
        std::string oracle;
        double eps, leafEps;
        bool overWithout;  // the solve without the budget is over 1 %
    };
    for (const Case& c : {Case{"bfa", 1e-2, 1e-2, true}, Case{"bfa", 1e-3, 1e-3, false},
                          Case{"ff", 0.1, 1e-3, true}}) {
        // Full: judged in every pass. Balanced (the default): judged where
        // the solve would converge, against the larger of eps and the error
        // inside the leaves, which in the furnace (the irradiance is flat
        // over every leaf) is nil: it holds the same budget.
        for (LeafBudget mode : {LeafBudget::Full, LeafBudget::Balanced}) {
            FurnaceRun with = runFurnace(c.oracle, c.eps, 0.5, -1, mode);
            EXPECT_GT(with.elements, with.patches) << "the oracle refined nothing";
            EXPECT_LT(with.estimateLeaves, c.leafEps) << c.oracle << " " << c.eps;
            EXPECT_LT(with.l1, std::min(0.01, 2.0 * c.leafEps)) << c.oracle << " " << c.eps;
        }
        if (c.overWithout) {
            FurnaceRun without = runFurnace(c.oracle, c.eps, 0.5, -1, LeafBudget::Off);
            EXPECT_GT(without.l1, 0.01) << c.oracle << " " << c.eps << ": nothing to hold";
        }
    }
}

// The balanced leaf budget (the default) allows eps beyond the error inside
// the leaves. On Cornell under bfa 1e-3 that inside error is most of the
// pointwise estimate (error_estimate_leaves 0.017 against _points 0.043 at
// the study's settings), so the budget holds without a push: the same links
// as without it, and its last pass is the final estimate. The full budget
// on the same solve pushes (it would fail the first expectation).
TEST(HrSolver, BalancedLeafBudgetLeavesCornellAlone) {
    scene::Scene s = scene::makeBuiltin("cornell");
    transport::Visibility vis(s);
    auto solve = [&](LeafBudget mode) {
        HrSettings st = test::hrSettings("bfa", 1e-3, "none", 1e-4);
        st.leafBudget = mode;
        HrSolver solver(s, vis, st);
        return solver.solve();
    };
    HrResult off = solve(LeafBudget::Off), balanced = solve(LeafBudget::Balanced),
             full = solve(LeafBudget::Full);
    ASSERT_GT(off.hierarchy->numLinks(), 0u);
    EXPECT_EQ(balanced.hierarchy->numLinks(), off.hierarchy->numLinks());
    EXPECT_GT(full.hierarchy->numLinks(), off.hierarchy->numLinks());
    // The reused totals are the estimate computed afresh (summed in the same
    // order: to the last bits).
    EXPECT_DOUBLE_EQ(balanced.errorEstimateLeaves, off.errorEstimateLeaves);
    EXPECT_DOUBLE_EQ(balanced.errorEstimatePoints, off.errorEstimatePoints);
    EXPECT_GT(off.errorEstimatePoints, 2.0 * off.errorEstimateLeaves);
    for (int c = 0; c < 3; ++c)
        EXPECT_DOUBLE_EQ(balanced.hierarchy->reflectedPower()[c],
                         off.hierarchy->reflectedPower()[c]);
}

TEST(HrSolver, LeafBudgetSettingTakesAModeOrABool) {
    auto mode = [](auto v) {
        Params p;
        p.set("hr.leaf_budget", v);
        return HrSettings::fromParams(p).leafBudget;
    };
    EXPECT_EQ(HrSettings{}.leafBudget, LeafBudget::Balanced);
    EXPECT_EQ(mode(std::string("balanced")), LeafBudget::Balanced);
    EXPECT_EQ(mode(std::string("full")), LeafBudget::Full);
    EXPECT_EQ(mode(std::string("off")), LeafBudget::Off);
    EXPECT_EQ(mode(true), LeafBudget::Full);
    EXPECT_EQ(mode(false), LeafBudget::Off);
    EXPECT_THROW(mode(std::string("maybe")), std::exception);
    EXPECT_THROW(mode(int64_t(1)), std::exception);
}

TEST(HrSolver, LeafErrorEstimateMatchesTheFurnace) {
    for (double eps : {1e-2, 1e-3}) {
        FurnaceRun f = runFurnace("bfa", eps, 0.5, -1, LeafBudget::Off);
        ASSERT_GT(f.l1, 1e-3) << "eps " << eps << ": nothing to estimate";
        EXPECT_NEAR(f.estimateLeaves / f.l1, 1.0, 0.1) << "eps " << eps;
        // Within a leaf the furnace's irradiance is constant: the pointwise
        // estimate adds nothing to the leaves' averages.
        EXPECT_NEAR(f.estimatePoints, f.estimateLeaves, 0.02 * f.estimateLeaves);
    }
    FurnaceRun exact = runFurnace("error", 1e-3, 0.5);
    EXPECT_LT(exact.l1, 1e-5);
    EXPECT_LT(exact.estimateLeaves, 1e-5);
    // The pointwise estimate keeps the difference between the Simpson mean of
    // the 16-bit kernel samples and the quadrature of K (1.1e-5 here).
    EXPECT_LT(exact.estimatePoints, 1e-4);
}

// The form-factor interval the solver gives bound-reading oracles (error, kv)
// on real links: it contains the link's F, is [0, Fmax] for partially visible
// links, and is only evaluated when asked for.
TEST(HrSolver, LinkEstimateBracketsTheFormFactor) {
    scene::Scene s = test::closedRoom();  // the block makes partially visible links
    transport::Visibility vis(s);
    HrSolver solver(s, vis, settingsFor("bfa", 1e-3));
    HrResult r = solver.solve();
    const Hierarchy& h = *r.hierarchy;
    uint64_t links = 0, partial = 0, varying = 0, positiveMin = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        for (uint64_t i = h.linkBegin(e); i < h.linkEnd(e); ++i) {
            const Link& l = h.link(i);
            oracles::LinkEstimate plain = solver.linkEstimate(h, e, l, false);
            EXPECT_EQ(plain.Fmin, 0.0);  // the defaults: not evaluated
            EXPECT_EQ(plain.Fmax, 1.0);
            oracles::LinkEstimate b = solver.linkEstimate(h, e, l, true);
            EXPECT_EQ(b.F, plain.F);
            ASSERT_LE(b.Fmin, b.F) << "link " << i;
            ASSERT_GE(b.Fmax, b.F) << "link " << i;
            // The point form factor never exceeds 1 (rule "gauss": exact
            // point-to-polygon values).
            EXPECT_LE(b.Fmax, 1.0);
            if (b.partialVisibility) {
                EXPECT_EQ(b.Fmin, 0.0);
                ++partial;
            }
            if (b.Fmax > b.F * (1 + 1e-6)) ++varying;
            if (b.Fmin > 0.0) ++positiveMin;
            ++links;
        }
    }
    std::cout << links << " links: " << partial << " partially visible, " << varying
              << " with Fmax > F, " << positiveMin << " with Fmin > 0\n";
    EXPECT_GT(partial, 0u);
    EXPECT_GT(varying, links / 2);
    EXPECT_GT(positiveMin, links / 4);
}

// In a closed scene all emitted power is eventually absorbed:
// sum_k A_k E_k = sum_k A_k (1 - rho_k) H_k with H_k = (B_k - E_k) / rho_k.
TEST(HrSolver, EnergyBalanceInClosedScene) {
    scene::Scene s = test::closedRoom();
    transport::Visibility vis(s);
    // The mean over ray seeds 0-6: one solve's own noise moves the balance
    // by about 4e-4 (0.9966-0.9976 of emitted, green); the bound below
    // allows three standard errors of that mean besides the 3e-3.
    const int seeds = 7;
    RGB absorbed(0.0), absorbed2(0.0);
    for (int seed = 0; seed < seeds; ++seed) {
        Params p;
        p.set("oracle.eps", 1e-4);
        p.set("hr.tolerance", 1e-8);
        p.set("hr.seed", int64_t(seed));
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        HrResult r = solver.solve();
        const Hierarchy& h = *r.hierarchy;
        RGB one(0.0);
        for (uint32_t e = 0; e < h.numElements(); ++e) {
            if (!h.isLeaf(e)) continue;
            const auto& patch = s.patches[h.patch(e)];
            for (int c = 0; c < 3; ++c)
                one[c] += h.area(e) * (1 - patch.rho[c]) * (h.B(e)[c] - patch.emission[c]) /
                          patch.rho[c];
        }
        for (int c = 0; c < 3; ++c) {
            absorbed[c] += one[c] / seeds;
            absorbed2[c] += one[c] * one[c] / seeds;
        }
    }
    RGB emitted = s.emittedPower();
    for (int c = 0; c < 3; ++c) {
        const double se = std::sqrt(
            std::max(0.0, absorbed2[c] - absorbed[c] * absorbed[c]) / (seeds - 1));
        std::cout << "channel " << c << ": emitted " << emitted[c] << " absorbed " << absorbed[c]
                  << " +- " << se << "\n";
        // Measured at eps 1e-4 (ff.vis_sampling = solid_angle, 2026-12-04):
        // 0.99701 / 0.99696 / 0.99746 of emitted over seeds 0-6, 0.99679 /
        // 0.99673 / 0.99725 over seeds 7-13 (area-uniform visibility rays:
        // 0.99720 / 0.99715 / 0.99758 and 0.99739 / 0.99734 / 0.99776, their
        // +0.3 % bias on small partly visible element pairs,
        // FormFactor.SolidAngleVisibilityIsUnbiasedInAClosedRoom and
        // papers/notes/2026-12-02-modern-hall-light.md section 12, offsetting
        // part of the loss). Hierarchical radiosity is not exactly
        // conservative: a subdivided sender's average leaves through links
        // whose coverage differs across its parts (hr/receiver_error.h
        // SenderTotal), and the receiver-side quadrature of near links breaks
        // reciprocity; both shrink with eps. The full-matrix solver meets
        // 1e-3 (tests/reference).
        EXPECT_NEAR(absorbed[c], emitted[c], 3e-3 * emitted[c] + 3.0 * se);
    }
}

TEST(HrSolver, BitwiseIdenticalForOneAndTwoThreads) {
    scene::Scene s = test::closedRoom();
    transport::Visibility vis(s);
    Params p;
    p.set("oracle.eps", 5e-4);
    HrSettings settings = HrSettings::fromParams(p);
    auto run = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
        HrSolver solver(s, vis, settings);
        return solver.solve();
    };
    HrResult a = run(1), b = run(2);
    const Hierarchy &ha = *a.hierarchy, &hb = *b.hierarchy;
    ASSERT_EQ(ha.numElements(), hb.numElements());
    ASSERT_EQ(ha.numLinks(), hb.numLinks());
    for (uint32_t e = 0; e < ha.numElements(); ++e)
        ASSERT_EQ(std::memcmp(&ha.B(e), &hb.B(e), sizeof(RGB)), 0) << "element " << e;
    for (uint64_t i = 0; i < ha.numLinks(); ++i)
        ASSERT_EQ(std::memcmp(&ha.link(i), &hb.link(i), sizeof(Link)), 0) << "link " << i;
}

// Stopping: at rho 0.99 the change per iteration is 1 % of what is still to
// come. Without extrapolation the solve used to stop on a change below 1e-4
// with the reflected power 1.0 % below E/(1-rho) - E; the tail estimate keeps
// it iterating until the estimated remaining error is below the tolerance.
TEST(HrSolver, StopsOnTheIterationErrorNotOnTheChange) {
    scene::Scene s = test::furnaceBox(1.0, 0.99);
    transport::Visibility vis(s);
    Params p;
    p.set("hr.oracle", std::string("error"));
    p.set("oracle.eps", 1e-3);
    p.set("hr.extrapolate", false);
    p.set("hr.max_iterations", int64_t(5000));
    HrSolver solver(s, vis, HrSettings::fromParams(p));
    HrResult r = solver.solve();
    ASSERT_TRUE(r.converged);
    const double exact = 6.0 * (1.0 / (1.0 - 0.99) - 1.0);  // reflected power, unit cube
    double got = r.hierarchy->reflectedPower().r;
    std::cout << "iterations " << r.history.size() << ", reflected " << got << " (exact " << exact
              << "), iteration error " << r.history.back().iterationError << "\n";
    EXPECT_LT(r.history.back().iterationError, 1e-4);
    EXPECT_NEAR(got, exact, 2e-4 * exact);
}

// Gauss-Seidel sweeps reach the same solution as Jacobi, in fewer iterations
// when the hierarchy is fixed (uniform oracle), bitwise identically for one
// and two threads.
TEST(HrSolver, GaussSeidelSameAnswerFewerIterations) {
    scene::Scene s = test::closedRoom();
    transport::Visibility vis(s);
    auto settings = [&](const char* iteration) {
        Params p;
        p.set("hr.oracle", std::string("uniform"));
        p.set("oracle.level", int64_t(2));
        p.set("hr.extrapolate", false);
        p.set("hr.tolerance", 1e-7);
        p.set("hr.iteration", std::string(iteration));
        return HrSettings::fromParams(p);
    };
    HrSolver jacobi(s, vis, settings("jacobi"));
    HrResult j = jacobi.solve();
    auto run = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
        HrSolver gs(s, vis, settings("gauss-seidel"));
        return gs.solve();
    };
    HrResult g = run(2), g1 = run(1);
    ASSERT_TRUE(j.converged);
    ASSERT_TRUE(g.converged);
    std::cout << "iterations: jacobi " << j.history.size() << ", gauss-seidel " << g.history.size()
              << "\n";
    EXPECT_LT(g.history.size() * 3, j.history.size() * 2);
    RGB pj = j.hierarchy->reflectedPower(), pg = g.hierarchy->reflectedPower();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(pg[c], pj[c], 1e-5 * pj[c]);
    const Hierarchy &ha = *g.hierarchy, &hb = *g1.hierarchy;
    ASSERT_EQ(ha.numElements(), hb.numElements());
    for (uint32_t e = 0; e < ha.numElements(); ++e)
        ASSERT_EQ(std::memcmp(&ha.B(e), &hb.B(e), sizeof(RGB)), 0) << "element " << e;
}

TEST(HrSettings, RejectsBadSettings) {
    Params p;
    p.set("hr.oracle", std::string("nope"), {"study.toml", 3});
    EXPECT_THROW(HrSettings::fromParams(p), InputError);
    Params q;
    q.set("oracle.epsilon", 1e-3, {"study.toml", 4});
    EXPECT_THROW(HrSettings::fromParams(q), InputError);
    Params r;
    r.set("hr.eps_schedule", std::string("1e-3,1e-2"), {"study.toml", 5});
    EXPECT_THROW(HrSettings::fromParams(r), InputError);
    // The error oracles read oracle.eps / norm / min_area and nothing else.
    Params t;
    t.set("hr.oracle", std::string("error"));
    t.set("oracle.use_bound", true, {"study.toml", 6});
    EXPECT_THROW(HrSettings::fromParams(t), InputError);
    Params u;
    u.set("hr.oracle", std::string("kv"));
    u.set("oracle.norm", std::string("radiance"), {"study.toml", 7});
    EXPECT_THROW(HrSettings::fromParams(u), InputError);
    Params v;
    v.set("hr.oracle", std::string("kv"));
    v.set("oracle.norm", std::string("radiosity"));
    v.set("oracle.eps", 1e-2);
    EXPECT_NO_THROW(HrSettings::fromParams(v));
    Params w;
    w.set("hr.iteration", std::string("sor"), {"study.toml", 8});
    EXPECT_THROW(HrSettings::fromParams(w), InputError);
}

TEST(HrSolver, EpsScheduleRunsEachStage) {
    scene::Scene s = test::closedRoom();
    transport::Visibility vis(s);
    Params p;
    p.set("hr.eps_schedule", std::string("1e-2, 3e-3, 1e-3"));
    HrSolver solver(s, vis, HrSettings::fromParams(p));
    HrResult r = solver.solve();
    ASSERT_FALSE(r.history.empty());
    EXPECT_EQ(r.history.back().stage, 2);
    EXPECT_DOUBLE_EQ(r.history.back().eps, 1e-3);
    // Links only grow as eps decreases.
    uint64_t prev = 0;
    int prevStage = -1;
    for (const auto& rec : r.history) {
        if (rec.stage != prevStage) {
            EXPECT_GE(rec.links, prev);
            prevStage = rec.stage;
        }
        prev = rec.links;
    }
}

// memory.budget_mb: refinement stops before a round after which the process
// would pass the budget (what it holds besides links and elements, the
// elements, and the peak of the next judging pass: HrSolver::passPeakBytes),
// with the links it has, and the solve finishes on that coarser hierarchy
// (flagged) instead of growing until the kernel kills it. The budget here is
// what this process holds now plus 8 MiB; office:2 at eps 1e-4 (345 k links)
// needs about 50 MiB more. The process's peak resident set during the
// capped solve (VmHWM, reset through /proc/self/clear_refs where Linux
// allows it) stays within the budget: the budget of links and elements alone
// that the solver checked before let the peak reach 2.4-2.8 times it
// (classroom at eps 1e-4, budgets of 30 and 60 MiB: 83 and 142 MiB).
TEST(HrSolver, MemoryBudgetStopsRefinementWithACoarserSolution) {
    scene::Scene s = scene::loadScene("office:2");
    transport::Visibility vis(s);
    auto run = [&](int64_t budgetMb) {
        Params p;
        p.set("cluster.model", std::string("oriented"));
        p.set("oracle.eps", 1e-4);
        // Without stand-ins: the links left unopened stay as they are
        // (HrSolver.CappedSolveKeepsTheLightWithStandIns tests them).
        p.set("cluster.stand_in", false);
        if (budgetMb > 0) p.set("memory.budget_mb", budgetMb);
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        return solver.solve();
    };
    HrResult full = run(0);
    // The peak from here on (5: reset VmHWM to the current resident set).
    bool peakReset = false;
    {
        std::ofstream clear("/proc/self/clear_refs");
        if (clear) peakReset = bool(clear << "5" << std::flush);
    }
    const int64_t budgetMb = int64_t(currentRssBytes() >> 20) + 8;
    peakReset = peakReset && peakRssBytes() <= currentRssBytes() + (uint64_t(1) << 20);
    HrResult capped = run(budgetMb);
    const uint64_t peak = peakRssBytes();
    EXPECT_FALSE(full.memoryBudgetHit);
    EXPECT_TRUE(capped.memoryBudgetHit);
    uint64_t bytes = capped.hierarchy->elementBytes() + capped.hierarchy->linkBytes();
    std::cout << "links: unlimited " << full.hierarchy->numLinks() << ", budget " << budgetMb
              << " MiB " << capped.hierarchy->numLinks() << " (" << bytes << " bytes; peak "
              << (peak >> 20) << " MiB" << (peakReset ? "" : ", not reset") << ")\n";
    EXPECT_LT(capped.hierarchy->numLinks(), full.hierarchy->numLinks());
    EXPECT_GT(capped.hierarchy->numLinks(), 1u);
    // What the budget leaves over the process's resident set (8 MiB) bounds
    // the links and elements it keeps (the budget was 1 MiB of links and
    // elements alone before it bounded the process).
    EXPECT_LE(bytes, uint64_t(8) << 20);
    if (peakReset) {
        EXPECT_LE(peak, uint64_t(budgetMb) << 20);
    }
    // Cluster links that had to be opened and were not carry nothing; the
    // solve counts them (summary unopened_links) so that a stopped solve
    // says how much of its transport is missing. A complete solve has none.
    uint64_t unopened = 0;
    for (uint64_t i = 0; i < capped.hierarchy->numLinks(); ++i)
        if (capped.hierarchy->link(i).flags & Link::kOpen) {
            ++unopened;
            EXPECT_EQ(capped.hierarchy->link(i).K, 0.f);
        }
    std::cout << "unopened links: " << unopened << "\n";
    EXPECT_GT(unopened, 0u);
    EXPECT_EQ(capped.unopenedLinks, unopened);
    EXPECT_EQ(full.unopenedLinks, 0u);
    // A solution, not nothing: finite, every patch at least its emission.
    RGB power = capped.hierarchy->radiosityPower();
    for (int c = 0; c < 3; ++c) {
        EXPECT_TRUE(std::isfinite(power[c]));
        EXPECT_GE(power[c], s.emittedPower()[c]);
    }
}

// A solve stopped by hr.max_links keeps the cluster links it was about to
// open; with stand-ins (cluster/link.h "Stand-ins", the default) each carries
// a sampled transfer, so the capped solve keeps the light that the same
// solve without them loses. Against the uncapped solve of office:2
// (reflected power per channel), capped at half its links: the stand-ins
// then carry about half the reflected light and the total is 4 % above the
// uncapped solve's (+4.6 / +4.2 / +3.8 %), because a receiving cluster takes
// the light of a stand-in whose spheres overlap by area: the ceiling gets
// light that belongs to the floor (papers/README.md "Stand-ins"). Without
// them it is below half.
TEST(HrSolver, CappedSolveKeepsTheLightWithStandIns) {
    scene::Scene s = scene::loadScene("office:2");
    transport::Visibility vis(s);
    auto run = [&](int64_t cap, bool standIn, const char* iteration = "jacobi") {
        Params p;
        p.set("cluster.model", std::string("oriented"));
        p.set("oracle.eps", 1e-3);
        p.set("hr.iteration", std::string(iteration));
        p.set("cluster.stand_in", standIn);
        // The published bfa, whose cap at half the links falls while the
        // near cluster pairs are being opened (with the receiver check, the
        // default, half the links are reached later: without stand-ins the
        // capped solve keeps 0.86-0.90 of the light, with them 1.005-1.008).
        p.set("hr.receiver_eps", std::string("off"));
        // Near pairs always opened, so that the cap falls among forced
        // openings (with judged stand-ins for large near pairs, the default,
        // the capped solve without cluster.stand_in kept 1.005-1.014 of the
        // light: its near pairs were stand-ins already).
        p.set("cluster.near", std::string("open"));
        if (cap > 0) p.set("hr.max_links", cap);
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        return solver.solve();
    };
    HrResult full = run(0, true);
    ASSERT_FALSE(full.linkCapHit);
    EXPECT_EQ(full.standInLinks, 0u);
    const uint64_t cap = full.hierarchy->numLinks() / 2;
    HrResult with = run(int64_t(cap), true), without = run(int64_t(cap), false);
    ASSERT_TRUE(with.linkCapHit);
    ASSERT_TRUE(without.linkCapHit);
    EXPECT_GT(without.unopenedLinks, 0u);
    EXPECT_EQ(with.unopenedLinks, 0u);
    EXPECT_EQ(with.standInLinks, without.unopenedLinks);
    // Every unopened link got an estimate; those whose rays all missed carry
    // nothing and are no stand-ins (no samples to gather).
    uint64_t standIns = 0, byCosine = 0, sampled = 0;
    for (uint64_t i = 0; i < with.hierarchy->numLinks(); ++i) {
        const Link& l = with.hierarchy->link(i);
        EXPECT_FALSE(l.flags & Link::kOpen);
        if (l.flags & Link::kSampled) ++sampled;
        if (l.flags & Link::kStandIn) {
            ++standIns;
            EXPECT_TRUE(l.flags & Link::kSampled);
            if (!l.byArea()) ++byCosine;
        }
    }
    EXPECT_EQ(standIns, with.standInLinksFinal);
    EXPECT_EQ(sampled, with.standInLinks);
    EXPECT_GT(standIns, 0u);
    EXPECT_GT(byCosine, 0u);  // spheres apart, into clusters: handed over by cosine
    EXPECT_GT(with.standInPowerShare, 0.0);
    const RGB e = s.emittedPower();
    const RGB ref = full.hierarchy->radiosityPower() - e;
    const RGB pw = with.hierarchy->radiosityPower() - e;
    const RGB po = without.hierarchy->radiosityPower() - e;
    std::cout << "office:2, " << cap << " links: reflected power over the uncapped solve with "
              << "stand-ins " << pw.r / ref.r << " " << pw.g / ref.g << " " << pw.b / ref.b
              << ", without " << po.g / ref.g << " (" << with.standInLinks << " estimated, "
              << standIns << " stand-ins, " << byCosine << " by cosine)\n";
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(pw[c] / ref[c], 1.0, 0.08) << c;
        EXPECT_LT(po[c] / ref[c], 0.5) << c;
    }
    // Gauss-Seidel sweeps gather the stand-ins into clusters too: the same
    // answer within the iteration's tolerance.
    HrResult gs = run(int64_t(cap), true, "gauss-seidel");
    const RGB pg = gs.hierarchy->radiosityPower() - e;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(pg[c] / pw[c], 1.0, 0.005) << c;
}

// cluster.near = stand_in (cluster/link.h "Judged stand-ins"): cluster pairs
// too close for the point approximation are estimated by sampling and
// judged before they are opened. On office:3 (bfa 1e-3, oriented) that
// keeps 63 k of the 98 k links the always-opened rule makes, 56 k with the
// overlapping pairs and self-links too (cluster.near_overlapping), and the
// reflected power stays within 1 % of the unclustered solve's (measured
// +0.59 / +0.40 / +0.07 % and +0.68 / +0.48 / +0.14 %; the always-opened
// rule +0.83 / +0.60 / +0.25 %). The overlapping pairs fail this when a
// stand-in's own estimate decides which checks it faces (papers/README.md,
// "Judged stand-ins").
TEST(HrSolver, JudgedStandInsOpenFewerNearPairsAndKeepTheLight) {
    scene::Scene s = scene::loadScene("office:3");
    transport::Visibility vis(s);
    // near == nullptr: the default near-pair settings.
    auto run = [&](const char* model, const char* near, bool overlapping = false) {
        Params p;
        p.set("cluster.model", std::string(model));
        p.set("oracle.eps", 1e-3);
        if (near) {
            p.set("cluster.near", std::string(near));
            p.set("cluster.near_overlapping", overlapping);
            p.set("cluster.near_open_pairs", int64_t(0));  // every near pair judged
        }
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        return solver.solve();
    };
    HrResult flat = run("none", "open");
    HrResult open = run("oriented", "open");
    HrResult judged = run("oriented", "stand_in");
    HrResult overlapping = run("oriented", "stand_in", true);
    // The default: pairs of at most 8,192 surface pairs opened, larger ones
    // judged (cluster.near_open_pairs).
    HrResult byDefault = run("oriented", nullptr);
    EXPECT_GT(byDefault.nearStandInsMade, 0u);
    EXPECT_LT(byDefault.nearStandInsMade, overlapping.nearStandInsMade);
    EXPECT_LT(overlapping.hierarchy->numLinks(), judged.hierarchy->numLinks());
    EXPECT_EQ(open.nearStandInsMade, 0u);
    EXPECT_GT(judged.nearStandInsMade, 0u);
    EXPECT_GT(judged.standInLinksFinal, 0u);
    EXPECT_LT(double(judged.hierarchy->numLinks()), 0.8 * double(open.hierarchy->numLinks()));
    uint64_t byCosine = 0;
    for (uint64_t i = 0; i < judged.hierarchy->numLinks(); ++i) {
        const Link& l = judged.hierarchy->link(i);
        EXPECT_FALSE(l.flags & Link::kOpen);
        if ((l.flags & Link::kStandIn) && !l.byArea()) ++byCosine;
    }
    EXPECT_GT(byCosine, 0u);
    const RGB e = s.emittedPower();
    const RGB ref = flat.hierarchy->radiosityPower() - e;
    const RGB pj = judged.hierarchy->radiosityPower() - e;
    const RGB po = overlapping.hierarchy->radiosityPower() - e;
    const RGB pd = byDefault.hierarchy->radiosityPower() - e;
    std::cout << "office:3: " << open.hierarchy->numLinks() << " links opened, "
              << judged.hierarchy->numLinks() << " with judged stand-ins; reflected power over "
              << "the unclustered solve " << pj.r / ref.r << " " << pj.g / ref.g << " "
              << pj.b / ref.b << "\n";
    std::cout << "  with overlapping pairs: " << overlapping.hierarchy->numLinks() << " links, "
              << po.r / ref.r << " " << po.g / ref.g << " " << po.b / ref.b << "\n";
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(pj[c] / ref[c], 1.0, 0.01) << c;
        EXPECT_NEAR(po[c] / ref[c], 1.0, 0.01) << c;
        EXPECT_NEAR(pd[c] / ref[c], 1.0, 0.01) << c;
    }
    std::cout << "  by default: " << byDefault.hierarchy->numLinks() << " links, "
              << byDefault.nearStandInsMade << " stand-ins made (" << overlapping.nearStandInsMade
              << " judging every pair), " << pd.r / ref.r << " " << pd.g / ref.g << " "
              << pd.b / ref.b << "\n";
}

// hr.max_seconds: past the limit, refinement and iteration stop and the
// solution so far is the result, flagged (a limit of a microsecond is hit by
// any solve, so the test does not depend on the machine's speed).
TEST(HrSolver, TimeLimitKeepsTheSolutionSoFar) {
    scene::Scene s = test::closedRoom();
    transport::Visibility vis(s);
    Params p;
    p.set("oracle.eps", 1e-4);
    p.set("hr.max_seconds", 1e-6);
    HrSolver solver(s, vis, HrSettings::fromParams(p));
    HrResult r = solver.solve();
    EXPECT_TRUE(r.timeLimitHit);
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(r.history.size(), 1u);
    ASSERT_NE(r.field, nullptr);
    // The unrefined initial links were gathered once: light, finite.
    RGB power = r.hierarchy->radiosityPower();
    for (int c = 0; c < 3; ++c) {
        EXPECT_TRUE(std::isfinite(power[c]));
        EXPECT_GT(power[c], s.emittedPower()[c]);
    }
}
