// hr/eps_power.h: the power eps is a fraction of, from the reflected power
// after each iteration.
#include "hr/eps_power.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace hrad;
using namespace hrad::hr;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

// A Jacobi iteration on a closed box of reflectance rho, E = 1: the
// reflected power after k gathers is rho + ... + rho^k, heading to
// rho / (1 - rho). Three terms predict it exactly.
TEST(EpsPowerTracker, PredictsAGeometricSeriesExactly) {
    const double rho = 0.5;
    EXPECT_NEAR(predictedReflected(RGB(0.0), RGB(rho), RGB(rho + rho * rho)), rho / (1 - rho),
                1e-15);
    // The largest channel's prediction counts.
    EXPECT_NEAR(predictedReflected(RGB(0.0, 0.0, 0.0), RGB(0.5, 0.2, 0.1),
                                   RGB(0.75, 0.24, 0.11)),
                1.0, 1e-15);
    // A fall (refinement closed a leak) or a settled channel: the power so far.
    EXPECT_EQ(predictedReflected(RGB(1.0), RGB(2.0), RGB(1.5)), 1.5);
    EXPECT_EQ(predictedReflected(RGB(1.0), RGB(2.0), RGB(2.0)), 2.0);
    // Changes that do not shrink: no prediction.
    EXPECT_EQ(predictedReflected(RGB(0.0), RGB(1.0), RGB(2.5)), kInf);
    EXPECT_EQ(predictedReflected(RGB(1.0), RGB(0.5), RGB(0.7)), kInf);
}

TEST(EpsPowerTracker, SmallerIsTheEmittedPowerUntilItCanPredict) {
    // An open scene that reflects a tenth of what it emits: 0.05, 0.075, ...
    EpsPowerTracker t(EpsPower::Smaller, 1.0, RGB(0.0));
    EXPECT_EQ(t.power(), 1.0);  // before the first gather
    t.add(RGB(0.05));
    EXPECT_EQ(t.power(), 1.0);  // one change: no ratio yet
    t.add(RGB(0.075));
    EXPECT_NEAR(t.power(), 0.1, 1e-15);
    t.add(RGB(0.0875));
    EXPECT_NEAR(t.power(), 0.1, 1e-15);
    // A change that does not shrink (q = 1, as an extrapolation's jump
    // may give): the last prediction stands ...
    t.add(RGB(0.1));
    EXPECT_NEAR(t.power(), 0.1, 1e-15);
    // ... or the power so far where it has passed it.
    t.add(RGB(0.2));
    EXPECT_NEAR(t.power(), 0.2, 1e-15);
    // Never above the emitted power.
    t.add(RGB(0.6));
    t.add(RGB(0.9));
    EXPECT_EQ(t.power(), 1.0);
}

TEST(EpsPowerTracker, EmittedAndReflectedModes) {
    EpsPowerTracker e(EpsPower::Emitted, 2.0, RGB(0.0)), r(EpsPower::Reflected, 2.0, RGB(0.0));
    EXPECT_EQ(e.power(), 2.0);
    EXPECT_EQ(r.power(), 2.0);  // nothing reflected yet
    for (double p : {0.1, 0.15, 0.175}) {
        e.add(RGB(p, 0.5 * p, 0.0));
        r.add(RGB(p, 0.5 * p, 0.0));
        EXPECT_EQ(e.power(), 2.0);
        EXPECT_EQ(r.power(), p);  // the power so far, max channel
    }
    EXPECT_STREQ(epsPowerName(EpsPower::Smaller), "smaller");
    EXPECT_STREQ(epsPowerName(EpsPower::Emitted), "emitted");
    EXPECT_STREQ(epsPowerName(EpsPower::Reflected), "reflected");
    for (EpsPower e : {EpsPower::Emitted, EpsPower::Reflected, EpsPower::Smaller})
        EXPECT_EQ(epsPowerFromName(epsPowerName(e)), e);
}
