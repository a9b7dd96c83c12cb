// Non-area lights (scene/lights/) end to end: closed forms for a point light
// over a plane, a plane under a constant sky and a sun through a square
// window, through the hierarchical solve, the full matrix, the Monte Carlo
// reference and the path tracer; the spot falloff; the Mitsuba loader.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/error.h"
#include "core/rng.h"
#include "hr/solver.h"
#include "reference/fullmatrix.h"
#include "reference/montecarlo.h"
#include "render/final_gather.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "tests/test_util.h"
#include "transport/light_irradiance.h"

namespace hrad {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kRho = 0.5;

/// The floor [-2, 2]^2 at z = 0 facing +z, reflectance kRho.
scene::Scene floorScene() {
    scene::Scene s;
    scene::Material m;
    m.name = "floor";
    m.rho = RGB(kRho);
    uint32_t f = s.addMaterial(m);
    s.addQuad(Vec3(-2, -2, 0), Vec3(2, -2, 0), Vec3(2, 2, 0), Vec3(-2, 2, 0), f);
    return s;
}

void addLight(scene::Scene& s, scene::LightSpec spec) { s.lights.push_back(scene::makeLight(spec)); }

/// A point light of intensity I at height h above the origin.
scene::Scene pointOverFloor(double I = 1.0, double h = 1.0) {
    scene::Scene s = floorScene();
    scene::LightSpec l;
    l.kind = "point";
    l.position = Vec3(0, 0, h);
    l.value = RGB(I);
    addLight(s, l);
    return s;
}

/// Exact mean of I h / (h^2 + x^2 + y^2)^{3/2} over [x0, x1] x [y0, y1]:
/// the solid angle of the rectangle seen from the light (Van Oosterom &
/// Strackee 1983's closed form for a rectangle with a corner at the foot,
/// combined by inclusion-exclusion), times I, over the area.
double cornerSolidAngle(double a, double b, double h) {
    // Solid angle of [0, a] x [0, b] from height h above the corner (signed in a, b).
    return std::atan2(a * b, h * std::sqrt(h * h + a * a + b * b));
}
double meanPointIrradiance(double I, double h, double x0, double x1, double y0, double y1) {
    const double omega = cornerSolidAngle(x1, y1, h) - cornerSolidAngle(x0, y1, h) -
                         cornerSolidAngle(x1, y0, h) + cornerSolidAngle(x0, y0, h);
    return I * omega / ((x1 - x0) * (y1 - y0));
}

/// The uniform-level leaf bounds of the floor quad (-2..2): its corner v0 =
/// (-2,-2), u along x, v along y.
struct Cell {
    double x0, x1, y0, y1;
};
Cell cellOf(const scene::Domain& d) {
    return {-2 + 4 * d.u0, -2 + 4 * (d.u0 + d.h), -2 + 4 * d.v0, -2 + 4 * (d.v0 + d.h)};
}

// ---- closed forms of the kinds ------------------------------------------------

TEST(Lights, PointIrradianceIsInverseSquareCosine) {
    scene::Scene s = pointOverFloor(2.0, 1.5);
    transport::Visibility vis(s);
    uint64_t rays = 0;
    const Vec3 x(1.0, 0.5, 0.0);
    const double r2 = 1.0 + 0.25 + 2.25, cosT = 1.5 / std::sqrt(r2);
    RGB E = transport::lightsIrradiance(s, vis, x, Vec3(0, 0, 1), 0, 1, 0, rays);
    EXPECT_NEAR(E.r, 2.0 * cosT / r2, 1e-12);
}

TEST(Lights, SpotFalloffIsMitsubas) {
    scene::Scene s = floorScene();
    scene::LightSpec l;
    l.kind = "spot";
    l.position = Vec3(0, 0, 1);
    l.direction = Vec3(0, 0, -1);
    l.value = RGB(1.0);
    l.cutoffDegrees = 40;
    l.beamDegrees = 20;
    addLight(s, l);
    transport::Visibility vis(s);
    uint64_t rays = 0;
    auto at = [&](double deg) {
        const double t = deg * kPi / 180;
        return transport::lightsIrradiance(s, vis, Vec3(std::tan(t), 0, 0), Vec3(0, 0, 1), 0, 1, 0,
                                           rays).r;
    };
    auto free = [](double deg) {  // I cos t / r^2 at height 1: cos^3 t
        return std::pow(std::cos(deg * kPi / 180), 3);
    };
    EXPECT_NEAR(at(10), free(10), 1e-12);
    EXPECT_NEAR(at(30), 0.5 * free(30), 1e-12);  // halfway through the transition
    EXPECT_EQ(at(45), 0.0);
}

TEST(Lights, BadValuesNameTheirPlace) {
    scene::LightSpec l;
    l.kind = "point";
    l.value = RGB(-1.0);
    l.where = SourceLocation{"scene.xml", 7, 0};
    try {
        scene::makeLight(l);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("scene.xml:7"), std::string::npos) << e.what();
    }
    l.kind = "nebula";
    EXPECT_THROW(scene::makeLight(l), InputError);
}

