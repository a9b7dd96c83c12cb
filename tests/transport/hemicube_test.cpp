// Hemicube form factors (transport/hemicube.h): delta form factors, the
// closed forms of the plates scenes as the resolution grows, the proximity
// error of a single centre point, and the full matrix's ff.method.
#include "transport/hemicube.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
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
