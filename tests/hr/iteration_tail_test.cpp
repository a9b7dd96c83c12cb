// hr/iteration_tail.h: the geometric-tail estimate the solver stops on.
#include "hr/iteration_tail.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace hrad;
using namespace hrad::hr;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

TEST(IterationTail, GeometricChangesGiveTheirTail) {
    IterationTail t;
    const RGB power(100.0);
    EXPECT_EQ(t.add(RGB(1.0), power, IterationTail::Step::kClean),
              kInf);  // one change: no ratio yet
    // q = 0.5: the tail after a change d is d q / (1 - q) = d.
    EXPECT_NEAR(t.add(RGB(0.5), power, IterationTail::Step::kClean), 0.5 / 100.0, 1e-15);
    EXPECT_NEAR(t.add(RGB(0.25), power, IterationTail::Step::kClean), 0.25 / 100.0, 1e-15);
    // A refinement (not clean) starts a new run.
    EXPECT_EQ(t.add(RGB(0.1), power, IterationTail::Step::kBreak), kInf);
    EXPECT_EQ(t.add(RGB(0.05), power, IterationTail::Step::kClean), kInf);
    EXPECT_NEAR(t.add(RGB(0.025), power, IterationTail::Step::kClean), 0.025 / 100.0, 1e-15);
}

// Changes that shrink irregularly: single steps that do not contract are
// judged over the window, so a channel falling 2x every two steps has a
// finite tail; one growing over the window has none.
TEST(IterationTail, IrregularChangesUseTheWindow) {
    IterationTail t;
    const RGB power(100.0);
    const double d[] = {1.0, 0.4, 0.5, 0.2, 0.25};
    double last = 0;
    for (double x : d) last = t.add(RGB(x, 0.0, 0.0), power, IterationTail::Step::kClean);
    // The last step (0.2 -> 0.25) grows; over the window 1 -> 0.25 in 4
    // steps, q = 0.25^(1/4).
    const double q = std::pow(0.25, 0.25);
    EXPECT_NEAR(last, 0.25 * q / (1 - q) / 100.0, 1e-12);
    // Growing over the whole window: no rate, no stop.
    IterationTail g;
    for (double x : {0.1, 0.12, 0.11, 0.13, 0.15})
        last = g.add(RGB(x, 0.0, 0.0), power, IterationTail::Step::kClean);
    EXPECT_EQ(last, kInf);
}

TEST(IterationTail, OscillatingAndSettledChannels) {
    IterationTail t;
    const RGB power(10.0);
    t.add(RGB(0.2, 1e-20, 0.0), power, IterationTail::Step::kClean);
    // Red oscillates (the change itself), green is settled, blue unchanged.
    EXPECT_NEAR(t.add(RGB(-0.1, 1e-20, 0.0), power, IterationTail::Step::kClean), 0.1 / 10.0,
                1e-15);
}

// A relaxation stopped by its budget (kIrregular) stays in the run, but the
// run's rate is then its slowest step, and needs two steps: one step that
// looks fast (0.1 after 1.0) does not stop the solve early.
TEST(IterationTail, IrregularStepsTakeTheSlowestStep) {
    IterationTail t;
    const RGB power(100.0);
    using S = IterationTail::Step;
    EXPECT_EQ(t.add(RGB(1.0), power, S::kIrregular), kInf);
    EXPECT_EQ(t.add(RGB(0.5), power, S::kIrregular), kInf);  // one step: not enough
    // Steps 0.5 and 0.2: q = 0.5, tail = 0.1 * 0.5 / 0.5.
    EXPECT_NEAR(t.add(RGB(0.1), power, S::kIrregular), 0.1 / 100.0, 1e-15);
    // The same changes in a clean run take the last step (q = 0.2).
    IterationTail c;
    c.add(RGB(1.0), power, S::kClean);
    c.add(RGB(0.5), power, S::kClean);
    EXPECT_NEAR(c.add(RGB(0.1), power, S::kClean), 0.1 * 0.25 / 100.0, 1e-15);
    // A refinement breaks an irregular run like a clean one.
    EXPECT_EQ(t.add(RGB(0.05), power, S::kBreak), kInf);
    EXPECT_EQ(t.add(RGB(0.04), power, S::kClean), kInf);
}
