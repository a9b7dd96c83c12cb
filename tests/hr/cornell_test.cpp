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

namespace {
// One reference solve shared by the tests of this file (it takes ~8 s).
struct CornellReference {
    scene::Scene scene = scene::loadScene("cornell");
    transport::Visibility vis{scene};
    reference::FullMatrixResult ref;
    CornellReference() {
        // Uniform mesh, elements of at most ~40 x 40 mm.
        Params fp;
        fp.set("fm.max_area", 1600.0);
        fp.set("fm.solver", std::string("gauss-seidel"));
        fp.set("fm.tolerance", 1e-9);
        auto fmSettings = reference::FullMatrixSettings::fromParams(fp, "fm");
        fp.reportUnused();
        ref = reference::solveFullMatrix(scene, vis, fmSettings, false);
    }
};
CornellReference& cornellReference() {
    static CornellReference r;
    return r;
}
}  // namespace

TEST(Cornell, BfaErrorDecreasesWithEpsAndReachesTwoPercent) {
    const scene::Scene& s = cornellReference().scene;
    const transport::Visibility& vis = cornellReference().vis;
    const auto& ref = cornellReference().ref;
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

// With clustering the Cornell error stays within 1 % (absolute, of the L2
// figure) of the error without clustering at the same eps.
TEST(Cornell, ClusteringKeepsTheError) {
    const scene::Scene& s = cornellReference().scene;
    const transport::Visibility& vis = cornellReference().vis;
    const auto& ref = cornellReference().ref;
    for (double eps : {1e-3, 1e-4}) {
        double base = 0;
        for (std::string model : {"none", "isotropic", "oriented"}) {
            Params p;
            p.set("oracle.eps", eps);
            p.set("hr.tolerance", 1e-6);
            p.set("cluster.model", model);
            hr::HrSolver solver(s, vis, hr::HrSettings::fromParams(p));
            hr::HrResult r = solver.solve();
            double l2 = reference::computeError(*r.field, *ref.field).l2Lum;
            std::cout << "eps " << eps << " cluster " << model << ": links "
                      << r.hierarchy->numLinks() << " (cluster links "
                      << r.linksSC + r.linksCS + r.linksCC << "), L2(lum) " << l2 << "\n";
            if (model == "none")
                base = l2;
            else
                EXPECT_NEAR(l2, base, 0.01);
        }
    }
}

// The error-driven oracles (`error`: LTG93 bound on the transported radiosity
// error; `kv`: kernel variation after Bekaert & Willems 1996) converge to the
// full-matrix solution as eps decreases, like bfa. Measured against this
// file's reference (printed lines): error 1.9 % -> 1.3 % -> 0.64 % with 0.5k,
// 3.1k, 21k links and kv 2.2 % -> 1.3 % -> 0.75 % with 0.36k, 2.2k, 15k links
// at eps 1e-2, 1e-3, 1e-4 (bfa above: 2.4 % -> 1.4 % -> 0.74 % with 0.3k,
// 2.3k, 23k links). The final 1 % bound leaves 25 % headroom for kv.
TEST(Cornell, ErrorOraclesConvergeWithEps) {
    const scene::Scene& s = cornellReference().scene;
    const transport::Visibility& vis = cornellReference().vis;
    const auto& ref = cornellReference().ref;
    for (std::string oracle : {"error", "kv"}) {
        double prevL2 = 1e30;
        uint64_t prevLinks = 0;
        for (double eps : {1e-2, 1e-3, 1e-4}) {
            Params p;
            p.set("hr.oracle", oracle);
            p.set("oracle.eps", eps);
            p.set("hr.tolerance", 1e-6);
            hr::HrSettings settings = hr::HrSettings::fromParams(p);
            p.reportUnused();
            hr::HrSolver solver(s, vis, settings);
            hr::HrResult r = solver.solve();
            EXPECT_TRUE(r.converged);
            auto err = reference::computeError(*r.field, *ref.field);
            uint64_t links = r.hierarchy->numLinks();
            std::cout << oracle << " eps " << eps << ": links " << links << ", elements "
                      << r.hierarchy->numElements() << ", L2(lum) " << err.l2Lum
                      << ", non-emitter mean ratio " << err.meanRatioNonEmit << "\n";
            // Lit surfaces are not systematically dark: the receivers'
            // averaged senders are held to eps together (hr/receiver_error.h);
            // judged link by link they stayed 3-4 % dark at every eps
            // (error: 0.962, 0.963, 0.971 at 1e-3, 3e-4, 1e-4).
            if (eps <= 1e-4) {
                EXPECT_GT(err.meanRatioNonEmit, 0.98) << oracle;
            }
            EXPECT_LT(err.l2Lum, prevL2) << oracle << " eps " << eps;
            EXPECT_GT(links, prevLinks) << oracle << " eps " << eps;
            prevL2 = err.l2Lum;
            prevLinks = links;
        }
        // The finest solve is within 1 % of the reference (measured ~0.5 %).
        EXPECT_LT(prevL2, 0.01) << oracle;
    }
}
