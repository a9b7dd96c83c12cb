// Per-link audit of judged stand-ins (cluster.near = stand_in, cluster/link.h
// "Judged stand-ins") against Monte Carlo (tests/link_audit.h): every final
// link of a solved scene, grouped into stand-ins taking their light by area,
// stand-ins handed over by cosine, sampled links that found nothing (K = 0:
// whatever they really carry is lost) and the other cluster links, with the
// model's power against the Monte Carlo power and its standard error. Not a
// fast test: office:4, and Lost Empire when ../shared/scenes is there.
#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/link_audit.h"
#include "tests/test_util.h"
#include "transport/visibility.h"

using namespace hrad;

namespace {

struct Group {
    double model = 0, mc = 0, var = 0, modelVar = 0;
    uint64_t links = 0;
    void add(const test::LinkPower& p, double weight, double pModelVar) {
        model += weight * p.model;
        mc += weight * p.mc;
        var += weight * weight * p.mcVar;
        modelVar += weight * weight * pModelVar;
        ++links;
    }
    double ratio() const { return mc > 0 ? model / mc : 1.0; }
    double se() const { return std::sqrt(var); }
    /// The standard error of model - mc: the audit's and the draws' own.
    double combinedSe() const { return std::sqrt(var + modelVar); }
};

enum { kByArea, kByCosine, kFoundNothing, kOther, kGroups };

struct SceneAudit {
    Group g[kGroups];
};

/// One audited link: its group, its weight in the group's sum, its powers and
/// the variance of its model power.
struct Audited {
    uint64_t link;
    int group;
    double weight;
    test::LinkPower pw;
    double modelVar;
};

// A stand-in's transfer is one draw of an estimator whose relative standard
// error is about its `uncertainty` / 200 (twice the relative error, in
// percent, cluster/stand_in.cpp judgeStandIn), and a few links whose draws or
// audits are very noisy decide a group's sum: on Lost Empire one by-area
// stand-in held 0.029 of its group's 0.076, one draw of an estimator whose
// mean over 64 draws is 0.0168 +- 0.0012 (Monte Carlo 0.0163 +- 0.0011).
// Where there are at most kRedrawAll stand-ins, every one is drawn afresh
// (the estimator's mean over kDraws independent draws, test::StandInRedraw);
// then the kHeavy stand-ins with the largest noise, the draw's plus the
// audit's plus the square of their disagreement, are audited again: drawn
// afresh and against kHeavyRays Monte Carlo samples. Each group's
// sum then compares the estimator's expectation, which is what an unbiased
// estimator promises, not one draw per link: the draws of a heavy-tailed
// estimator mostly fall below its mean (on Lost Empire's default regime the
// kept draws summed to 0.123 against a mean of 0.132, measured before the
// solid-angle visibility rays).
constexpr int kHeavy = 96, kDraws = 64, kHeavyRays = 1 << 18;
constexpr size_t kRedrawAll = 4096;

// A stand-in's Monte Carlo power: with sender points weighted by radiosity
// where its ends' bounding spheres are apart (bounded kernel,
// test::auditLinkBySenderRadiosity), else by gathering (ends that touch or
// overlap, where point pairs' cos cos / (pi d^2) has an infinite variance).
test::LinkPower auditStandIn(const scene::Scene& s, const transport::Visibility& vis,
                             const hr::HrResult& res, const std::vector<uint32_t>& recv, uint64_t i,
                             int n, const std::vector<uint32_t>& orderPos) {
    const hr::Hierarchy& h = *res.hierarchy;
    const uint32_t r = recv[i], sd = h.link(i).sender;
    const bool apart = glm::length(h.center(r) - h.center(sd)) > h.radius(r) + h.radius(sd);
    return apart ? test::auditLinkBySenderRadiosity(s, vis, res, recv, i, n)
                 : test::auditLinkByGather(s, vis, res, recv, i, n, orderPos);
}

void reauditNoisiest(const scene::Scene& s, const transport::Visibility& vis,
                     const hr::HrResult& res, const hr::HrSettings& hs,
                     const std::vector<uint32_t>& recv, const std::vector<uint32_t>& orderPos,
                     std::vector<Audited>& audited) {
    std::vector<size_t> order;
    for (size_t k = 0; k < audited.size(); ++k)
        if (audited[k].group != kOther) order.push_back(k);
    const test::StandInRedraw redraw(s, vis, res, hs.clusterLink);
    auto drawAfresh = [&](Audited& a) {
        const test::StandInRedraw::Power p = redraw.power(recv, a.link, kDraws);
        a.pw.model = p.model;
        a.modelVar = p.modelVar;
    };
    // Few stand-ins (the default regime): every one is drawn afresh first.
    const bool all = order.size() <= kRedrawAll;
    if (all)
        tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 8), [&](const auto& range) {
            for (size_t j = range.begin(); j != range.end(); ++j) drawAfresh(audited[order[j]]);
        });
    // The noisiest, and those whose model and audit disagree most (an audit
    // whose samples found nothing reports a variance of 0).
    auto noise = [&](size_t k) {
        const Audited& a = audited[k];
        const double gap = a.pw.model - a.pw.mc;
        return a.modelVar + a.pw.mcVar + gap * gap;
    };
    const size_t n = std::min<size_t>(kHeavy, order.size());
    std::partial_sort(order.begin(), order.begin() + n, order.end(),
                      [&](size_t a, size_t b) { return noise(a) > noise(b); });
    for (size_t j = 0; j < n; ++j) {
        Audited& a = audited[order[j]];
        const double drawn = a.pw.model, drawnSe = std::sqrt(a.modelVar);
        if (!all) drawAfresh(a);
        const test::LinkPower g = auditStandIn(s, vis, res, recv, a.link, kHeavyRays, orderPos);
        std::cout << "  link " << a.link << ": " << (all ? "mean of draws " : "drawn ") << drawn
                  << " +- " << drawnSe << ", mean of " << kDraws << " draws " << a.pw.model
                  << " +- " << std::sqrt(a.modelVar) << "; Monte Carlo " << a.pw.mc << " +- "
                  << std::sqrt(a.pw.mcVar) << ", with " << kHeavyRays << " rays " << g.mc
                  << " +- " << std::sqrt(g.mcVar) << "\n";
        a.pw.mc = g.mc;
        a.pw.mcVar = g.mcVar;
    }
}