// ---- point light over a plane ---------------------------------------------------

// Uniform level 3 (0.5 m cells at 1 m height): the solve's 3 x 3 midpoint
// rule per cell has a relative error ~ (d^2 / 24) |Laplacian f| / f with d =
// 1/6 m, at most 0.4 % (below the light, where f = (1 + r^2)^{-3/2} curves
// most); tolerance 1 %.
TEST(LightsPoint, HierarchicalLeavesMatchTheClosedForm) {
    scene::Scene s = pointOverFloor();
    transport::Visibility vis(s);
    Params p;
    p.set("hr.oracle", std::string("uniform"));
    p.set("oracle.level", int64_t(3));
    p.set("cluster.model", std::string("none"));
    hr::HrSettings st = hr::HrSettings::fromParams(p);
    hr::HrSolver solver(s, vis, st);
    hr::HrResult r = solver.solve(false);
    const hr::Hierarchy& h = *r.hierarchy;
    int leaves = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e)) continue;
        ++leaves;
        Cell c = cellOf(h.domain(e));
        const double exact = kRho * meanPointIrradiance(1.0, 1.0, c.x0, c.x1, c.y0, c.y1);
        EXPECT_NEAR(h.B(e).r, exact, 0.01 * exact) << c.x0 << " " << c.y0;
    }
    EXPECT_EQ(leaves, 64);
}

// The error oracle refines where the irradiance varies: below the light.
// The reflected power then matches the closed form rho I Omega (Omega the
// solid angle of the floor seen from the light) within 1 % (the midpoint
// rule's error on the coarsest accepted elements).
TEST(LightsPoint, ErrorOracleRefinesBelowTheLight) {
    scene::Scene s = pointOverFloor();
    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, test::hrSettings("error", 1e-3));
    hr::HrResult r = solver.solve(false);
    const hr::Hierarchy& h = *r.hierarchy;
    double power = 0, nearArea = 1e9, farArea = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e)) continue;
        power += h.area(e) * h.B(e).r;
        const Vec3 c = scene::elementCentroid(s.patches[0], h.domain(e));
        if (glm::length(Vec2(c.x, c.y)) < 0.5) nearArea = std::min(nearArea, h.area(e));
        if (glm::length(Vec2(c.x, c.y)) > 2.3) farArea = std::max(farArea, h.area(e));
    }
    const double exact = kRho * 1.0 * 16 * meanPointIrradiance(1.0, 1.0, -2, 2, -2, 2);
    EXPECT_NEAR(power, exact, 0.01 * exact);
    EXPECT_LT(nearArea, farArea);
}

// Full matrix, level 3: 4 x 4 midpoints per 0.5 m cell, error <= 0.25 %;
// tolerance 1 %.
TEST(LightsPoint, FullMatrixMatchesTheClosedForm) {
    scene::Scene s = pointOverFloor();
    transport::Visibility vis(s);
    reference::FullMatrixSettings fs;
    fs.level = 3;
    reference::FullMatrixResult r = reference::solveFullMatrix(s, vis, fs, false);
    const scene::UniformField& f = *r.field;
    ASSERT_EQ(f.numElements(), 64u);
    for (size_t i = 0; i < f.count(0); ++i) {
        Cell c = cellOf(scene::keyDomain(scene::PatchKind::Quad, f.key(0, i)));
        const double exact = kRho * meanPointIrradiance(1.0, 1.0, c.x0, c.x1, c.y0, c.y1);
        EXPECT_NEAR(f.value(i).r, exact, 0.01 * exact);
    }
}

