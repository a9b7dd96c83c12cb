// Issue 64: SIGINT/SIGTERM stop the reference solvers at a safe point
// (core/stop.h). A real signal is raised in a forked child (the flag is
// process-wide and stays set, so each case runs in its own process, as a
// gtest death test): the solver must return promptly, keep what it computed
// and say interrupted. The command-line cases (signals timed from outside)
// are in tests/apps/hostile_io_test.cpp; this covers the full-matrix
// iterations, which a signal from outside cannot be timed to reach.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>

#include "core/interrupt.h"
#include "reference/fullmatrix.h"
#include "reference/montecarlo.h"
#include "reference/progressive.h"
#include "tests/reference/box_scenes.h"

namespace hrad::reference {
namespace {

const MatrixSolver kSolvers[] = {MatrixSolver::Jacobi, MatrixSolver::GaussSeidel, MatrixSolver::Southwell};

// A matrix computed before the signal, solved after it: the solve stops at
// its first check with B = E (no sweep or shot), marked interrupted.
TEST(InterruptDeathTest, FullMatrixIterationsStopAtTheFirstCheck) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    for (MatrixSolver solver : kSolvers) {
        EXPECT_EXIT(
            {
                scene::Scene s = test::furnaceBox();
                transport::Visibility vis(s);
                FullMatrixSettings st;
                st.level = 2;
                st.solver = solver;
                st.tolerance = 1e-12;
                FormFactorMatrix m = computeFormFactorMatrix(s, vis, st, false);
                bool okBefore = !m.interrupted;
                catchInterrupts();
                std::raise(SIGINT);
                FullMatrixResult r = solveFormFactorMatrix(s, m, st);
                bool ok = okBefore && r.stats.interrupted && !r.stats.converged && r.stats.iterations == 0 &&
                          r.field->value(0) == s.patches[0].emission;
                std::exit(ok ? 7 : 1);
            },
            ::testing::ExitedWithCode(7), "")
            << "solver " << int(solver);
    }
}

// A signal before the matrix: no row is computed, nothing is solved, and the
// field is E (what was computed), marked interrupted; never a silent zero.
TEST(InterruptDeathTest, FullMatrixProgressiveAndMonteCarloStopOnASignal) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_EXIT(
        {
            scene::Scene s = test::furnaceBox();
            transport::Visibility vis(s);
            catchInterrupts();
            std::raise(SIGTERM);
            FullMatrixSettings fm;
            fm.level = 2;
            FullMatrixResult f = solveFullMatrix(s, vis, fm, false);
            ProgressiveSettings pr;
            ProgressiveResult p = solveProgressive(s, vis, pr, false);
            MonteCarloSettings mc;
            MonteCarloResult c = solveMonteCarlo(s, vis, mc, false);
            bool ok = f.stats.interrupted && f.stats.formFactors == 0 && f.field->value(0) == s.patches[0].emission &&
                      p.interrupted && p.shots == 0 && !p.converged && c.stats.interrupted &&
                      c.stats.estimated == 0 && std::isnan(c.field->value(0).r);
            std::exit(ok ? 7 : 1);
        },
        ::testing::ExitedWithCode(7), "");
}

}  // namespace
}  // namespace hrad::reference
