// Per-link audit of judged stand-ins (cluster.near = stand_in, cluster/link.h
// "Judged stand-ins") against Monte Carlo (tests/link_audit.h): every final
// link of a solved scene, grouped into stand-ins taking their light by area,
// stand-ins handed over by cosine, sampled links that found nothing (K = 0:
// whatever they really carry is lost) and the other cluster links, with the
// model's power against the Monte Carlo power and its standard error. Not a
// fast test: office:4, and Lost Empire when ../shared/scenes is there.
#include <gtest/gtest.h>

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
    double model = 0, mc = 0, var = 0;
    uint64_t links = 0;
    void add(const test::LinkPower& p, double weight) {
        model += weight * p.model;
        mc += weight * p.mc;
        var += weight * weight * p.mcVar;
        ++links;
    }
    double ratio() const { return mc > 0 ? model / mc : 1.0; }
    double se() const { return std::sqrt(var); }
};

enum { kByArea, kByCosine, kFoundNothing, kOther, kGroups };

struct SceneAudit {
    Group g[kGroups];
};

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
    SceneAudit a;
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
        // Stand-ins taken by area join ends that touch or overlap, where the
        // point pairs' cos cos / (pi d^2) has an infinite variance (on Lost
        // Empire their sum moved 21 % with 16x the pairs); they are audited
        // by gathering, whose variance is bounded (tests/link_audit.h).
        const test::LinkPower pw =
            group == kByArea ? test::auditLinkByGather(s, vis, res, recv, i, standInPairs, orderPos)
                             : test::auditLink(s, vis, res, recv, i, group == kOther ? kPairs : standInPairs);
        a.g[group].add(pw, weight);
    }
    static const char* names[kGroups] = {"stand-ins by area", "stand-ins by cosine",
                                         "sampled, found nothing", "other cluster links"};
    for (int k = 0; k < kGroups; ++k)
        std::cout << spec << " near=" << near
                  << (regime == Regime::kDefault ? " (default pairs)" : "") << ", " << names[k]
                  << ": " << a.g[k].links << " links, model " << a.g[k].model << ", Monte Carlo "
                  << a.g[k].mc << " +- " << a.g[k].se() << ", ratio " << a.g[k].ratio() << "\n";
    return a;
}

// All the stand-ins together (by area, by cosine, and those that found
// nothing and carry 0) against the Monte Carlo power of the same links.
// Each stand-in's transfer is an unbiased estimate (cluster/link.h), so the
// sum must match within its noise and the audit's (measured 1.009 on
// office:4; on Lost Empire 1.042 +- 0.011, the stand-ins taken by area
// carrying 1.65x their power: a known bias this test fails on, README
// "Known limitations", papers/notes/2026-12-02-modern-hall-light.md s. 10). Stand-ins judged by the estimate they
// carry would be kept more often where it is low, and the sum would fall
// short. The found-nothing group alone is biased low and the others high by
// the same power (which of the two a link falls in is its own estimate).
// On office:4 the always-opened solve's cluster links are printed for
// comparison: the point approximation carries 1.5 % more than Monte Carlo
// there, and 3.8 % more on Lost Empire (5.002 against 4.820 +- 0.018,
// measured once; that second solve of Lost Empire is not part of the test,
// where it took 55 of its 123 s).
// The stand-in groups summed (by area, by cosine, found nothing), printed.
Group allStandIns(const SceneAudit& a) {
    Group all;
    for (int k : {kByArea, kByCosine, kFoundNothing}) {
        all.model += a.g[k].model;
        all.mc += a.g[k].mc;
        all.var += a.g[k].var;
        all.links += a.g[k].links;
    }
    std::cout << "stand-ins in all: " << all.links << " links, model " << all.model
              << ", Monte Carlo " << all.mc << " +- " << all.se() << ", ratio " << all.ratio()
              << "\n";
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
    // The texel alone, as the scene's reflectance was before textures were
    // read: with map_Kd x Kd per patch (the default since 2026-12-02) the
    // stand-ins spread by area carry 1.51x their Monte Carlo power and all
    // stand-ins 1.045x (README, "Known limitations").
    p.set("obj.texture_kd", std::string("replace"));
    const std::string le = (*dir / "lost-empire/lost_empire.obj").string();
    expectStandInsUnbiased(audit(le, p, "stand_in", 8));
}

// The default regime: overlapping pairs are judged too, and small pairs are
// opened, so fewer stand-ins remain (Lost Empire 5,108 against 440,039),
// spanning larger clusters, and their sum is judged against the audit's own
// standard error (4,096 point pairs per stand-in): measured 1.028 +- 0.015.
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
    EXPECT_LT(std::fabs(all.model - all.mc), 3.0 * all.se());
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
