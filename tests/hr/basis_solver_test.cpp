// Polynomial bases in the hierarchical solver (hr.basis; scene/basis.h,
// transport/coupling.h, hr/hierarchy.h): the furnace for every basis on quads
// and triangles, exact push-pull of a linear field, reciprocity of the
// coupling coefficients, the constant basis unchanged, and saved solutions.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/rng.h"
#include "hr/solver.h"
#include "oracles/registry.h"
#include "reference/cache.h"
#include "scene/builtin.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"

using namespace hrad;
using namespace hrad::hr;

namespace {

HrSettings basisSettings(const std::string& oracle, double eps, const std::string& basis) {
    Params p;
    p.set("hr.oracle", oracle);
    if (oracle == "uniform")
        p.set("oracle.level", int64_t(2));
    else
        p.set("oracle.eps", eps);
    p.set("hr.tolerance", 1e-7);
    p.set("hr.max_iterations", int64_t(400));
    p.set("cluster.model", std::string("none"));
    p.set("hr.basis", basis);
    HrSettings s = HrSettings::fromParams(p);
    p.reportUnused();
    return s;
}

/// The furnace box with every face split into two triangles.
scene::Scene triangleFurnace(double rho) {
    scene::Scene q = test::furnaceBox(1.0, rho);
    scene::Scene s;
    s.name = "test-furnace-triangles";
    uint32_t m = s.addMaterial({"furnace", RGB(rho), RGB(1.0)});
    for (const auto& p : q.patches) {
        s.addTriangle(p.v[0], p.v[1], p.v[2], m);
        s.addTriangle(p.v[0], p.v[2], p.v[3], m);
    }
    return s;
}

/// Largest relative deviation from E/(1-rho) of the field at random points of
/// every leaf, and of every leaf's mean.
double furnaceWorst(const scene::Scene& s, const HrSettings& st, double rho, uint64_t* links) {
    transport::Visibility vis(s);
    HrSolver solver(s, vis, st);
    HrResult r = solver.solve();
    EXPECT_TRUE(r.converged);
    const double exact = 1.0 / (1.0 - rho);
    double worst = 0.0;
    const Hierarchy& h = *r.hierarchy;
    for (uint32_t e = 0; e < h.numElements(); ++e)
        if (h.isLeaf(e))
            worst = std::max(worst, maxComponent(glm::abs(h.B(e) - RGB(exact))) / exact);
    Pcg32 rng(3);
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        for (int k = 0; k < 50; ++k) {
            double u = rng.nextDouble(), v = rng.nextDouble();
            if (s.patches[p].kind == scene::PatchKind::Triangle && u + v > 1) {
                u = 1 - u;
                v = 1 - v;
            }
            worst =
                std::max(worst, maxComponent(glm::abs(r.field->at(p, u, v) - RGB(exact))) / exact);
        }
    if (links) *links = h.numLinks();
    return worst;
}

}  // namespace

class FurnaceAllBases : public ::testing::TestWithParam<std::string> {};

// With the `uniform` oracle every leaf gathers from a partition of the box at
// its own level, and at every receiver quadrature point the exact point form
// factors to the senders sum to one, so sum_s K^{a0} = delta_a0 (the rule
// integrates phi_a exactly): the constant field is a fixed point for every
// basis. Tolerance 1e-5: the coupling coefficients are stored as floats.
TEST_P(FurnaceAllBases, QuadsAndTrianglesAreExact) {
    for (double rho : {0.5, 0.9}) {
        EXPECT_LT(furnaceWorst(test::furnaceBox(1.0, rho), basisSettings("uniform", 0, GetParam()),
                               rho, nullptr),
                  1e-5)
            << "quads rho " << rho;
        EXPECT_LT(furnaceWorst(triangleFurnace(rho), basisSettings("uniform", 0, GetParam()), rho,
                               nullptr),
                  1e-5)
            << "triangles rho " << rho;
    }
}