// The two regimes audited: every near pair whose spheres are apart judged and
// overlapping pairs opened (kApartJudged), or the default: near and
// overlapping pairs judged unless they hold at most cluster.near_open_pairs
// surface pairs, which are opened (cluster/link.h, "Small pairs are opened").
enum class Regime { kApartJudged, kDefault };

SceneAudit audit(const std::string& spec, const Params& extra, const std::string& near,
                 uint64_t otherStride, Regime regime = Regime::kApartJudged) {
    Params p = extra;
    p.set("hr.oracle", std::string("bfa"));
    p.set("oracle.eps", 1e-3);
    p.set("cluster.model", std::string("oriented"));
    p.set("cluster.near", near);
    if (regime == Regime::kApartJudged) {
        p.set("cluster.near_overlapping", false);
        p.set("cluster.near_open_pairs", int64_t(0));
    }
    scene::Scene s = scene::loadScene(spec, p);
    transport::Visibility vis(s);
    hr::HrSettings hs = hr::HrSettings::fromParams(p);
    hr::HrSolver solver(s, vis, hs);
    hr::HrResult res = solver.solve();
    const hr::Hierarchy& h = *res.hierarchy;
    const std::vector<uint32_t> recv = h.linkReceivers();
    std::vector<Audited> audited;
    std::vector<uint32_t> orderPos(s.patches.size(), 0);
    if (res.clusterTree)
        for (uint32_t k = 0; k < res.clusterTree->orderSize(); ++k) orderPos[res.clusterTree->patchAt(k)] = k;
    // The default leaves few stand-ins, spanning large clusters: more point
    // pairs each, or the audit's own noise decides nothing.
    constexpr int kPairs = 256;
    const int standInPairs = regime == Regime::kDefault ? 4096 : kPairs;
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        const hr::Link& l = h.link(i);
        int group;
        double weight = 1.0;
        if ((l.flags & hr::Link::kSampled) && !(l.K > 0))
            group = kFoundNothing;
        else if (l.flags & hr::Link::kStandIn)
            group = l.byArea() ? kByArea : kByCosine;
        else if ((h.isCluster(recv[i]) || h.isCluster(l.sender)) && l.K > 0) {
            // Every otherStride-th of the other cluster links, weighted by it.
            if (i % otherStride) continue;
            group = kOther;
            weight = double(otherStride);
        } else
            continue;
        const test::LinkPower pw = group == kOther ? test::auditLink(s, vis, res, recv, i, kPairs)
                                                   : auditStandIn(s, vis, res, recv, i, standInPairs, orderPos);
        const double relative = double(l.uncertainty) / 200.0;
        audited.push_back({i, group, weight, pw,
                           group == kOther ? 0.0 : (pw.model * relative) * (pw.model * relative)});
    }
    reauditNoisiest(s, vis, res, hs, recv, orderPos, audited);
    SceneAudit a;
    for (const Audited& x : audited) a.g[x.group].add(x.pw, x.weight, x.modelVar);
    static const char* names[kGroups] = {"stand-ins by area", "stand-ins by cosine",
                                         "sampled, found nothing", "other cluster links"};
    for (int k = 0; k < kGroups; ++k)
        std::cout << spec << " near=" << near
                  << (regime == Regime::kDefault ? " (default pairs)" : "") << ", " << names[k]
                  << ": " << a.g[k].links << " links, model " << a.g[k].model << ", Monte Carlo "
                  << a.g[k].mc << " +- " << a.g[k].se() << ", ratio " << a.g[k].ratio()
                  << " (model - Monte Carlo +- " << a.g[k].combinedSe() << ")\n";
    return a;
}

