// Full-matrix reference on the built-in Cornell box (needs scene loaders).
#include <gtest/gtest.h>

#include <algorithm>

#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "scene/loader.h"

namespace hrad::reference {
namespace {

TEST(FullMatrixCornell, SolversAgreeAndErrorShrinksWithLevel) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    FullMatrixSettings st;
    st.level = 3;
    FormFactorMatrix fine = computeFormFactorMatrix(s, vis, st, false);
    FullMatrixResult ref = solveFormFactorMatrix(s, fine, st);
    ASSERT_TRUE(ref.stats.converged);
    for (MatrixSolver solver : {MatrixSolver::Jacobi, MatrixSolver::Southwell}) {
        st.solver = solver;
        FullMatrixResult r = solveFormFactorMatrix(s, fine, st);
        ASSERT_TRUE(r.stats.converged);
        ErrorMetrics e = computeError(*r.field, *ref.field);
        EXPECT_LT(e.linfRgb, 1e-5) << solverName(solver);
    }
    // Coarser full-matrix solutions approach the level-3 one as the level
    // grows (discretisation error, measured through the exact region averages).
    std::vector<double> l1;
    for (int level : {0, 1, 2}) {
        FullMatrixSettings c;
        c.level = level;
        FullMatrixResult r = solveFullMatrix(s, vis, c, false);
        l1.push_back(computeError(*r.field, *ref.field).l1Lum);
    }
    EXPECT_GT(l1[0], l1[1]);
    EXPECT_GT(l1[1], l1[2]);
    EXPECT_GT(l1[2], 0.0);
    // Lit: the brightest element is the light (E = 17, 12, 4 plus reflection).
    double maxLum = 0;
    for (const RGB& b : ref.field->values()) maxLum = std::max(maxLum, luminance(b));
    EXPECT_GT(maxLum, luminance(RGB(17.0, 12.0, 4.0)));
}

}  // namespace
}  // namespace hrad::reference