// bfa judges links one by one; receivers that gather through coarse links of
// their ancestors see those links' averages (solver_test.cpp: 5.2 % L1 for
// the constant basis at eps 1e-3, worst leaf larger). A higher-order basis
// carries the variation of those links' point form factors across the
// receiver, so its worst error must not be larger than the constant basis's.
// Measured (bfa judging higher-order links by their projection residual):
// worst 0.110 with 2,352 links (constant), 0.110 / 2,352 (linear), 0.055 /
// 912 (quadratic), 0.0065 / 408 (cubic); with basis_residual = false,
// linear has 0.028 on the constant's 2,352 links.
TEST_P(FurnaceAllBases, BfaIsNoWorseThanConstant) {
    uint64_t lc = 0, lb = 0;
    double c =
        furnaceWorst(test::furnaceBox(1.0, 0.5), basisSettings("bfa", 1e-3, "constant"), 0.5, &lc);
    double b =
        furnaceWorst(test::furnaceBox(1.0, 0.5), basisSettings("bfa", 1e-3, GetParam()), 0.5, &lb);
    std::cout << GetParam() << ": worst " << b << " (" << lb << " links), constant " << c << " ("
              << lc << " links)\n";
    EXPECT_LE(b, c * 1.0001);
}

// The error oracle judges a receiver by the sum of its links' projection
// residuals, which cancel in a closed box (Coupling.ResidualSamplesOfAClosed
// BoxCancel): the furnace stays exact for every basis, as for the constant
// one (hr/receiver_error.h).
TEST_P(FurnaceAllBases, ErrorOracleKeepsItExact) {
    uint64_t links = 0;
    double worst = furnaceWorst(test::furnaceBox(1.0, 0.5),
                                basisSettings("error", 1e-3, GetParam()), 0.5, &links);
    std::cout << GetParam() << ": worst " << worst << " (" << links << " links)\n";
    EXPECT_LT(worst, 1e-4);
}

INSTANTIATE_TEST_SUITE_P(Bases, FurnaceAllBases,
                         ::testing::Values("constant", "linear", "quadratic", "cubic"));

// A linear field (as a linearly varying emitter would give) handed to the
// root of a patch is reproduced exactly on every leaf after push-pull for
// every basis of degree >= 1, pointwise (HierarchyField::at) and in the
// means over any region (HierarchyField::average), including regions below
// the leaves; the constant basis reproduces only the means of the leaves'
// ancestors.
TEST(BasisHierarchy, LinearFieldIsReproducedExactlyByDegreeOneAndUp) {
    for (int degree = 1; degree <= 3; ++degree) {
        for (auto kind : {scene::PatchKind::Quad, scene::PatchKind::Triangle}) {
            scene::Scene s;
            uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
            // A sheared (non-rectangular) parallelogram or triangle.
            if (kind == scene::PatchKind::Quad)
                s.addQuad(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2.5, 1, 0), Vec3(0.5, 1, 0), m);
            else
                s.addTriangle(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0.5, 1, 0), m);
            Hierarchy h(s, nullptr, cluster::ClusterModel::None, degree);
            // f(u, v) = 1 + 2u - 3v per channel (scaled): project it on the
            // root's basis by quadrature (exact for degree 1 + p).
            auto f = [](double u, double v, int c) { return (1.0 + c) * (1.0 + 2 * u - 3 * v); };
            const scene::Basis& b = h.basis()->of(kind);
            scene::QuadratureRule q = scene::referenceRule(kind, 4);
            double phi[scene::kMaxBasisSize];
            RGB coef[scene::kMaxBasisSize] = {};
            for (size_t k = 0; k < q.size(); ++k) {
                b.eval(q.points[k].x, q.points[k].y, phi);
                for (int a = 0; a < b.size(); ++a)
                    for (int c = 0; c < 3; ++c)
                        coef[a][c] += q.weights[k] * phi[a] * f(q.points[k].x, q.points[k].y, c);
            }
            // Refine irregularly: the root, child 1, child 1's child 3.
            h.subdivide(0);
            h.subdivide(h.firstChild(0) + 1);
            h.subdivide(h.firstChild(h.firstChild(0) + 1) + 3);
            h.gathered(0) = coef[0];
            for (int a = 1; a < b.size(); ++a) h.gatheredHi(0)[a - 1] = coef[a];
            h.pushPull();
            HierarchyField field(h);
            Pcg32 rng(11);
            for (int k = 0; k < 200; ++k) {
                double u = rng.nextDouble(), v = rng.nextDouble();
                if (kind == scene::PatchKind::Triangle && u + v > 1) {
                    u = 1 - u;
                    v = 1 - v;
                }
                RGB got = field.at(0, u, v);
                for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], f(u, v, c), 1e-12) << degree;
            }
            // The exports' corner values (RadiosityField::leafPoint).
            field.forEachLeaf(0, [&](scene::ElementKey key, const RGB& value) {
                scene::Domain d = scene::keyDomain(kind, key);
                for (int i = 0; i < (kind == scene::PatchKind::Quad ? 4 : 3); ++i) {
                    Vec2 lc = scene::cornerLocal(kind, i);
                    Vec2 uv = scene::domainParam(d, lc.x, lc.y);
                    RGB got = field.leafPoint(0, key, value, lc.x, lc.y);
                    for (int c = 0; c < 3; ++c)
                        EXPECT_NEAR(got[c], f(uv.x, uv.y, c), 1e-12) << degree;
                }
            });
            // Means over regions at levels 0..5 (below the leaves too).
            for (int k = 0; k < 50; ++k) {
                scene::ElementKey key =
                    scene::keyAt(kind, 0.3 * rng.nextDouble(), 0.3 * rng.nextDouble(), k % 6);
                scene::Domain d = scene::keyDomain(kind, key);
                // The mean of a linear function over a domain is its value at
                // the centroid: (1/2, 1/2) on quads, (1/3, 1/3) on triangles.
                double ca = kind == scene::PatchKind::Quad ? 0.5 : 1.0 / 3.0;
                Vec2 uv = scene::domainParam(d, ca, ca);
                RGB got = field.average(0, key);
                for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], f(uv.x, uv.y, c), 1e-12) << degree;
            }
        }
    }
}

