// The refinement checks as a family (hr/checks/): the table's order, which
// checks take part for each oracle, and a new check added as one class and
// one table row (here an extra row handed to the solver, as a study would
// before it enters hr/checks/registry.cpp).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hr/checks/registry.h"
#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "transport/visibility.h"

using namespace hrad;
using namespace hrad::hr;

TEST(RefinementChecks, TableIsInAmendmentOrder) {
    std::vector<std::string> names;
    for (const CheckEntry& e : refinementChecks()) names.push_back(e.name);
    const std::vector<std::string> expected = {"receiver",           "leaf_budget",
                                               "sender_total",       "sampled_uncertainty",
                                               "partial_receivers",  "near_stand_in",
                                               "importance"};
    EXPECT_EQ(names, expected);
    for (const CheckEntry& e : refinementChecks()) {
        EXPECT_NE(e.make, nullptr);
        EXPECT_GT(std::string(e.summary).size(), 10u) << e.name;
    }
}

namespace {

// A check that refines, on the receiver side, every accepted surface link
// whose receiver is above a fixed level: a minimum depth, the simplest
// amendment there is.
constexpr int kMinLevel = 2;

class MinimumLevelCheck final : public RefinementCheck {
  public:
    const char* name() const override { return "minimum_level"; }
    bool beginPass(const CheckPass&) override { return true; }
    void amend(const CheckRound& round, size_t i, const oracles::LinkEstimate& e,
               oracles::Decision& d) const override {
        if (d == oracles::Decision::Accept && !round.h.isCluster(round.recv[i]) &&
            e.receiverLevel < kMinLevel && e.receiverCanSubdivide)
            d = oracles::Decision::RefineReceiver;
    }
};

std::unique_ptr<RefinementCheck> makeMinimumLevel(const HrSettings&) {
    return std::make_unique<MinimumLevelCheck>();
}

uint32_t shallowestLeafLevel(const Hierarchy& h) {
    uint32_t lowest = 1u << 30;
    for (uint32_t e = 0; e < h.numElements(); ++e)
        if (!h.isCluster(e) && h.isLeaf(e)) lowest = std::min<uint32_t>(lowest, h.level(e));
    return lowest;
}

}  // namespace

TEST(RefinementChecks, ANewCheckIsOneClassAndOneRow) {
    scene::Scene s = scene::loadScene("plates:parallel:1:1:1");
    transport::Visibility vis(s);
    const HrSettings st = test::hrSettings("bfa", 0.5);
    HrResult plain = HrSolver(s, vis, st).solve();
    HrResult deeper = HrSolver(s, vis, st, {{"minimum_level", makeMinimumLevel,
                                             "every receiver refined to level 2"}})
                          .solve();
    // At eps 0.5 bfa keeps the two root patches; the check pushes every
    // receiver that gathers light to level 2.
    EXPECT_LT(shallowestLeafLevel(*plain.hierarchy), uint32_t(kMinLevel));
    EXPECT_GE(shallowestLeafLevel(*deeper.hierarchy), uint32_t(kMinLevel));
    EXPECT_GT(deeper.hierarchy->numLinks(), plain.hierarchy->numLinks());
    EXPECT_TRUE(deeper.converged);
    // The result names every check; the new one took part and amended.
    ASSERT_EQ(deeper.checks.size(), refinementChecks().size() + 1);
    EXPECT_EQ(deeper.checks.back().name, "minimum_level");
    EXPECT_GT(deeper.checks.back().passes, 0u);
    EXPECT_GT(deeper.checks.back().amended, 0u);
    EXPECT_EQ(plain.checks.size(), refinementChecks().size());
}

TEST(RefinementChecks, TheErrorOraclesTakeNoReceiverCheck) {
    // error and kv judge the receiver aggregate themselves: with them the
    // receiver check and the sender-total check stay out of every pass; with
    // bfa (hr.receiver_eps = auto) they take part. Measured through the
    // solve: turning hr.receiver_eps off changes bfa's solve, not error's.
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    auto links = [&](const std::string& oracle, double eps, bool receiverCheck) {
        HrSettings st = test::hrSettings(oracle, eps);
        st.receiverEps = receiverCheck ? -1.0 : 0.0;
        st.leafBudget = HrSettings::LeafBudget::Off;
        return HrSolver(s, vis, st).solve().hierarchy->numLinks();
    };
    EXPECT_NE(links("bfa", 1e-2, true), links("bfa", 1e-2, false));
    EXPECT_EQ(links("error", 1e-2, true), links("error", 1e-2, false));
    // The result says so: the receiver check took part in bfa's passes and
    // amended decisions, and in none of error's.
    auto receiverUse = [&](const std::string& oracle) {
        HrSettings st = test::hrSettings(oracle, 1e-2);
        HrResult r = HrSolver(s, vis, st).solve();
        EXPECT_EQ(r.checks.front().name, "receiver");
        return r.checks.front();
    };
    const CheckUse bfa = receiverUse("bfa"), error = receiverUse("error");
    EXPECT_GT(bfa.passes, 0u);
    EXPECT_GT(bfa.amended, 0u);
    EXPECT_EQ(error.passes, 0u);
}

TEST(RefinementChecks, HrChecksChoosesThem) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    auto solve = [&](const std::string& checks) {
        Params p;
        p.set("hr.oracle", std::string("bfa"));
        p.set("oracle.eps", 1e-2);
        p.set("cluster.model", std::string("none"));
        if (!checks.empty()) p.set("hr.checks", checks);
        HrSettings st = HrSettings::fromParams(p);
        p.reportUnused();
        return HrSolver(s, vis, st).solve();
    };
    const HrResult all = solve(""), none = solve("none"), some = solve("receiver, sender_total");
    EXPECT_EQ(all.checks.size(), refinementChecks().size());
    EXPECT_TRUE(none.checks.empty());
    ASSERT_EQ(some.checks.size(), 2u);
    EXPECT_EQ(some.checks[0].name, "receiver");
    EXPECT_EQ(some.checks[1].name, "sender_total");
    // Without the checks bfa judges link by link, as published: fewer links.
    EXPECT_LT(none.hierarchy->numLinks(), all.hierarchy->numLinks());
    try {
        solve("receiver,recever");
        FAIL() << "an unknown check name must be an error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("recever"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("leaf_budget"), std::string::npos);
    }
}
