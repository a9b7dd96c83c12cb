#include <gtest/gtest.h>

#include "oracles/registry.h"

using namespace hrad;
using namespace hrad::oracles;

namespace {
LinkEstimate baseEstimate() {
    LinkEstimate e;
    e.F = 0.1;
    e.unoccludedF = 0.1;
    e.Fupper = 0.2;
    e.receiverArea = 1.0;
    e.senderArea = 4.0;  // F_sr = 0.025 < F_rs: the sender looks larger
    e.senderB = RGB(10.0);
    e.receiverRho = RGB(0.5);
    e.emittedPower = 100.0;
    e.receiverCanSubdivide = e.senderCanSubdivide = true;
    return e;
}
}  // namespace

TEST(OracleRegistry, UnknownNameListsValidNames) {
    try {
        createOracle("bf", Params{});
        FAIL();
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_NE(m.find("bfa"), std::string::npos) << m;
        EXPECT_NE(m.find("uniform"), std::string::npos) << m;
    }
}

TEST(OracleRegistry, UnknownSettingIsReported) {
    Params p;
    p.setFromText("epsilon", "0.1", {"x.toml", 3});
    auto o = createOracle("bfa", p);
    EXPECT_THROW(p.reportUnused(), InputError);
}

TEST(OracleRegistry, OutOfRangeEpsNamesKey) {
    Params p;
    p.setFromText("eps", "0", {"x.toml", 7});
    try {
        createOracle("ff", p);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("eps"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("x.toml:7"), std::string::npos);
    }
}

TEST(PowerOracle, AcceptsBelowThresholdRefinesLargerSideAbove) {
    LinkEstimate e = baseEstimate();
    // transported power = 0.5 * 10 * 0.1 * 1 = 0.5 = 5e-3 of emitted power.
    Params lo;
    lo.set("eps", 1e-2);
    EXPECT_EQ(createOracle("bfa", lo)->decide(e), Decision::Accept);
    Params hi;
    hi.set("eps", 1e-3);
    auto o = createOracle("bfa", hi);
    EXPECT_EQ(o->decide(e), Decision::RefineSender);
    e.senderCanSubdivide = false;
    EXPECT_EQ(o->decide(e), Decision::RefineReceiver);
    e.receiverCanSubdivide = false;
    EXPECT_EQ(o->decide(e), Decision::Accept);
}

TEST(PowerOracle, DarkSenderIsAccepted) {
    LinkEstimate e = baseEstimate();
    e.senderB = RGB(0.0);
    Params p;
    p.set("eps", 1e-9);
    EXPECT_EQ(createOracle("bfa", p)->decide(e), Decision::Accept);
}

TEST(FormFactorOracle, ThresholdOnBothDirections) {
    LinkEstimate e = baseEstimate();
    Params p;
    p.set("eps", 0.2);
    EXPECT_EQ(createOracle("ff", p)->decide(e), Decision::Accept);
    p.set("eps", 0.05);
    EXPECT_EQ(createOracle("ff", p)->decide(e), Decision::RefineSender);
    // Receiver looks larger from the sender when the receiver is larger.
    e.receiverArea = 16.0;
    e.F = e.unoccludedF = 0.01;  // F_sr = 0.04
    p.set("eps", 0.02);
    EXPECT_EQ(createOracle("ff", p)->decide(e), Decision::RefineReceiver);
    // min_area stops subdivision.
    p.set("min_area", 100.0);
    EXPECT_EQ(createOracle("ff", p)->decide(e), Decision::Accept);
}

TEST(UniformOracle, RefinesBothSidesToTheLevel) {
    LinkEstimate e = baseEstimate();
    Params p;
    p.set("level", int64_t(2));
    auto o = createOracle("uniform", p);
    e.receiverLevel = 0;
    e.senderLevel = 1;
    EXPECT_EQ(o->decide(e), Decision::RefineBoth);
    e.receiverLevel = 2;
    EXPECT_EQ(o->decide(e), Decision::RefineSender);
    e.senderLevel = 2;
    EXPECT_EQ(o->decide(e), Decision::Accept);
    e.senderLevel = 0;
    e.senderCanSubdivide = false;  // at the minimum area: never refine the receiver instead
    EXPECT_EQ(o->decide(e), Decision::Accept);
}

TEST(Constrain, FallsBackToTheOtherSide) {
    LinkEstimate e = baseEstimate();
    e.receiverCanSubdivide = false;
    EXPECT_EQ(constrain(Decision::RefineBoth, e), Decision::RefineSender);
    EXPECT_EQ(constrain(Decision::RefineReceiver, e), Decision::RefineSender);
    e.senderCanSubdivide = false;
    EXPECT_EQ(constrain(Decision::RefineBoth, e), Decision::Accept);
}