// A_r K_rs^{ab} = A_s K_sr^{ba}. Entries with a, b >= 1 use the same
// point-to-point quadrature both ways and agree to float round-off; the b = 0
// column takes the exact point-to-element form factor as inner integral and
// the a = 0 row the quadrature of the kernel, so those agree to the
// quadrature error: measured at most 3.7e-6 of the largest coefficient for
// parallel plates and 1.7e-4 for perpendicular plates sharing an edge
// (linear; less for higher degrees, which use more points); the test allows
// 1e-3.
// K^{00} is the form factor.
TEST(Coupling, IsReciprocalAndK00IsTheFormFactor) {
    for (const char* spec : {"plates:parallel:1:1:1", "plates:perpendicular:1:1:1"}) {
        scene::Scene s = scene::makeBuiltin(spec);
        transport::Visibility vis(s);
        transport::FormFactorSettings fs;
        fs.points = 6;
        transport::FormFactorEngine ff(s, &vis, fs);
        for (int degree = 1; degree <= 3; ++degree) {
            scene::BasisSet basis(degree);
            transport::CouplingEngine ce(s, &vis, ff, basis, degree + 4);
            const int n = basis.size();
            // Elements: patch 0 root, patch 1's child 2 (unequal areas).
            transport::ElementRef r{0, scene::Domain{}, 1};
            transport::ElementRef e{1, scene::childDomain(s.patches[1].kind, scene::Domain{}, 2),
                                    2};
            double Ar = scene::elementArea(s.patches[0], r.dom),
                   Ae = scene::elementArea(s.patches[1], e.dom);
            std::vector<float> Kre(size_t(n * n)), Ker(size_t(n * n));
            ce.compute(r, e, 1.0, false, Kre.data());
            ce.compute(e, r, 1.0, false, Ker.data());
            double big = 0;
            for (float k : Kre) big = std::max(big, std::fabs(Ar * double(k)));
            double worst0 = 0;
            for (int a = 0; a < n; ++a)
                for (int b = 0; b < n; ++b) {
                    double x = Ar * double(Kre[size_t(a * n + b)]),
                           y = Ae * double(Ker[size_t(b * n + a)]);
                    if (a > 0 && b > 0)
                        EXPECT_NEAR(x, y, 1e-6 * big) << spec << " " << a << "," << b;
                    else
                        worst0 = std::max(worst0, std::fabs(x - y) / big);
                }
            std::cout << spec << " degree " << degree << ": K00 " << Kre[0]
                      << ", reciprocity of row/column 0 within " << worst0
                      << " of the largest coefficient\n";
            EXPECT_LT(worst0, 1e-3) << spec;
            double F = ff.compute(r, e).F;
            EXPECT_NEAR(Kre[0], F, 1e-4 * F) << spec;
        }
    }
}