// All the stand-ins together (by area, by cosine, and those that found
// nothing and carry 0) against the Monte Carlo power of the same links.
// Each stand-in's transfer is an unbiased estimate (cluster/link.h), so the
// sum of the estimators' means must match the Monte Carlo power within 1.5 %
// (measured 0.999 +- 0.002 on office:4 and 1.002 +- 0.006 on Lost Empire,
// the standard error counting the audit's and the draws' noise; the
// stand-ins taken by area 1.009 +- 0.010 and 1.005 +- 0.034). Stand-ins judged by the estimate they carry
// would be kept more often where it is low, and the sum would fall short.
// The found-nothing group alone is biased low and the others high by the
// same power (which of the two a link falls in is its own draw). On
// office:4 the always-opened solve's cluster links are printed for
// comparison: the point approximation carries 1.5 % more than Monte Carlo
// there, and 3.8 % more on Lost Empire (5.002 against 4.820 +- 0.018,
// measured once; that second solve of Lost Empire is not part of the test).
// The stand-in groups summed (by area, by cosine, found nothing), printed.
Group allStandIns(const SceneAudit& a) {
    Group all;
    for (int k : {kByArea, kByCosine, kFoundNothing}) {
        all.model += a.g[k].model;
        all.mc += a.g[k].mc;
        all.var += a.g[k].var;
        all.modelVar += a.g[k].modelVar;
        all.links += a.g[k].links;
    }
    std::cout << "stand-ins in all: " << all.links << " links, model " << all.model
              << ", Monte Carlo " << all.mc << " +- " << all.se() << ", ratio " << all.ratio()
              << " (model - Monte Carlo +- " << all.combinedSe() << ")\n";
    return all;
}

void expectStandInsUnbiased(const SceneAudit& a) {
    ASSERT_GT(a.g[kByCosine].links, 0u);
    const Group all = allStandIns(a);
    ASSERT_GT(all.mc, 0.0);
    EXPECT_NEAR(all.model / all.mc, 1.0, 0.015);
}

}  // namespace

