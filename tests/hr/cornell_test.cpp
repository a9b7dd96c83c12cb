// Convergence of hierarchical radiosity to the full-matrix solution on the
// Cornell box (issue: "hr with bfa at decreasing eps has decreasing L2 error
// against a full-matrix solution at a fine uniform mesh, reaching <= 2 %
// while using far fewer links than n^2").
#include <gtest/gtest.h>

#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/metrics.h"
#include "scene/loader.h"

using namespace hrad;

TEST(Cornell, BfaErrorDecreasesWithEpsAndReachesTwoPercent) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);

    // Reference: uniform mesh, elements of at most ~40 x 40 mm.
    Params fp;
    fp.set("fm.max_area", 1600.0);
    fp.set("fm.solver", std::string("gauss-seidel"));
    fp.set("fm.tolerance", 1e-9);
    auto fmSettings = reference::FullMatrixSettings::fromParams(fp, "fm");
    fp.reportUnused();
    auto ref = reference::solveFullMatrix(s, vis, fmSettings);
    size_t n = ref.field->numElements();
    std::cout << "reference: " << n << " elements, " << ref.stats.formFactors
              << " form factors\n";

    double prevL2 = 1e30;
    double lastL2 = 1e30;
    uint64_t lastLinks = 0;
    for (double eps : {1e-2, 1e-3, 1e-4}) {
        Params p;
        p.set("oracle.eps", eps);
        p.set("hr.tolerance", 1e-6);
        hr::HrSolver solver(s, vis, hr::HrSettings::fromParams(p));
        hr::HrResult r = solver.solve();
        auto err = reference::computeError(*r.field, *ref.field);
        std::cout << "eps " << eps << ": links " << r.hierarchy->numLinks() << ", elements "
                  << r.hierarchy->numElements() << ", L2(lum) " << err.l2Lum << ", L2(rgb) "
                  << err.l2Rgb << "\n";
        EXPECT_LT(err.l2Lum, prevL2);
        prevL2 = err.l2Lum;
        lastL2 = err.l2Lum;
        lastLinks = r.hierarchy->numLinks();
    }
    EXPECT_LE(lastL2, 0.02);
    EXPECT_LT(double(lastLinks), 0.1 * double(n) * double(n));
}