// The projection residuals the receiver aggregate sums for a polynomial
// basis (transport CouplingEngine::residualSamples, hr/receiver_error.h):
// in a closed box the point form factors from any receiver point to all the
// other elements sum to one, and the projection of one is one, so the
// residuals of a receiver's links cancel at every sample point. This is what
// keeps the furnace exact under the error-driven oracles for every basis.
// They are also the residual projectionResidual() bounds: their largest
// magnitude is of its order (the check points differ: 5 % against 1e-6
// inset).
TEST(Coupling, ResidualSamplesOfAClosedBoxCancel) {
    scene::Scene s = test::furnaceBox(1.0, 0.5);
    transport::Visibility vis(s);
    transport::FormFactorEngine ff(s, &vis, transport::FormFactorSettings{});
    for (int degree = 1; degree <= 3; ++degree) {
        scene::BasisSet basis(degree);
        transport::CouplingEngine ce(s, &vis, ff, basis, degree + 2);
        // All elements of level 1 (4 per face), receiver: face 0's child 1.
        std::vector<transport::ElementRef> els;
        for (uint32_t p = 0; p < s.patches.size(); ++p)
            for (int c = 0; c < 4; ++c)
                els.push_back({p, scene::childDomain(s.patches[p].kind, scene::Domain{}, c),
                               uint32_t(els.size())});
        const transport::ElementRef r = els[1];
        double sum[transport::FormFactorEngine::kMaxKernelSamples] = {};
        double largest = 0.0, bound = 0.0;
        int m = 0;
        for (const auto& e : els) {
            if (e.patch == r.patch) continue;
            double v[transport::FormFactorEngine::kMaxKernelSamples];
            m = ce.residualSamples(r, e, v);
            for (int k = 0; k < m; ++k) {
                sum[k] += v[k];
                largest = std::max(largest, std::fabs(v[k]));
            }
            bound = std::max(bound, ce.projectionResidual(r, e));
        }
        ASSERT_EQ(m, 9);
        std::cout << "degree " << degree << ": largest link residual " << largest
                  << ", projectionResidual " << bound << "\n";
        EXPECT_GT(largest, 1e-3);  // the links' residuals are not zero ...
        for (int k = 0; k < m; ++k)
            EXPECT_NEAR(sum[k], 0.0, 1e-9) << "point " << k;  // ... their sum is
        EXPECT_LT(largest, 20.0 * bound);
        EXPECT_GT(largest, 0.05 * bound);
    }
}

// The check on the point-to-point rule (hr.basis_check, transport/
// coupling.h): two slivers 7 mm x 1.2 m meeting at a right angle along their
// long edge (the chamfers of the classroom's tables) defeat it, and the link
// keeps its exact column 0 and no higher columns; two unit squares meeting
// at a right angle (a Cornell box corner) are integrated well and keep all.
TEST(Coupling, SliversKeepOnlyTheSendersMean) {
    const double w = 0.007, len = 1.2;
    scene::Scene s;
    s.name = "test-sliver-groove";
    uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    ASSERT_TRUE(s.addQuad({0, 0, 0}, {0, 0, w}, {len, 0, w}, {len, 0, 0}, m));  // normal +y
    ASSERT_TRUE(s.addQuad({0, 0, 0}, {len, 0, 0}, {len, w, 0}, {0, w, 0}, m));  // normal +z
    ASSERT_TRUE(s.addQuad({0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, m));      // a corner of
    ASSERT_TRUE(s.addQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m));      // unit squares
    EXPECT_GT(s.patches[0].normal.y, 0.99);
    EXPECT_GT(s.patches[1].normal.z, 0.99);
    transport::FormFactorEngine ff(s, nullptr, transport::FormFactorSettings{});
    for (int degree = 1; degree <= 2; ++degree) {
        scene::BasisSet basis(degree);
        transport::CouplingEngine ce(s, nullptr, ff, basis, degree + 2, 1, 0.5);
        const int n = basis.size();
        std::vector<float> K(size_t(n * n));
        transport::ElementRef a{0, scene::Domain{}, 0}, b{1, scene::Domain{}, 1};
        ce.compute(a, b, 1.0, false, K.data());
        EXPECT_EQ(ce.fallbacks(), 1u);
        EXPECT_NEAR(K[0], ff.compute(a, b).F, 1e-3 * K[0]);
        for (int r = 0; r < n; ++r)
            for (int c = 1; c < n; ++c) EXPECT_EQ(K[size_t(r * n + c)], 0.f) << r << "," << c;
        transport::ElementRef c{2, scene::Domain{}, 2}, d{3, scene::Domain{}, 3};
        ce.compute(c, d, 1.0, false, K.data());
        EXPECT_EQ(ce.fallbacks(), 1u);  // the squares pass
        double higher = 0;
        for (int r = 0; r < n; ++r)
            for (int col = 1; col < n; ++col)
                higher = std::max(higher, double(std::fabs(K[size_t(r * n + col)])));
        EXPECT_GT(higher, 1e-3);
        // Off, the sliver link gets its (wrong) higher columns.
        transport::CouplingEngine off(s, nullptr, ff, basis, degree + 2, 1, 1e300);
        off.compute(a, b, 1.0, false, K.data());
        EXPECT_EQ(off.fallbacks(), 0u);
    }
}