TEST(StandInAudit, StandInsCarryTheirMonteCarloPowerOnOffice4) {
    expectStandInsUnbiased(audit("office:4", Params{}, "stand_in", 1));
    audit("office:4", Params{}, "open", 1);
}

TEST(StandInAudit, StandInsCarryTheirMonteCarloPowerOnLostEmpire) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes is absent";
    Params p;
    p.set("scene.clamp_rho", 0.99);
    const std::string le = (*dir / "lost-empire/lost_empire.obj").string();
    expectStandInsUnbiased(audit(le, p, "stand_in", 8));
}

// The default regime: overlapping pairs are judged too, and small pairs are
// opened, so fewer stand-ins remain (Lost Empire 5,108 against 440,039),
// spanning larger clusters, each drawn afresh 64 times, and their sum is
// judged against the audit's and the draws' standard error (4,096 Monte
// Carlo samples per stand-in): measured 0.963 +- 0.027. Re-audited by
// noise alone, the found-nothing group's audit (4,096 samples that had met
// none of a few links' light, variance 0) put it at 1.075 +- 0.026.
TEST(StandInAudit, DefaultStandInsCarryTheirMonteCarloPowerOnLostEmpire) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes is absent";
    Params p;
    p.set("scene.clamp_rho", 0.99);
    const std::string le = (*dir / "lost-empire/lost_empire.obj").string();
    const SceneAudit a = audit(le, p, "stand_in", 8, Regime::kDefault);
    ASSERT_GT(a.g[kByArea].links + a.g[kByCosine].links, 100u);
    const Group all = allStandIns(a);
    ASSERT_GT(all.mc, 0.0);
    EXPECT_LT(std::fabs(all.model - all.mc), 3.0 * all.combinedSe());
}

// On office:4 the default leaves about 100-130 stand-ins (cluster pairs of
// about 110 x 110 surfaces, most overlapping or nearly so), each with a
// relative standard error of 50-100 % at 32 rays (the oracle keeps it
// because that error times its power is within eps of the emitted power).
// One solve's sum is then one noisy draw: at 32 rays the fixed seeding gave
// 0.60 of the Monte Carlo power, and the audit's standard error (0.02) does
// not count the stand-ins' own noise. Over solves with independent seeds
// (hr.seed) the spread of (model - Monte Carlo) between seeds counts both,
// and the mean difference must lie within three of its standard errors:
// measured -0.256 +- 0.263 at 32 rays, 0.001 +- 0.092 at 128 (the default);
// with the judged estimate drawn from the carried one's stream (the
// selection bias the independent estimate avoids) -0.945 +- 0.108, a
// failure. The audit's own estimate is heavy-tailed where the two clusters'
// surfaces touch (area sampling of 1 / d^2): over seeds 0-24 at 32 rays,
// four seeds' audits had standard errors of 0.35-1.5 against 0.02-0.08 for
// the others (bench/results/large_scenes.md, "The solver's own noise, over
// seeds").
TEST(StandInAudit, DefaultStandInsCarryTheirMonteCarloPowerOnOffice4OverSeeds) {
    constexpr int kSeeds = 12;
    double sum = 0, sum2 = 0, model = 0, mc = 0;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Params p;
        p.set("hr.seed", int64_t(seed));
        const Group all = allStandIns(audit("office:4", p, "stand_in", 1, Regime::kDefault));
        ASSERT_GT(all.links, 50u);
        const double d = all.model - all.mc;
        sum += d, sum2 += d * d, model += all.model, mc += all.mc;
    }
    const double mean = sum / kSeeds;
    const double se = std::sqrt(std::max(0.0, sum2 / kSeeds - mean * mean) / (kSeeds - 1));
    std::cout << "office:4 default stand-ins over " << kSeeds << " seeds: model " << model
              << ", Monte Carlo " << mc << ", mean difference " << mean << " +- " << se << "\n";
    ASSERT_GT(se, 0.0);
    EXPECT_LT(std::fabs(mean), 3.0 * se);
}