// Monte Carlo, level 2: each region's mean within 4 standard errors of the
// closed form (the only noise is where on the region a path starts).
TEST(LightsPoint, MonteCarloMatchesTheClosedForm) {
    scene::Scene s = pointOverFloor();
    transport::Visibility vis(s);
    reference::MonteCarloSettings ms;
    ms.level = 2;
    ms.samples = 4000;
    reference::MonteCarloResult r = reference::solveMonteCarlo(s, vis, ms, false);
    const scene::UniformField& f = *r.field;
    for (size_t i = 0; i < f.count(0); ++i) {
        Cell c = cellOf(scene::keyDomain(scene::PatchKind::Quad, f.key(0, i)));
        const double exact = kRho * meanPointIrradiance(1.0, 1.0, c.x0, c.x1, c.y0, c.y1);
        EXPECT_NEAR(f.value(i).r, exact, 4 * r.stdError[i].r + 1e-12);
        EXPECT_GT(r.stdError[i].r, 0.0);
    }
}

// The path tracer at one point: exact (one shadow ray, nothing to reflect
// from), to rounding.
TEST(LightsPoint, PathTracerIsExactOnAnOpenPlane) {
    scene::Scene s = pointOverFloor();
    transport::Visibility vis(s);
    render::Gatherer g(s, vis, render::GatherSettings{});
    Pcg32 rng(3);
    const Vec3 x(0.7, -0.4, 0.0);
    const double r2 = 1 + 0.49 + 0.16;
    EXPECT_NEAR(g.pathTraced(0, x, rng).r, kRho * (1.0 / std::sqrt(r2)) / r2, 1e-12);
}

// ---- a plane under a constant sky -------------------------------------------------

scene::Scene floorUnderSky(double L) {
    scene::Scene s = floorScene();
    scene::LightSpec l;
    l.kind = "constant";
    l.value = RGB(L);
    addLight(s, l);
    return s;
}

// Unoccluded upward plane: E = pi L at every point; cosine-distributed
// directions score pi L each, so every method is exact to rounding (the
// hierarchy's light link stores a float: 1e-6 relative there).
TEST(LightsConstant, PlaneReceivesPiL) {
    scene::Scene s = floorUnderSky(0.3);
    transport::Visibility vis(s);
    const double exact = kRho * kPi * 0.3;
    hr::HrSolver solver(s, vis, test::hrSettings("error", 1e-3));
    hr::HrResult hr = solver.solve(false);
    for (uint32_t e = 0; e < hr.hierarchy->numElements(); ++e)
        if (hr.hierarchy->isLeaf(e)) {
            EXPECT_NEAR(hr.hierarchy->B(e).r, exact, 1e-6 * exact);
        }
    reference::FullMatrixSettings fs;
    fs.level = 1;
    reference::FullMatrixResult fm = reference::solveFullMatrix(s, vis, fs, false);
    for (size_t i = 0; i < fm.field->numElements(); ++i)
        EXPECT_NEAR(fm.field->value(i).r, exact, 1e-9 * exact);
    reference::MonteCarloSettings ms;
    ms.samples = 16;
    reference::MonteCarloResult mc = reference::solveMonteCarlo(s, vis, ms, false);
    EXPECT_NEAR(mc.field->value(0).r, exact, 1e-9 * exact);
    render::Gatherer g(s, vis, render::GatherSettings{});
    Pcg32 rng(5);
    EXPECT_NEAR(g.pathTraced(0, Vec3(0.1, 0.2, 0), rng).r, exact, 1e-9 * exact);
}

// ---- a sun through a square window --------------------------------------------------

// The floor [-2, 2]^2 under a black roof at z = 1 with a 1 x 1 window
// [-0.5, 0.5]^2; the sun travels along (0.5, 0, -1), so the window's light
// falls on [0, 1] x [-0.5, 0.5] (area 1, on level-3 cell boundaries) with
// irradiance E_perp cos t, cos t = 1 / sqrt(1.25). The roof is black and
// the floor does not see itself: B = rho E exactly.
scene::Scene sunThroughWindow(double Eperp) {
    scene::Scene s = floorScene();
    scene::Material black;
    black.name = "roof";
    uint32_t m = s.addMaterial(black);
    auto roof = [&](double x0, double x1, double y0, double y1) {  // facing down
        s.addQuad(Vec3(x0, y0, 1), Vec3(x0, y1, 1), Vec3(x1, y1, 1), Vec3(x1, y0, 1), m);
    };
    roof(-3, -0.5, -3, 3);
    roof(0.5, 3, -3, 3);
    roof(-0.5, 0.5, -3, -0.5);
    roof(-0.5, 0.5, 0.5, 3);
    scene::LightSpec l;
    l.kind = "directional";
    l.direction = Vec3(0.5, 0, -1);
    l.value = RGB(Eperp);
    addLight(s, l);
    return s;
}