// The error-driven oracles see the basis (oracles/error_oracle.h,
// kv_oracle.h): a receiver is judged by what the projections of its links'
// kernels miss, so at the same eps higher degrees refine less. Measured on
// the perpendicular plates at eps 1e-4: error 1,658 / 518 / 290 / 236 links,
// kv 1,004 / 446 / 284 / 248 (constant / linear / quadratic / cubic); judged
// like the constant basis they had the constant's links, 1,658 and 1,004.
// ff (oracles/ff_oracle.h) judges a higher-order link by the residual form
// factor: at F_eps 1e-2, 76,340 / 27,140 / 11,012 / 8,132 links.
TEST(BasisSolver, ErrorOraclesRefineLessForHigherDegrees) {
    scene::Scene s = scene::makeBuiltin("plates:perpendicular:1:1:1");
    transport::Visibility vis(s);
    for (const char* oracle : {"error", "kv", "ff"}) {
        uint64_t last = UINT64_MAX, constant = 0;
        const double eps = std::string(oracle) == "ff" ? 1e-2 : 1e-4;
        for (const char* b : {"constant", "linear", "quadratic", "cubic"}) {
            HrResult r = HrSolver(s, vis, basisSettings(oracle, eps, b)).solve();
            const uint64_t links = r.hierarchy->numLinks();
            std::cout << oracle << " " << b << ": " << links << " links\n";
            EXPECT_LT(links, last) << oracle << " " << b;
            if (last == UINT64_MAX) constant = links;
            last = links;
        }
        EXPECT_LT(last, constant / 3) << oracle;
    }
}

// The constant basis is the solver of before this option existed: the same
// numbers whether hr.basis is unset or "constant".
TEST(BasisSolver, ConstantIsTheDefault) {
    scene::Scene s = scene::makeBuiltin("cornell");
    transport::Visibility vis(s);
    HrSettings a = test::hrSettings("bfa", 1e-2);
    HrSettings b = basisSettings("bfa", 1e-2, "constant");
    b.tolerance = a.tolerance;
    b.maxIterations = a.maxIterations;
    HrResult ra = HrSolver(s, vis, a).solve(), rb = HrSolver(s, vis, b).solve();
    ASSERT_EQ(ra.hierarchy->numElements(), rb.hierarchy->numElements());
    ASSERT_EQ(ra.hierarchy->numLinks(), rb.hierarchy->numLinks());
    for (uint32_t e = 0; e < ra.hierarchy->numElements(); ++e)
        ASSERT_EQ(ra.hierarchy->B(e), rb.hierarchy->B(e));
}

