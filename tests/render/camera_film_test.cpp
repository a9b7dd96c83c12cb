// A Mitsuba sensor's film sets the image's default size and aspect, and its
// fov_axis is honoured at that aspect (and kept along that axis at another
// aspect): render::CameraFrame rays and RenderSettings::adoptFilm.
#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "render/camera.h"
#include "render/render.h"
#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::render {
namespace {

constexpr double kPi = std::numbers::pi;

/// A light, and a perspective sensor at the origin looking along +z (Mitsuba's
/// camera space), with the given fov, fov_axis and film (none when film is "").
scene::Scene sensorScene(const test::TempDir& dir, double fov, const std::string& axis, const std::string& film) {
    std::string xml = "<scene version=\"3.0.0\">\n"
                      "  <shape type=\"rectangle\">\n"
                      "    <transform name=\"to_world\"><translate value=\"0, 0, 10\"/></transform>\n"
                      "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n"
                      "  </shape>\n"
                      "  <sensor type=\"perspective\">\n"
                      "    <float name=\"fov\" value=\"" + std::to_string(fov) + "\"/>\n"
                      "    <string name=\"fov_axis\" value=\"" + axis + "\"/>\n" + film +
                      "  </sensor>\n</scene>\n";
    return scene::loadScene(test::writeFile(dir / "scene.xml", xml).string());
}

std::string film(int w, int h) {
    return "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"" + std::to_string(w) +
           "\"/><integer name=\"height\" value=\"" + std::to_string(h) + "\"/></film>\n";
}

/// Angle (degrees) between the view direction and the ray through pixel (px, py).
double angle(const CameraFrame& f, double px, double py) {
    return std::acos(std::clamp(glm::dot(f.direction(px, py), f.forward), -1.0, 1.0)) * 180.0 / kPi;
}

const double kAtanHalf = std::atan(0.5) * 180.0 / kPi, kAtan2 = std::atan(2.0) * 180.0 / kPi;

TEST(CameraFilm, FovAxisXAndYOnA200x100Film) {
    auto dir = test::tempDir("film_xy");
    scene::Scene sx = sensorScene(dir, 90, "x", film(200, 100));
    ASSERT_TRUE(sx.camera.has_value());
    EXPECT_EQ(sx.camera->filmWidth, 200);
    EXPECT_EQ(sx.camera->filmHeight, 100);
    // fov 90 along x: the left and right edges are 45 degrees off axis, the
    // top and bottom atan(tan 45 / 2) = atan(0.5).
    CameraFrame fx(*sx.camera, 200, 100);
    EXPECT_NEAR(angle(fx, 200, 50), 45.0, 1e-9);
    EXPECT_NEAR(angle(fx, 0, 50), 45.0, 1e-9);
    EXPECT_NEAR(angle(fx, 100, 0), kAtanHalf, 1e-9);
    EXPECT_NEAR(sx.camera->fovYDegrees, 2 * kAtanHalf, 1e-9);

    // fov 90 along y: top and bottom at 45 degrees, the sides at atan(2).
    scene::Scene sy = sensorScene(dir, 90, "y", film(200, 100));
    CameraFrame fy(*sy.camera, 200, 100);
    EXPECT_NEAR(angle(fy, 100, 0), 45.0, 1e-9);
    EXPECT_NEAR(angle(fy, 100, 100), 45.0, 1e-9);
    EXPECT_NEAR(angle(fy, 200, 50), kAtan2, 1e-9);

    // Mitsuba's image x runs along camera-space -x (its "left" vector): the
    // right edge of the image looks towards world -x for this identity
    // to_world, up is +y.
    EXPECT_LT(fx.direction(200, 50).x, 0.0);
    EXPECT_GT(fx.direction(100, 0).y, 0.0);
}

TEST(CameraFilm, AnotherAspectKeepsTheFovAlongItsAxis) {
    auto dir = test::tempDir("film_aspect");
    // Rendered square instead of 2:1, fov_axis x keeps the horizontal 90
    // degrees (the vertical fov grows from 53 to 90), fov_axis y the vertical.
    scene::Scene sx = sensorScene(dir, 90, "x", film(200, 100));
    CameraFrame fx(*sx.camera, 100, 100);
    EXPECT_NEAR(angle(fx, 100, 50), 45.0, 1e-9);
    EXPECT_NEAR(angle(fx, 50, 0), 45.0, 1e-9);
    scene::Scene sy = sensorScene(dir, 90, "y", film(200, 100));
    CameraFrame fy(*sy.camera, 50, 100);
    EXPECT_NEAR(angle(fy, 25, 0), 45.0, 1e-9);
    EXPECT_NEAR(angle(fy, 50, 50), std::atan(0.5) * 180 / kPi, 1e-9);
    // diagonal: the corner ray is at half the fov for any aspect.
    scene::Scene sd = sensorScene(dir, 90, "diagonal", film(200, 100));
    for (auto [w, h] : {std::pair{200, 100}, std::pair{100, 100}, std::pair{30, 120}}) {
        CameraFrame fd(*sd.camera, w, h);
        EXPECT_NEAR(angle(fd, w, h), 45.0, 1e-9) << w << "x" << h;
    }
    // smaller: on the 200 x 100 film the fov is vertical; on a 100 x 200
    // image the smaller axis is x, and the fov holds there.
    scene::Scene ss = sensorScene(dir, 90, "smaller", film(200, 100));
    CameraFrame fs1(*ss.camera, 200, 100);
    EXPECT_NEAR(angle(fs1, 100, 0), 45.0, 1e-9);
    CameraFrame fs2(*ss.camera, 100, 200);
    EXPECT_NEAR(angle(fs2, 100, 100), 45.0, 1e-9);
    EXPECT_NEAR(angle(fs2, 50, 0), kAtan2, 1e-9);
    // larger on the same film: horizontal.
    scene::Scene sl = sensorScene(dir, 90, "larger", film(200, 100));
    CameraFrame fl(*sl.camera, 200, 100);
    EXPECT_NEAR(angle(fl, 200, 50), 45.0, 1e-9);
}

TEST(CameraFilm, SensorWithoutFilmUsesMitsubasDefault768x576) {
    auto dir = test::tempDir("film_default");
    scene::Scene s = sensorScene(dir, 60, "x", "");
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.camera->filmWidth, 768);
    EXPECT_EQ(s.camera->filmHeight, 576);
    CameraFrame f(*s.camera, 768, 576);
    EXPECT_NEAR(angle(f, 768, 288), 30.0, 1e-9);
}