bool litCell(const Cell& c) { return c.x0 >= 0 && c.x1 <= 1 && c.y0 >= -0.5 && c.y1 <= 0.5; }

TEST(LightsDirectional, SunThroughAWindowLightsItsImage) {
    scene::Scene s = sunThroughWindow(2.0);
    transport::Visibility vis(s);
    const double lit = kRho * 2.0 / std::sqrt(1.25);
    // Hierarchical, uniform level 3: every cell fully lit or dark, exact up
    // to the light link's float storage (2^-24 relative): 1e-6 relative.
    Params p;
    p.set("hr.oracle", std::string("uniform"));
    p.set("oracle.level", int64_t(3));
    p.set("cluster.model", std::string("none"));
    hr::HrSolver solver(s, vis, hr::HrSettings::fromParams(p));
    hr::HrResult r = solver.solve(false);
    const hr::Hierarchy& h = *r.hierarchy;
    int litLeaves = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e) || h.patch(e) != 0) continue;
        Cell c = cellOf(h.domain(e));
        EXPECT_NEAR(h.B(e).r, litCell(c) ? lit : 0.0, 1e-6 * lit) << c.x0 << " " << c.y0;
        litLeaves += litCell(c) ? 1 : 0;
    }
    EXPECT_EQ(litLeaves, 4);
    // Full matrix, level 3: the same, exact.
    reference::FullMatrixSettings fs;
    fs.level = 3;
    reference::FullMatrixResult fm = reference::solveFullMatrix(s, vis, fs, false);
    for (size_t i = 0; i < fm.field->count(0); ++i) {
        Cell c = cellOf(scene::keyDomain(scene::PatchKind::Quad, fm.field->key(0, i)));
        EXPECT_NEAR(fm.field->value(i).r, litCell(c) ? lit : 0.0, 1e-9);
    }
    // Monte Carlo: every path of a cell scores the same, exact.
    reference::MonteCarloSettings ms;
    ms.level = 3;
    ms.samples = 8;
    reference::MonteCarloResult mc = reference::solveMonteCarlo(s, vis, ms, false);
    for (size_t i = 0; i < mc.field->count(0); ++i) {
        Cell c = cellOf(scene::keyDomain(scene::PatchKind::Quad, mc.field->key(0, i)));
        EXPECT_NEAR(mc.field->value(i).r, litCell(c) ? lit : 0.0, 1e-9);
    }
}

// The error oracle follows the shadow edges: the lit power (rho E_perp cos t
// times the lit area 1) within 2 % (the cells the edges cross at the
// finest level carry a half-lit mean, within the element's own midpoint
// error).
TEST(LightsDirectional, ErrorOracleFindsTheLitPower) {
    scene::Scene s = sunThroughWindow(2.0);
    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, test::hrSettings("error", 1e-3, "none", 1e-4));
    hr::HrResult r = solver.solve(false);
    const hr::Hierarchy& h = *r.hierarchy;
    double power = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e)
        if (h.isLeaf(e) && h.patch(e) == 0) power += h.area(e) * h.B(e).r;
    const double exact = kRho * 2.0 / std::sqrt(1.25);
    EXPECT_NEAR(power, exact, 0.02 * exact);
}

// ---- light links into clusters (hr.light_clusters) ------------------------------------

// A floor of 32 x 32 patches (0.125 m, rho 0.5) under a sun shining straight
// down, a black roof strip over x in [-2, -1.5] shading the first four
// columns (its edge on patch edges). Oriented clusters: coplanar patches
// exchange nothing, the roof is black, so B = rho E on every patch and the
// light links alone make the solution; unclustered, every patch is exact
// (fully lit or dark). Clustered light links start at the root cluster; a
// cluster some shadow ray of which is blocked is opened, the fully lit ones
// are kept (no variation: the error oracle accepts them), so every patch
// gets the unclustered B (to the links' float storage, 1e-6) from a
// fraction of the links.
scene::Scene sunOverPatches() {
    scene::Scene s;
    scene::Material m;
    m.name = "floor";
    m.rho = RGB(kRho);
    const uint32_t f = s.addMaterial(m);
    const int n = 32;
    const double h = 4.0 / n;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double x = -2 + i * h, y = -2 + j * h;
            s.addQuad(Vec3(x, y, 0), Vec3(x + h, y, 0), Vec3(x + h, y + h, 0), Vec3(x, y + h, 0), f);
        }
    scene::Material black;
    black.name = "roof";
    const uint32_t r = s.addMaterial(black);
    s.addQuad(Vec3(-2.5, -2.5, 1), Vec3(-2.5, 2.5, 1), Vec3(-1.5, 2.5, 1), Vec3(-1.5, -2.5, 1), r);
    scene::LightSpec l;
    l.kind = "directional";
    l.direction = Vec3(0, 0, -1);
    l.value = RGB(2.0);
    addLight(s, l);
    return s;
}