// bfa sees the basis (oracles/bfa_oracle.h): a higher-order link is judged by
// what its projection misses, so at the same eps higher degrees refine less
// (measured on cornell at eps 1e-3 with the receiver check, the default:
// 23,930 / 15,284 / 12,161 / 10,353 links for constant / linear / quadratic
// / cubic); with basis_residual = false the links are judged as for the
// constant basis.
TEST(BasisSolver, BfaRefinesLessForHigherDegrees) {
    scene::Scene s = scene::makeBuiltin("cornell");
    transport::Visibility vis(s);
    uint64_t last = UINT64_MAX;
    for (const char* b : {"constant", "linear", "quadratic", "cubic"}) {
        HrResult r = HrSolver(s, vis, basisSettings("bfa", 1e-3, b)).solve();
        std::cout << b << ": " << r.hierarchy->numLinks() << " links\n";
        EXPECT_LT(r.hierarchy->numLinks(), last) << b;
        last = r.hierarchy->numLinks();
    }
    // bfa's own rule alone: the receiver check (hr.receiver_eps, on by
    // default) judges a linear receiver by its basis residual whatever
    // basis_residual says.
    HrSettings off = basisSettings("bfa", 1e-3, "linear");
    off.oracleParams.set("basis_residual", false);
    off.receiverEps = 0.0;
    HrSettings constant = basisSettings("bfa", 1e-3, "constant");
    constant.receiverEps = 0.0;
    uint64_t constantLinks = HrSolver(s, vis, constant).solve().hierarchy->numLinks();
    uint64_t offLinks = HrSolver(s, vis, off).solve().hierarchy->numLinks();
    // Not equal: the radiosities B_s the rule multiplies differ a little.
    EXPECT_NEAR(double(offLinks), double(constantLinks), 0.02 * double(constantLinks));
}

// ff puts the residual form factor in F's place (oracles/ff_oracle.h).
TEST(FfOracle, UsesTheBasisResidualWhenGiven) {
    Params p;
    p.set("eps", 1e-2);
    auto o = oracles::createOracle("ff", p);
    EXPECT_TRUE(o->needsBasisResidual());
    oracles::LinkEstimate e;
    e.F = e.unoccludedF = 0.2;
    e.receiverArea = 1.0;
    e.senderArea = 2.0;
    e.receiverCanSubdivide = e.senderCanSubdivide = true;
    EXPECT_NE(o->decide(e), oracles::Decision::Accept);  // 0.2 > 1e-2
    e.basisResidualF = 9e-3;                             // 9e-3 and 4.5e-3 < 1e-2
    EXPECT_EQ(o->decide(e), oracles::Decision::Accept);
    e.senderArea = 0.5;  // R A_r / A_s = 1.8e-2 > 1e-2
    EXPECT_NE(o->decide(e), oracles::Decision::Accept);
    e.senderArea = 2.0;
    Params q;
    q.set("eps", 1e-2);
    q.set("basis_residual", false);
    auto off = oracles::createOracle("ff", q);
    EXPECT_FALSE(off->needsBasisResidual());
    EXPECT_NE(off->decide(e), oracles::Decision::Accept);
    Params u;
    u.set("eps", 1e-2);
    u.set("use_bound", true);
    EXPECT_FALSE(oracles::createOracle("ff", u)->needsBasisResidual());
}

TEST(BfaOracle, UsesTheBasisResidualWhenGiven) {
    Params p;
    p.set("eps", 1e-3);
    auto o = oracles::createOracle("bfa", p);
    EXPECT_TRUE(o->needsBasisResidual());
    oracles::LinkEstimate e;
    e.F = 0.5;
    e.receiverArea = 1.0;
    e.senderArea = 1.0;
    e.senderB = RGB(1.0);
    e.receiverRho = RGB(0.5);
    e.emittedPower = 1.0;
    e.receiverCanSubdivide = e.senderCanSubdivide = true;
    EXPECT_NE(o->decide(e), oracles::Decision::Accept);  // 0.25 > 1e-3
    e.basisResidualF = 1e-3;                             // 5e-4 <= 1e-3
    EXPECT_EQ(o->decide(e), oracles::Decision::Accept);
    Params q;
    q.set("eps", 1e-3);
    q.set("basis_residual", false);
    EXPECT_NE(oracles::createOracle("bfa", q)->decide(e), oracles::Decision::Accept);
}

