// Full-matrix reference solver: analytic furnace, agreement of the three
// iterative methods, and energy balance in a closed scene.
#include "reference/fullmatrix.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tests/reference/box_scenes.h"

namespace hrad::reference {
namespace {

FullMatrixSettings settingsFor(int level, MatrixSolver solver) {
    FullMatrixSettings s;
    s.level = level;
    s.solver = solver;
    return s;
}

const MatrixSolver kSolvers[] = {MatrixSolver::Jacobi, MatrixSolver::GaussSeidel,
                                 MatrixSolver::Southwell};

/// max_i |a_i - b_i|_inf / max_i |b_i|_inf
double maxRelDiff(const std::vector<RGB>& a, const std::vector<RGB>& b) {
    double d = 0, m = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        d = std::max(d, maxComponent(glm::abs(a[i] - b[i])));
        m = std::max(m, maxComponent(glm::abs(b[i])));
    }
    return d / m;
}

TEST(FullMatrix, FurnaceEverySolverGivesEOverOneMinusRho) {
    // Closed box, E = 1, rho = 0.5 everywhere: B = E + rho B (row sums 1), so
    // B = E / (1 - rho) = 2. The error in B is about the row-sum error of the
    // quadrature (dB/B ~ rho/(1-rho) dSum), hence 1e-3.
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    for (int level : {1, 2, 3}) {
        FormFactorMatrix m =
            computeFormFactorMatrix(s, vis, settingsFor(level, MatrixSolver::Jacobi), false);
        EXPECT_EQ(m.size(), 6u << (2 * level));
        for (MatrixSolver solver : kSolvers) {
            FullMatrixResult r = solveFormFactorMatrix(s, m, settingsFor(level, solver));
            ASSERT_TRUE(r.stats.converged) << solverName(solver);
            EXPECT_LE(r.stats.residual, 1e-7);
            double worst = 0;
            for (const RGB& b : r.field->values())
                worst = std::max(worst, maxComponent(glm::abs(b - RGB(2.0))));
            EXPECT_LT(worst / 2.0, 1e-3) << "level " << level << " " << solverName(solver);
        }
    }
}

TEST(FullMatrix, MatrixHasNoDiagonalAndRowSumsNearOneInClosedBox) {
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    FormFactorMatrix m =
        computeFormFactorMatrix(s, vis, settingsFor(2, MatrixSolver::Jacobi), false);
    for (size_t i = 0; i < m.size(); ++i) {
        for (uint64_t k = m.rowStart[i]; k < m.rowStart[i + 1]; ++k) {
            EXPECT_NE(m.cols[k], i);
            EXPECT_NE(m.patchOf[m.cols[k]], m.patchOf[i]);  // coplanar: nothing
        }
        EXPECT_NEAR(m.rowSum(i), 1.0, 1e-3) << "row " << i;
    }
    // Five other walls of 16 elements each are all facing and unoccluded.
    EXPECT_EQ(m.nonZeros(), m.size() * 5 * 16);
    EXPECT_EQ(m.bytes(), (m.size() + 1) * 8 + m.nonZeros() * 12);
}

TEST(FullMatrix, JacobiGaussSeidelSouthwellAgree) {
    scene::Scene s = test::blockerBox();
    transport::Visibility vis(s);
    FormFactorMatrix m =
        computeFormFactorMatrix(s, vis, settingsFor(2, MatrixSolver::Jacobi), false);
    std::vector<std::vector<RGB>> sols;
    std::vector<int64_t> iters;
    for (MatrixSolver solver : kSolvers) {
        FullMatrixResult r = solveFormFactorMatrix(s, m, settingsFor(2, solver));
        ASSERT_TRUE(r.stats.converged) << solverName(solver);
        EXPECT_LE(relativeResidual(s, m, r.field->values()), 1e-7) << solverName(solver);
        // History: one entry per check, ending at the reported residual.
        ASSERT_FALSE(r.stats.residualHistory.empty());
        EXPECT_EQ(r.stats.residualHistory.back(), r.stats.residual);
        sols.push_back(r.field->values());
        iters.push_back(r.stats.iterations);
    }
    EXPECT_LT(maxRelDiff(sols[0], sols[1]), 1e-5);
    EXPECT_LT(maxRelDiff(sols[2], sols[1]), 1e-5);
    // Gauss-Seidel needs fewer sweeps than Jacobi.
    EXPECT_LT(iters[1], iters[0]);
    // Something actually happened: the blocker is lit, its hidden side darker.
    double maxB = 0;
    for (const RGB& b : sols[1]) maxB = std::max(maxB, maxComponent(b));
    EXPECT_GT(maxB, 10.0);
}

TEST(FullMatrix, EnergyBalanceInClosedScene) {
    // With H_i = sum_j F_ij B_j the radiosity arriving at element i (per unit
    // area), B_i = E_i + rho_i H_i. In a closed scene, reciprocity
    // (A_i F_ij = A_j F_ji) and closure (sum_i F_ji = 1) give
    //   sum_i A_i H_i = sum_j B_j sum_i A_j F_ji = sum_j A_j B_j,
    // i.e. the power arriving equals the power leaving, and subtracting
    // sum_i A_i rho_i H_i from both sides:
    //   emitted  sum_i A_i E_i  =  absorbed  sum_i A_i (1 - rho_i) H_i,
    // with H_i = (B_i - E_i) / rho_i (every rho > 0 here). The discrete
    // matrix satisfies reciprocity and closure only up to quadrature error,
    // so this checks form factors and solver together: 1e-3 relative.
    scene::Scene s = test::blockerBox();
    transport::Visibility vis(s);
    FullMatrixResult r = solveFullMatrix(s, vis, settingsFor(3, MatrixSolver::GaussSeidel), false);
    const scene::UniformField& f = *r.field;
    RGB emitted(0.0), absorbed(0.0);
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        const scene::Patch& patch = s.patches[p];
        for (size_t l = 0; l < f.count(p); ++l) {
            size_t i = f.offset(p) + l;
            RGB H = (f.value(i) - patch.emission) / patch.rho;
            emitted += f.area(i) * patch.emission;
            absorbed += f.area(i) * (RGB(1.0) - patch.rho) * H;
        }
    }
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(absorbed[c] / emitted[c], 1.0, 1e-3) << "channel " << c;
    EXPECT_NEAR(luminance(emitted), luminance(s.emittedPower()), 1e-12);
}

