// Hemicube form factors (transport/hemicube.h): delta form factors, the
// closed forms of the plates scenes as the resolution grows, the proximity
// error of a single centre point, visibility decided from the centre, and the
// full matrix's ff.method.
#include "transport/hemicube.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/rng.h"
#include "reference/fullmatrix.h"
#include "scene/loader.h"
#include "transport/formfactor.h"

namespace hrad::transport {
namespace {

/// Hemicube F from the receiver (patch 0) to the sender (patch 1) of a plates
/// scene, averaged over k x k points of the receiver.
double platesF(const scene::Scene& s, const Visibility& vis, int res, int k) {
    Hemicube cube(res);
    std::vector<Vec3> pts;
    std::vector<double> w;
    const scene::Patch& r = s.patches[0];
    hemicubePoints(r, scene::keyDomain(r.kind, scene::kRootKey), k, pts, w);
    double F = 0;
    for (size_t i = 0; i < pts.size(); ++i)
        cube.project(vis, s, pts[i], r.normal, 0, [&](uint32_t q, const Vec3&, double dF) {
            if (q == 1) F += w[i] * dF;
        });
    return F;
}

TEST(Hemicube, DeltaFormFactorsSumToOne) {
    // Midpoint rule on the hemicube faces: the error falls as res^-2.
    double prev = 1.0;
    for (int res : {4, 16, 64}) {
        double err = std::fabs(Hemicube(res).sum() - 1.0);
        EXPECT_LT(err, prev) << res;
        prev = err;
    }
    EXPECT_LT(prev, 1e-3);
    EXPECT_EQ(Hemicube(8).cells().size(), 3u * 8 * 8);
}

TEST(Hemicube, ParallelPlatesApproachTheClosedFormAsResolutionGrows) {
    // Unit squares at distance 1: F = 0.19982 (Howell C-11). With 8 x 8
    // points per receiver the proximity error is small; what remains is the
    // cell aliasing, which shrinks as the resolution grows.
    scene::Scene s = scene::loadScene("plates:parallel:1:1:1");
    Visibility vis(s);
    const double exact = parallelRectangles(1, 1, 1);
    std::vector<double> err;
    for (int res : {8, 32, 128}) err.push_back(std::fabs(platesF(s, vis, res, 8) - exact) / exact);
    EXPECT_LT(err[2], err[0]);
    EXPECT_LT(err[2], 5e-3) << err[0] << " " << err[1] << " " << err[2];
}

TEST(Hemicube, PerpendicularPlatesAndTheProximityError) {
    // Perpendicular unit squares sharing an edge: F = 0.20004 (Howell C-14).
    // A single hemicube at the receiver's centre gives the point value
    // F_dA(centre) (0.191 at res 128), not the area average: the proximity
    // error of the method, here 4.7 %. Many points on the receiver remove it.
    scene::Scene s = scene::loadScene("plates:perpendicular:1:1:1");
    Visibility vis(s);
    const double exact = perpendicularRectangles(1, 1, 1);
    double centre = platesF(s, vis, 128, 1);
    double many = platesF(s, vis, 128, 16);
    EXPECT_GT(std::fabs(centre - exact) / exact, 0.03) << centre;
    EXPECT_LT(std::fabs(many - exact) / exact, 0.01) << many << " vs " << exact;
}

TEST(Hemicube, SmallDistantPatchesAlias) {
    // A 0.02 x 0.02 plate at distance 1 subtends less than one cell at res 16:
    // the centre hemicube sees it with 0 or 1 rays, F either 0 or a whole
    // cell's dF, never its true ~1.3e-4.
    scene::Scene s = scene::loadScene("plates:parallel:0.02:0.02:1");
    Visibility vis(s);
    const double exact = parallelRectangles(0.02, 0.02, 1);
    double coarse = platesF(s, vis, 16, 1);
    double cellDF = Hemicube(16).cells()[16 * 8 + 8].dF;  // the top face's centre cell
    EXPECT_TRUE(coarse == 0.0 || std::fabs(coarse - cellDF) < 1e-12) << coarse;
    EXPECT_GT(std::fabs(coarse - exact) / exact, 0.5);
}

/// Monte Carlo estimate of the occluded F from the receiver (patch 0) to the
/// sender (patch 1) of a plates scene, with its standard error: n point pairs
/// (x, y) uniform on the two quads,
///   F = A_1 E[cos t_x cos t_y V(x, y) / (pi r^2)]   (Cohen & Wallace 1993, eq. 4.11),
/// V from Embree occlusion rays (transport::Visibility), the standard error
/// sqrt(s^2 / n) from the sample variance. Unbiased, no discretisation.
struct McEstimate {
    double mean = 0.0, stdError = 0.0;
};
McEstimate platesMonteCarloF(const scene::Scene& s, const Visibility& vis, int n, uint64_t seed) {
    const scene::Patch& r = s.patches[0];
    const scene::Patch& q = s.patches[1];
    const scene::Domain dom = scene::keyDomain(r.kind, scene::kRootKey);
    Pcg32 rng(seed);
    std::vector<Segment> segs(n);
    std::vector<double> k(n);
    for (int i = 0; i < n; ++i) {
        Vec3 x = scene::elementPoint(r, dom, rng.nextDouble(), rng.nextDouble());
        Vec3 y = scene::elementPoint(q, dom, rng.nextDouble(), rng.nextDouble());
        Vec3 d = y - x;
        double r2 = glm::dot(d, d);
        double c = std::max(0.0, glm::dot(r.normal, d)) * std::max(0.0, -glm::dot(q.normal, d)) / r2;
        k[i] = q.area * c / (kPi * r2);
        segs[i] = Segment{x, y, 0, 1};
    }
    std::vector<uint8_t> blocked(n);
    vis.occluded(segs.data(), segs.size(), blocked.data());
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        double v = blocked[i] ? 0.0 : k[i];
        sum += v;
        sum2 += v * v;
    }
    double mean = sum / n, var = (sum2 - n * mean * mean) / (n - 1);
    return {mean, std::sqrt(var / n)};
}

TEST(Hemicube, VisibilityIsDecidedFromTheSamplePoints) {
    // The third failing of Cohen & Wallace 1993 ch. 4: a hemicube decides
    // visibility from its centre only (Cohen & Greenberg 1985 place it at the
    // patch centre). plates:occluded:1:1:1:0.12:0.1 puts a black 0.12 x 0.12
    // square 0.1 above the centre of the unit receiver: its shadow from the
    // centre (side S D / Z = 1.2, scene/builtin.h) covers the whole sender,
    // while it misses the sender entirely from points more than 0.122 off the
    // centre in x or y (shadow centre c - 9 (x - c), half side 0.6).
    // Truth: Monte Carlo over 2^20 point pairs (mean +- standard error),
    // measured 0.19574 +- 0.00007, 2 % below the unoccluded 0.19982.
    scene::Scene s = scene::loadScene("plates:occluded:1:1:1:0.12:0.1");
    ASSERT_EQ(s.patches.size(), 3u);
    Visibility vis(s);
    const McEstimate truth = platesMonteCarloF(s, vis, 1 << 20, 14);
    const double unoccluded = parallelRectangles(1, 1, 1);
    std::printf("[hemicube] plates:occluded:1:1:1:0.12:0.1: Monte Carlo F = %.5f +- %.5f "
                "(unoccluded %.5f)\n",
                truth.mean, truth.stdError, unoccluded);
    ASSERT_GT(truth.mean, 100 * truth.stdError);
    EXPECT_GT(truth.mean, 0.9 * unoccluded);  // the occluder shadows little of the pair

    // Printed, not checked: hrad's quadrature is not the reference here. Its
    // visibility is a stratified fraction of vis_rays segments, which can
    // miss a shadow this small (formfactor.h).
    for (int rays : {16, 64, 256, 1024}) {
        FormFactorSettings fs;
        fs.visRays = rays;
        fs.adaptiveDepth = 3;  // the full matrix's default
        FormFactorEngine engine(s, &vis, fs);
        FormFactorResult q = engine.compute({0, scene::keyDomain(s.patches[0].kind, scene::kRootKey), 1},
                                            {1, scene::keyDomain(s.patches[1].kind, scene::kRootKey), 2});
        std::printf("[hemicube]   quadrature, vis_rays %4d: F = %.5f (unoccluded %.5f)\n", rays, q.F,
                    q.unoccludedF);
    }

    // One point, the centre: every cell ray towards the sender crosses the
    // occluder plane within 0.05 of the centre (inside the occluder's 0.06),
    // so F = 0 exactly, at any resolution: the error is 100 %, not aliasing.
    for (int res : {16, 64, 256}) EXPECT_EQ(platesF(s, vis, res, 1), 0.0) << res;

    // k x k points: the shadow decides for fewer of them and the error falls
    // (measured at res 128: 100 %, 6.2 %, 3.1 %, 0.35 %, 0.13 % for
    // k = 1, 2, 4, 8, 16; k = 2 and 4 see no shadow at all and keep the
    // proximity error of the unoccluded plates). Resolutions with res = 2k
    // are avoided here: there the cell pitch on the sender's plane (2D/res)
    // equals the receiver points' pitch (W/k), every hemicube meets the
    // sender's edges at the same phase of its cell grid, and the edge
    // cells' aliasing adds up instead of averaging out (+10 % at k = 16,
    // res = 32; papers/README.md), an aliasing effect, not this one.
    const int res = 128;
    std::vector<double> err;
    double F16 = 0;
    for (int k : {1, 2, 4, 8, 16}) {
        double F = platesF(s, vis, res, k);
        err.push_back(std::fabs(F - truth.mean));
        std::printf("[hemicube]   res %d, %2d x %-2d points: F = %.5f, relative error %.4f\n", res, k,
                    k, F, err.back() / truth.mean);
        F16 = F;
    }
    for (size_t i = 1; i < err.size(); ++i) EXPECT_LT(err[i], err[i - 1]) << i;
    // With 16 x 16 points what is left is the hemicube's own discretisation
    // error (cells and receiver points), which the same hemicube shows on the
    // unoccluded plates against the closed form (Howell C-11), plus the
    // Monte Carlo truth's noise (4 standard errors).
    scene::Scene p = scene::loadScene("plates:parallel:1:1:1");
    Visibility pvis(p);
    double discretisation = std::fabs(platesF(p, pvis, res, 16) - unoccluded);
    EXPECT_LT(std::fabs(F16 - truth.mean), 4 * truth.stdError + discretisation)
        << F16 << " vs " << truth.mean << " +- " << truth.stdError << ", discretisation "
        << discretisation;
}

TEST(Hemicube, FullMatrixMethodAgreesWithQuadratureOnCornell) {
    scene::Scene s = scene::loadScene("cornell");
    Visibility vis(s);
    reference::FullMatrixSettings q;
    q.level = 1;
    reference::FullMatrixSettings h = q;
    h.hemicube.enabled = true;
    h.hemicube.res = 64;
    h.hemicube.points = 4;
    reference::FullMatrixResult rq = reference::solveFullMatrix(s, vis, q, false);
    reference::FullMatrixResult rh = reference::solveFullMatrix(s, vis, h, false);
    ASSERT_TRUE(rh.stats.converged);
    EXPECT_NE(q.describe(), h.describe());  // different cache keys
    EXPECT_EQ(q.describe().find("hemicube"), std::string::npos);
    // Total reflected power within 3 % (measured 0.x %).
    double pq = luminance(rq.field->totalPower()), ph = luminance(rh.field->totalPower());
    EXPECT_NEAR(ph / pq, 1.0, 0.03) << ph << " vs " << pq;
}

TEST(Hemicube, SettingsFromParams) {
    Params p;
    p.set("fm.ff.method", std::string("hemicube"));
    p.set("fm.ff.hemicube_res", int64_t(32));
    p.set("fm.ff.hemicube_points", int64_t(2));
    reference::FullMatrixSettings s = reference::FullMatrixSettings::fromParams(p);
    EXPECT_TRUE(s.hemicube.enabled);
    EXPECT_EQ(s.hemicube.res, 32);
    EXPECT_EQ(s.hemicube.points, 2);
    EXPECT_NO_THROW(p.reportUnused());
    Params odd;
    odd.set("fm.ff.hemicube_res", int64_t(33));
    EXPECT_THROW(reference::FullMatrixSettings::fromParams(odd), InputError);
    Params bad;
    bad.set("fm.ff.method", std::string("raster"));
    EXPECT_THROW(reference::FullMatrixSettings::fromParams(bad), InputError);
}

}  // namespace
}  // namespace hrad::transport