TEST(CameraFilm, ImageSizePrecedence) {
    auto dir = test::tempDir("film_size");
    scene::Scene s = sensorScene(dir, 90, "x", film(200, 100));
    auto sized = [&](const Params& p) {
        RenderSettings rs = RenderSettings::fromParams(p);
        rs.adoptFilm(s);
        return std::pair{rs.width, rs.height};
    };
    EXPECT_EQ(sized(Params{}), (std::pair{200, 100}));  // neither set: the film
    Params w;
    w.set("render.width", int64_t(400));
    EXPECT_EQ(sized(w), (std::pair{400, 200}));  // one set: the film's aspect
    Params h;
    h.set("render.height", int64_t(51));
    EXPECT_EQ(sized(h), (std::pair{102, 51}));
    Params both;
    both.set("render.width", int64_t(64));
    both.set("render.height", int64_t(64));
    EXPECT_EQ(sized(both), (std::pair{64, 64}));  // both set: as set
    Params eye;                                   // an explicit camera has no film
    eye.set("render.eye", std::string("0, 0, -5"));
    eye.set("render.target", std::string("0, 0, 0"));
    EXPECT_EQ(sized(eye), (std::pair{512, 512}));
    // A scene whose camera has no film keeps the 512 default.
    scene::Scene cornell = scene::loadScene("cornell");
    RenderSettings rs = RenderSettings::fromParams(Params{});
    rs.adoptFilm(cornell);
    EXPECT_EQ(rs.width, 512);
    EXPECT_EQ(rs.height, 512);
}

TEST(CameraFilm, FilmBeyondTheSampleBudgetIsAnErrorAtTheFilm) {
    auto dir = test::tempDir("film_budget");
    scene::Scene s = sensorScene(dir, 90, "x", film(20000, 10000));
    RenderSettings rs = RenderSettings::fromParams(Params{});
    try {
        rs.adoptFilm(s);
        FAIL() << "2e8 samples accepted";
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_NE(m.find("scene.xml:9"), std::string::npos) << m;  // the <film> line
        EXPECT_NE(m.find("render.max_samples"), std::string::npos) << m;
    }
    // Bad film sizes stop the load at the film.
    try {
        sensorScene(dir, 90, "x", film(0, 100));
        FAIL() << "film width 0 accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("scene.xml:9"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace hrad::render