TEST(LightsClusters, SunOnManyPatchesNeedsFewLinksForTheSameLight) {
    scene::Scene s = sunOverPatches();
    transport::Visibility vis(s);
    auto solve = [&](bool clusters) {
        Params p;
        p.set("hr.oracle", std::string("error"));
        p.set("oracle.eps", 1e-3);
        p.set("hr.tolerance", 1e-7);
        p.set("cluster.model", std::string("oriented"));
        p.set("hr.light_clusters", clusters);
        hr::HrSolver solver(s, vis, hr::HrSettings::fromParams(p));
        return solver.solve(false);
    };
    hr::HrResult a = solve(true), b = solve(false);
    ASSERT_GT(a.hierarchy->numClusters(), 0u);
    const double lit = kRho * 2.0;
    for (uint32_t q = 0; q < 32 * 32; ++q) {
        const double Ba = a.hierarchy->B(q).r, Bb = b.hierarchy->B(q).r;
        const bool shaded = q < 4 * 32;  // columns i = 0..3
        EXPECT_NEAR(Bb, shaded ? 0.0 : lit, 1e-6 * lit) << q;
        EXPECT_NEAR(Ba, Bb, 1e-6 * lit) << q;
    }
    EXPECT_EQ(b.lightLinks, 32u * 32u);
    EXPECT_LT(4 * a.lightLinks, b.lightLinks) << a.lightLinks << " vs " << b.lightLinks;
}

// ---- Mitsuba ------------------------------------------------------------------------

std::string sceneXml(const std::string& body) {
    return "<scene version=\"3.0.0\">\n" + body + "</scene>\n";
}
const char* kFloor = R"(  <shape type="rectangle"><bsdf type="diffuse"/></shape>
)";

TEST(LightsMitsuba, EmittersBecomeLights) {
    auto dir = test::tempDir("mts_lights");
    auto path = test::writeFile(dir / "scene.xml", sceneXml(std::string(kFloor) + R"(
  <emitter type="point"><point name="position" x="0" y="0" z="2"/><rgb name="intensity" value="3"/></emitter>
  <emitter type="spot"><transform name="to_world"><lookat origin="0,0,3" target="0,0,0" up="0,1,0"/></transform>
    <float name="cutoff_angle" value="30"/></emitter>
  <emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/><rgb name="irradiance" value="2"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
)"));
    scene::Scene s = scene::loadScene(path.string(), {});
    ASSERT_EQ(s.lights.size(), 4u);
    EXPECT_STREQ(s.lights[0]->name(), "point");
    EXPECT_STREQ(s.lights[1]->name(), "spot");
    EXPECT_STREQ(s.lights[2]->name(), "directional");
    EXPECT_STREQ(s.lights[3]->name(), "constant");
    // The point light at height 2 over the origin: I / 4; the spot along -z: I = 1 / 9.
    scene::LightSample a = s.lights[0]->sample(Vec3(0.0), 0.5, 0.5);
    EXPECT_NEAR(a.value.r, 3.0 / 4.0, 1e-12);
    scene::LightSample b = s.lights[1]->sample(Vec3(0.0), 0.5, 0.5);
    EXPECT_NEAR(b.value.r, 1.0 / 9.0, 1e-12);
    EXPECT_NEAR(s.lights[2]->sample(Vec3(0.0), 0.5, 0.5).dir.z, 1.0, 1e-12);
    EXPECT_NEAR(s.lights[3]->radiance(Vec3(0, 0, 1)).r, 0.5, 1e-12);
}

TEST(LightsMitsuba, BadIntensityIsAnErrorAtItsLine) {
    auto dir = test::tempDir("mts_lights_bad");
    auto path = test::writeFile(dir / "scene.xml", sceneXml(std::string(kFloor) + R"(  <emitter type="point"><rgb name="intensity" value="-1"/></emitter>
)"));
    try {
        scene::loadScene(path.string(), {});
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("scene.xml:3"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace hrad