TEST(FullMatrix, SouthwellAmbientOnlyMattersBeforeConvergence) {
    scene::Scene s = test::blockerBox();
    transport::Visibility vis(s);
    FullMatrixSettings st = settingsFor(1, MatrixSolver::Southwell);
    FormFactorMatrix m = computeFormFactorMatrix(s, vis, st, false);
    st.maxIterations = 1;  // n shots only: far from converged
    FullMatrixResult plain = solveFormFactorMatrix(s, m, st);
    EXPECT_FALSE(plain.stats.converged);
    st.ambient = true;
    FullMatrixResult amb = solveFormFactorMatrix(s, m, st);
    FullMatrixResult exact = solveFormFactorMatrix(s, m, settingsFor(1, MatrixSolver::GaussSeidel));
    // The ambient term adds the missing light on average: the total power
    // with ambient is closer to the converged one.
    double p0 = luminance(plain.field->totalPower()), p1 = luminance(amb.field->totalPower());
    double pe = luminance(exact.field->totalPower());
    EXPECT_GT(p1, p0);
    EXPECT_LT(std::fabs(p1 - pe), std::fabs(p0 - pe));
    // Converged with ambient: within the tolerance of the plain solution.
    st.maxIterations = 10000;
    FullMatrixResult ambConv = solveFormFactorMatrix(s, m, st);
    EXPECT_LT(maxRelDiff(ambConv.field->values(), exact.field->values()), 1e-5);
}

TEST(FullMatrix, SettingsFromParams) {
    Params p;
    p.set("fm.level", int64_t(2));
    p.set("fm.solver", std::string("southwell"));
    p.set("fm.tolerance", 1e-9);
    p.set("fm.ambient", true);
    p.set("fm.ff.points", int64_t(4));
    FullMatrixSettings s = FullMatrixSettings::fromParams(p);
    EXPECT_EQ(s.level, 2);
    EXPECT_EQ(s.solver, MatrixSolver::Southwell);
    EXPECT_EQ(s.tolerance, 1e-9);
    EXPECT_TRUE(s.ambient);
    EXPECT_EQ(s.ff.points, 4);
    EXPECT_NO_THROW(p.reportUnused());
    EXPECT_NE(s.describe().find("southwell"), std::string::npos);

    Params bad;
    bad.set("fm.solver", std::string("conjugate-gradient"));
    EXPECT_THROW(FullMatrixSettings::fromParams(bad), InputError);
    Params neg;
    neg.set("fm.tolerance", -1.0);
    EXPECT_THROW(FullMatrixSettings::fromParams(neg), InputError);
}

TEST(FullMatrix, MaxAreaChoosesLevels) {
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    FullMatrixSettings st;
    st.maxArea = 1.0 / 16;  // unit faces: level 2
    FormFactorMatrix m = computeFormFactorMatrix(s, vis, st, false);
    for (uint8_t l : m.levels) EXPECT_EQ(l, 2);
}

}  // namespace
}  // namespace hrad::reference