// With clustering, links touching a cluster exchange the constant term only
// (hr/hierarchy.h): a clustered office solve with a higher basis has cluster
// links, converges, and carries the power of the constant-basis solve
// (measured on office:2, oriented, bfa 1e-3: green radiosity power 185.2
// constant, 184.6 linear; the difference is the surface links' basis).
TEST(BasisSolver, ClusterLinksExchangeTheConstantTerm) {
    scene::Scene s = scene::makeBuiltin("office:1");
    transport::Visibility vis(s);
    for (const char* model : {"isotropic", "oriented"}) {
        double power[2];
        for (int i = 0; i < 2; ++i) {
            HrSettings st = basisSettings("bfa", 1e-3, i == 0 ? "constant" : "linear");
            st.clusterModel = cluster::parseClusterModel(model);
            HrResult r = HrSolver(s, vis, st).solve();
            EXPECT_TRUE(r.converged) << model;
            EXPECT_GT(r.linksSC + r.linksCS + r.linksCC, 0u) << model;
            power[i] = r.field->totalPower().g;
        }
        std::cout << model << ": power constant " << power[0] << ", linear " << power[1] << "\n";
        EXPECT_NEAR(power[1], power[0], 0.02 * power[0]) << model;
    }
}

// A saved polynomial solution (solution.hrsol version 2) is the solver's
// field: `hrad render` evaluates the same polynomials, pointwise and in the
// averages over parts of a leaf; a constant one is still written as
// version 1. A truncated or out-of-range polynomial file is refused.
TEST(BasisSolver, SavedSolutionKeepsThePolynomials) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / fmt::format("hrad-basis-hrsol-{}", ::getpid());
    fs::create_directories(dir);
    scene::Scene s = scene::makeBuiltin("cornell");
    transport::Visibility vis(s);
    for (const char* b : {"constant", "linear", "cubic"}) {
        HrResult r = HrSolver(s, vis, basisSettings("bfa", 1e-2, b)).solve();
        const HierarchyField& f = *r.field;
        const std::string path = (dir / fmt::format("{}.hrsol", b)).string();
        reference::saveSolution(path, f);
        std::string bytes;
        {
            std::ifstream in(path, std::ios::binary);
            bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        }
        uint32_t version = 0;
        std::memcpy(&version, bytes.data() + 8, 4);
        EXPECT_EQ(version, std::string(b) == "constant" ? 1u : 2u) << b;
        auto back = reference::loadSolution(path, s);
        ASSERT_TRUE(back);
        EXPECT_EQ(back->basisDegree(), f.basisDegree());
        Pcg32 rng(7);
        double worstPoint = 0.0, worstAverage = 0.0, spread = 0.0;
        for (uint32_t p = 0; p < s.patches.size(); ++p) {
            for (int i = 0; i < 40; ++i) {
                double u = rng.nextDouble(), v = rng.nextDouble();
                if (s.patches[p].kind == scene::PatchKind::Triangle && u + v > 1)
                    u = 1 - u, v = 1 - v;
                RGB a = f.at(p, u, v), c = back->at(p, u, v);
                worstPoint = std::max(worstPoint, maxComponent(glm::abs(a - c)));
                spread = std::max(spread, maxComponent(glm::abs(a - f.at(p, 0.5, 0.5))));
            }
            // Every leaf, and a region two levels inside each leaf.
            f.forEachLeaf(p, [&](scene::ElementKey k, const RGB&) {
                for (scene::ElementKey q : {k, scene::childKey(scene::childKey(k, 1), 2)}) {
                    RGB a = f.average(p, q), c = back->average(p, q);
                    worstAverage = std::max(worstAverage, maxComponent(glm::abs(a - c)));
                }
            });
        }
        EXPECT_LT(worstPoint, 1e-12) << b;
        EXPECT_LT(worstAverage, 1e-12) << b;
        // The comparison can fail: the polynomial fields vary inside leaves.
        if (std::string(b) != "constant") {
            EXPECT_GT(spread, 1e-3) << b;
        }
        if (std::string(b) == "constant") continue;
        std::ofstream(path + ".short", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
        EXPECT_THROW(reference::loadSolution(path + ".short", s), InputError) << b;
        std::string degree = bytes;
        const uint32_t nine = 9;
        std::memcpy(degree.data() + 28, &nine, 4);
        std::ofstream(path + ".degree", std::ios::binary) << degree;
        try {
            reference::loadSolution(path + ".degree", s);
            ADD_FAILURE() << "expected an error";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("basis degree 9"), std::string::npos) << e.what();
        }
    }
    fs::remove_all(dir);
}
