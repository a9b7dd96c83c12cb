// Mitsuba 3 XML loading (scene/mitsuba_loader.h): small scenes written into a
// temporary folder.
#include <png.h>
#include <stb/stb_image_write.h>  // Debian libstb-dev; implementation in libstb

#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

constexpr double kPi = std::numbers::pi;

/// A scene file: the body between <scene> tags, starting on line 2.
std::string sceneXml(const std::string& body) { return "<scene version=\"3.0.0\">\n" + body + "</scene>\n"; }

const char* kLight = R"(  <shape type="rectangle">
    <transform name="to_world"><translate value="0, 0, 10"/></transform>
    <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
  </shape>
)";

Scene load(const test::TempDir& dir, const std::string& body, const Params& p = {}) {
    auto path = test::writeFile(dir / "scene.xml", sceneXml(body));
    return loadScene(path.string(), p);
}

/// The message of the InputError thrown by loading `body`.
std::string loadError(const test::TempDir& dir, const std::string& body, const Params& p = {}) {
    try {
        load(dir, body, p);
    } catch (const InputError& e) {
        return e.what();
    }
    return "no error";
}

bool hasWarning(const Scene& s, const std::string& needle) {
    for (const auto& w : s.stats.warnings)
        if (w.find(needle) != std::string::npos) return true;
    return false;
}

double areaOf(const Scene& s, const std::string& material) {
    double a = 0;
    for (const Patch& p : s.patches)
        if (s.materials[p.material].name == material && !p.backSide) a += p.area;
    return a;
}

TEST(MitsubaLoader, AreaEmitterRadianceBecomesPiL) {
    auto dir = test::tempDir("mts_emitter");
    Scene s = load(dir, kLight);
    EXPECT_EQ(s.source, "mitsuba");
    ASSERT_EQ(s.patches.size(), 1u);
    const Patch& p = s.patches[0];
    EXPECT_EQ(p.kind, PatchKind::Quad);
    EXPECT_NEAR(p.area, 4.0, 1e-12);  // rectangle [-1,1]^2
    EXPECT_NEAR(p.normal.z, 1.0, 1e-12);
    EXPECT_NEAR(p.centroid().z, 10.0, 1e-12);
    EXPECT_NEAR(p.emission.r, kPi * 1, 1e-12);
    EXPECT_NEAR(p.emission.g, kPi * 2, 1e-12);
    EXPECT_NEAR(p.emission.b, kPi * 3, 1e-12);
    EXPECT_NEAR(s.emittedPower().b, kPi * 3 * 4, 1e-9);
    EXPECT_EQ(p.rho, RGB(0.5));  // no BSDF: Mitsuba's default diffuse 0.5
}

TEST(MitsubaLoader, AnalyticShapesKeepTheirExactArea) {
    auto dir = test::tempDir("mts_shapes");
    Params p;
    p.set("mitsuba.resolution", int64_t(12));
    Scene s = load(dir, std::string(kLight) + R"(
  <bsdf type="diffuse" id="d"><rgb name="reflectance" value="0.5"/></bsdf>
  <bsdf type="diffuse" id="e"><rgb name="reflectance" value="0.4"/></bsdf>
  <bsdf type="diffuse" id="f"><rgb name="reflectance" value="0.3"/></bsdf>
  <bsdf type="diffuse" id="g"><rgb name="reflectance" value="0.2"/></bsdf>
  <shape type="disk"><ref id="d"/>
    <transform name="to_world"><scale value="2"/></transform></shape>
  <shape type="sphere"><float name="radius" value="3"/><point name="center" x="5" y="0" z="0"/><ref id="e"/></shape>
  <shape type="cylinder"><float name="radius" value="0.5"/>
    <point name="p0" value="0,0,0"/><point name="p1" value="0,0,4"/><ref id="f"/></shape>
  <shape type="cube"><ref id="g"/><transform name="to_world"><scale x="1" y="2" z="3"/></transform></shape>
)",
                     p);
    EXPECT_NEAR(areaOf(s, "d"), kPi * 4, 1e-9);
    EXPECT_NEAR(areaOf(s, "e"), 4 * kPi * 9, 1e-9);
    EXPECT_NEAR(areaOf(s, "f"), 2 * kPi * 0.5 * 4, 1e-9);
    EXPECT_NEAR(areaOf(s, "g"), 8 * (1 * 2 + 2 * 3 + 1 * 3), 1e-9);
    // Closed shapes face outwards: normals point away from their centres.
    for (const Patch& q : s.patches) {
        const std::string& m = s.materials[q.material].name;
        if (m == "e") {
            EXPECT_GT(glm::dot(q.normal, q.centroid() - Vec3(5, 0, 0)), 0);
        }
        if (m == "g") {
            EXPECT_GT(glm::dot(q.normal, q.centroid()), 0);
        }
        if (m == "f") {
            EXPECT_GT(glm::dot(q.normal, q.centroid() - Vec3(0, 0, q.centroid().z)), 0);
        }
        if (m == "d") {
            EXPECT_NEAR(q.normal.z, 1.0, 1e-12);
        }
    }
    EXPECT_EQ(s.count(PatchKind::Quad), 1u + 6u + 12u + 12u * 4u);  // rectangle, cube, cylinder, sphere bands
}

TEST(MitsubaLoader, TransformsApplyInOrder) {
    auto dir = test::tempDir("mts_xf");
    // scale by 2, then rotate +90 degrees about x (z -> -y), then translate.
    Scene s = load(dir, std::string(kLight) + R"(  <shape type="rectangle">
    <transform name="to_world">
      <scale value="2"/>
      <rotate x="1" angle="90"/>
      <translate x="1" y="2" z="3"/>
    </transform>
  </shape>
  <shape type="rectangle">
    <transform name="to_world">
      <matrix value="1 0 0 7  0 1 0 0  0 0 -1 0  0 0 0 1"/>
    </transform>
  </shape>
)");
    ASSERT_EQ(s.patches.size(), 3u);
    const Patch& a = s.patches[1];
    EXPECT_NEAR(a.area, 16.0, 1e-9);
    EXPECT_NEAR(a.normal.y, -1.0, 1e-12);
    EXPECT_NEAR(a.centroid().x, 1.0, 1e-12);
    EXPECT_NEAR(a.centroid().y, 2.0, 1e-12);
    EXPECT_NEAR(a.centroid().z, 3.0, 1e-12);
    // A mirroring matrix keeps the analytic normal M^-T n (Mitsuba's rule).
    const Patch& b = s.patches[2];
    EXPECT_NEAR(b.normal.z, -1.0, 1e-12);
    EXPECT_NEAR(b.centroid().x, 7.0, 1e-12);
}

TEST(MitsubaLoader, SensorBecomesCameraWithVerticalFovAndUpAxis) {
    auto dir = test::tempDir("mts_sensor");
    Scene s = load(dir, std::string(kLight) + R"(  <sensor type="perspective">
    <float name="fov" value="90"/>
    <string name="fov_axis" value="x"/>
    <transform name="to_world"><lookat origin="0, -10, 1" target="0, 0, 1" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="200"/><integer name="height" value="100"/></film>
  </sensor>
)");
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_NEAR(s.camera->fovYDegrees, 2 * std::atan(0.5) * 180 / kPi, 1e-9);
    EXPECT_NEAR(s.camera->eye.y, -10, 1e-12);
    EXPECT_NEAR(glm::dot(glm::normalize(s.camera->target - s.camera->eye), Vec3(0, 1, 0)), 1.0, 1e-12);
    EXPECT_NEAR(s.camera->up.z, 1.0, 1e-12);
    EXPECT_EQ(s.upAxis, 2);

    Scene d = load(dir, std::string(kLight) + R"(  <sensor type="perspective">
    <float name="fov" value="60"/><string name="fov_axis" value="diagonal"/>
    <film type="hdrfilm"><integer name="width" value="300"/><integer name="height" value="400"/></film>
  </sensor>
)");
    ASSERT_TRUE(d.camera.has_value());
    EXPECT_NEAR(d.camera->fovYDegrees, 2 * std::atan(std::tan(kPi / 6) * 400 / 500) * 180 / kPi, 1e-9);
    EXPECT_EQ(d.upAxis, 1);
}

TEST(MitsubaLoader, RefsDefaultsParamsAndForwardReferences) {
    auto dir = test::tempDir("mts_ref");
    const std::string body = R"(  <default name="refl" value="0.25"/>
  <shape type="rectangle"><ref id="mat"/><ref id="light"/></shape>
  <bsdf type="diffuse" id="mat"><rgb name="reflectance" value="$refl, $refl, 0.5"/></bsdf>
  <emitter type="area" id="light"><rgb name="radiance" value="2"/></emitter>
)";
    Scene s = load(dir, body);
    ASSERT_EQ(s.patches.size(), 1u);
    EXPECT_NEAR(s.patches[0].rho.r, 0.25, 1e-12);
    EXPECT_NEAR(s.patches[0].rho.b, 0.5, 1e-12);
    EXPECT_NEAR(s.patches[0].emission.g, 2 * kPi, 1e-12);
    Params p;
    p.set("mitsuba.param.refl", 0.75);
    Scene t = load(dir, body, p);
    EXPECT_NEAR(t.patches[0].rho.r, 0.75, 1e-12);
    EXPECT_TRUE(p.unusedKeys().empty());
    // The parameter is in the settings the run records (summary.json
    // resolved_settings), as given.
    const auto rec = p.records().find("mitsuba.param.refl");
    ASSERT_NE(rec, p.records().end());
    EXPECT_EQ(Params::valueToString(rec->second.value), "0.75");

    std::string e = loadError(dir, std::string(kLight) + "  <bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"$nope\"/></bsdf>\n"
                                                         "  <shape type=\"rectangle\"><ref id=\"x\"/></shape>\n");
    EXPECT_NE(e.find("scene.xml:7: error: reference to undefined id 'x'"), std::string::npos) << e;
}

TEST(MitsubaLoader, ShapegroupInstances) {
    auto dir = test::tempDir("mts_instance");
    Scene s = load(dir, std::string(kLight) + R"(  <shape type="shapegroup" id="g">
    <shape type="rectangle"><transform name="to_world"><translate z="1"/></transform></shape>
  </shape>
  <shape type="instance"><ref id="g"/><transform name="to_world"><translate x="5"/></transform></shape>
  <shape type="instance"><ref id="g"/><transform name="to_world"><translate x="-5"/></transform></shape>
)");
    ASSERT_EQ(s.patches.size(), 3u);
    EXPECT_NEAR(s.patches[1].centroid().x, 5, 1e-12);
    EXPECT_NEAR(s.patches[2].centroid().x, -5, 1e-12);
    EXPECT_NEAR(s.patches[2].centroid().z, 1, 1e-12);
}

TEST(MitsubaLoader, IncludesAndObjMeshesWithTransform) {
    auto dir = test::tempDir("mts_include");
    test::writeFile(dir / "meshes" / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    test::writeFile(dir / "parts" / "part.xml", sceneXml(R"(  <shape type="obj">
    <string name="filename" value="../meshes/tri.obj"/>
    <transform name="to_world"><scale value="2"/><translate x="3"/></transform>
  </shape>
)"));
    Scene s = load(dir, std::string(kLight) + "  <include filename=\"parts/part.xml\"/>\n");
    ASSERT_EQ(s.patches.size(), 2u);
    EXPECT_NEAR(s.patches[1].area, 2.0, 1e-12);
    EXPECT_NEAR(s.patches[1].v[1].x, 5.0, 1e-12);
    EXPECT_NEAR(s.patches[1].normal.z, 1.0, 1e-12);

    test::writeFile(dir / "loop.xml", sceneXml("  <include filename=\"loop.xml\"/>\n"));
    std::string e = loadError(dir, std::string(kLight) + "  <include filename=\"loop.xml\"/>\n");
    EXPECT_NE(e.find("loop.xml:2: error:"), std::string::npos) << e;
    EXPECT_NE(e.find("include cycle"), std::string::npos) << e;
}

TEST(MitsubaLoader, PlyMeshesAndUnusedAreaEmitters) {
    auto dir = test::tempDir("mts_ply");
    test::writeFile(dir / "q.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                   "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                   "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
    Scene s = load(dir, std::string(kLight) + R"(  <shape type="ply"><string name="filename" value="q.ply"/>
    <boolean name="flip_normals" value="true"/>
    <transform name="to_world"><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.2, 0.3"/></bsdf>
  </shape>
  <emitter type="area" id="spare"><rgb name="radiance" value="1"/></emitter>
)");
    ASSERT_EQ(s.patches.size(), 2u);
    EXPECT_NEAR(s.patches[1].area, 9.0, 1e-12);
    EXPECT_NEAR(s.patches[1].normal.z, -1.0, 1e-12);  // flip_normals
    EXPECT_NEAR(s.patches[1].rho.b, 0.3, 1e-12);      // the XML BSDF, not the PLY's grey
    EXPECT_TRUE(hasWarning(s, "scene.xml:11: warning: area emitter 'spare' is attached to no shape"));
}

TEST(MitsubaLoader, BsdfRulesTwoSidedAndClamping) {
    auto dir = test::tempDir("mts_bsdf");
    Scene s = load(dir, std::string(kLight) + R"(  <bsdf type="twosided" id="plastic">
    <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.2, 0.3, 0.4"/></bsdf>
  </bsdf>
  <bsdf type="conductor" id="metal">
    <rgb name="eta" value="2"/><rgb name="k" value="0"/><rgb name="specular_reflectance" value="0.5"/>
  </bsdf>
  <bsdf type="diffuse" id="white"><rgb name="reflectance" value="1, 0.5, 0.5"/></bsdf>
  <bsdf type="dielectric" id="glass"/>
  <shape type="rectangle"><ref id="plastic"/><transform name="to_world"><translate z="1"/></transform></shape>
  <shape type="rectangle"><ref id="metal"/><transform name="to_world"><translate z="2"/></transform></shape>
  <shape type="rectangle"><ref id="white"/><transform name="to_world"><translate z="3"/></transform></shape>
  <shape type="rectangle"><ref id="glass"/><transform name="to_world"><translate z="4"/></transform></shape>
  <shape type="rectangle"><ref id="white"/><transform name="to_world"><translate z="5"/></transform></shape>
)");
    // 1 light + plastic (two-sided: front and back) + metal + 2 white; glass is skipped.
    ASSERT_EQ(s.patches.size(), 6u);
    EXPECT_EQ(s.numBackSides(), 1u);
    for (const Patch& p : s.patches) {
        const Material& m = s.materials[p.material];
        if (m.name == "plastic") {
            EXPECT_TRUE(m.twoSided);
            EXPECT_FALSE(m.emitsBothSides);
            EXPECT_NEAR(p.rho.g, 0.3, 1e-12);
        }
        if (m.name == "metal") {
            EXPECT_NEAR(p.rho.r, 0.5 * 1.0 / 9.0, 1e-12);  // F0 = (eta-1)^2/(eta+1)^2
        }
        if (m.name == "white") {
            EXPECT_NEAR(p.rho.r, 0.99, 1e-12);
            EXPECT_NEAR(p.rho.g, 0.5, 1e-12);
        }
    }
    EXPECT_TRUE(hasWarning(s, "roughplastic"));
    EXPECT_TRUE(hasWarning(s, "dielectric is transparent"));
    int clampWarnings = 0;
    for (const auto& w : s.stats.warnings) clampWarnings += w.find("clamped") != std::string::npos;
    EXPECT_EQ(clampWarnings, 1);  // one warning per material, not per shape
    Params strict;
    strict.set("scene.clamp_rho", 0.0);
    std::string e = loadError(dir, std::string(kLight) + R"(  <bsdf type="diffuse" id="white"><rgb name="reflectance" value="1"/></bsdf>
  <shape type="rectangle"><ref id="white"/></shape>
)", strict);
    EXPECT_NE(e.find("scene.xml:6: error: reflectance (1, 1, 1) >= 1"), std::string::npos) << e;
}

TEST(MitsubaLoader, SpectraToLinearRgb) {
    auto dir = test::tempDir("mts_spectrum");
    Scene s = load(dir, R"(  <shape type="rectangle">
    <bsdf type="diffuse"><spectrum name="reflectance" value="360:0.5, 830:0.5"/></bsdf>
    <emitter type="area"><spectrum name="radiance" value="360:1, 830:1"/></emitter>
  </shape>
  <shape type="rectangle"><transform name="to_world"><translate z="1"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="400:0.05, 550:0.05, 600:0.6, 700:0.6"/></bsdf>
  </shape>
)");
    ASSERT_EQ(s.patches.size(), 2u);
    // A flat reflectance stays a neutral grey of the same value.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.patches[0].rho[c], 0.5, 1e-12);
    // Equal-energy emission of radiance 1 has luminance Y = 1 (times pi).
    const RGB& e = s.patches[0].emission;
    double y = 0.2126729 * e.r + 0.7151522 * e.g + 0.0721750 * e.b;  // linear sRGB -> Y (IEC 61966-2-1)
    EXPECT_NEAR(y, kPi, 1e-3 * kPi);
    EXPECT_GT(e.r, e.b);  // equal-energy white is warmer than D65
    // A long-pass reflectance is red.
    EXPECT_GT(s.patches[1].rho.r, 0.4);
    EXPECT_LT(s.patches[1].rho.g, 0.3);
    EXPECT_LT(s.patches[1].rho.b, 0.1);
}

TEST(MitsubaLoader, TextureMeans) {
    auto dir = test::tempDir("mts_texture");
    // A 2 x 1 sRGB PNG: pure red and black; the linear mean is (0.5, 0, 0).
    png_image img;
    std::memset(&img, 0, sizeof(img));
    img.version = PNG_IMAGE_VERSION;
    img.width = 2;
    img.height = 1;
    img.format = PNG_FORMAT_RGB;
    const uint8_t px[6] = {255, 0, 0, 0, 0, 0};
    ASSERT_TRUE(png_image_write_to_file(&img, (dir / "t.png").c_str(), 0, px, 0, nullptr));
    test::writeFile(dir / "t.jpg", "not an image");
    Scene s = load(dir, std::string(kLight) + R"(  <shape type="rectangle"><transform name="to_world"><translate z="1"/></transform>
    <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="t.png"/></texture></bsdf>
  </shape>
  <shape type="rectangle"><transform name="to_world"><translate z="2"/></transform>
    <bsdf type="diffuse"><texture name="reflectance" type="checkerboard">
      <rgb name="color0" value="0.2"/><rgb name="color1" value="0.6"/></texture></bsdf>
  </shape>
  <shape type="rectangle"><transform name="to_world"><translate z="3"/></transform>
    <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="t.jpg"/></texture></bsdf>
  </shape>
)");
    ASSERT_EQ(s.patches.size(), 4u);
    EXPECT_NEAR(s.patches[1].rho.r, 0.5, 1e-4);
    EXPECT_NEAR(s.patches[1].rho.g, 0.0, 1e-9);
    EXPECT_NEAR(s.patches[2].rho.g, 0.4, 1e-12);
    EXPECT_NEAR(s.patches[3].rho.b, 0.5, 1e-12);  // mitsuba.texture_rho
    // A diffuse bitmap is kept as the material's texture (scene/texture.h),
    // not replaced by its mean; the rectangle's patch mean is the texels'.
    EXPECT_FALSE(hasWarning(s, "t.png' -> its mean"));
    EXPECT_EQ(s.textures.size(), 1u);
    EXPECT_GE(s.materials[s.patches[1].material].diffuseMap.texture, 0);
    EXPECT_TRUE(hasWarning(s, "t.jpg': unreadable image (stb_image:"));
}

/// A 16 x 16 JPEG (stb_image_write, quality 100, no chroma subsampling at
/// that quality): the left half sRGB `a`, the right half `b`. The halves are
/// whole 8 x 8 blocks, so each block is flat and survives the DCT up to the
/// rounding of its DC term and the YCbCr conversion (about one code).
std::vector<uint8_t> jpegHalves(const uint8_t a[3], const uint8_t b[3]) {
    std::vector<uint8_t> px(16 * 16 * 3);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x)
            for (int c = 0; c < 3; ++c) px[size_t((y * 16 + x) * 3 + c)] = x < 8 ? a[c] : b[c];
    std::vector<uint8_t> out;
    auto append = [](void* ctx, void* data, int size) {
        auto* o = static_cast<std::vector<uint8_t>*>(ctx);
        o->insert(o->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
    };
    EXPECT_TRUE(stbi_write_jpg_to_func(append, &out, 16, 16, 3, px.data(), 100));
    return out;
}

double srgbDecode(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

TEST(MitsubaLoader, JpegTextureMeanIsSrgbDecodedUnlessRaw) {
    auto dir = test::tempDir("mts_jpeg");
    const uint8_t a[3] = {200, 100, 50}, b[3] = {20, 180, 240};
    std::vector<uint8_t> jpg = jpegHalves(a, b);
    test::writeFile(dir / "halves.jpg", std::string(jpg.begin(), jpg.end()));
    // The same bytes with a start-of-frame header claiming 65535 x 65535
    // texels: refused from the header (stbi_info), before any allocation.
    std::vector<uint8_t> huge = jpg;
    bool patched = false;
    for (size_t i = 0; i + 8 < huge.size() && !patched; ++i)
        if (huge[i] == 0xFF && (huge[i + 1] == 0xC0 || huge[i + 1] == 0xC2)) {
            for (size_t k = 5; k < 9; ++k) huge[i + k] = 0xFF;  // height, width (big-endian)
            patched = true;
        }
    ASSERT_TRUE(patched);
    test::writeFile(dir / "huge.jpg", std::string(huge.begin(), huge.end()));
    // Truncated inside the header: stb_image cannot read it.
    test::writeFile(dir / "cut.jpg", std::string(jpg.begin(), jpg.begin() + 20));
    Scene s = load(dir, std::string(kLight) + R"(  <shape type="rectangle"><transform name="to_world"><translate z="1"/></transform>
    <bsdf type="diffuse" id="srgb"><texture name="reflectance" type="bitmap"><string name="filename" value="halves.jpg"/></texture></bsdf>
  </shape>
  <shape type="rectangle"><transform name="to_world"><translate z="2"/></transform>
    <bsdf type="diffuse" id="raw"><texture name="reflectance" type="bitmap"><string name="filename" value="halves.jpg"/>
      <boolean name="raw" value="true"/></texture></bsdf>
  </shape>
  <shape type="rectangle"><transform name="to_world"><translate z="4"/></transform>
    <bsdf type="diffuse" id="cut"><texture name="reflectance" type="bitmap"><string name="filename" value="cut.jpg"/></texture></bsdf>
  </shape>
)", [] {
        Params p;
        p.set("mitsuba.texture_rho", 0.3);
        return p;
    }());
    ASSERT_EQ(s.patches.size(), 4u);
    for (int c = 0; c < 3; ++c) {
        double lin = 0.5 * (srgbDecode(a[c] / 255.0) + srgbDecode(b[c] / 255.0));
        double raw = 0.5 * (a[c] + b[c]) / 255.0;
        // Tolerance: one 8-bit code is at most 0.0092 in linear units (the
        // slope of the sRGB curve at 1 is 2.4 / 1.055 / 255), and JPEG's
        // rounding of a flat block is about one code.
        EXPECT_NEAR(s.patches[1].rho[c], lin, 0.01) << "channel " << c;
        EXPECT_NEAR(s.patches[2].rho[c], raw, 1.5 / 255) << "channel " << c;
        EXPECT_NEAR(s.patches[3].rho[c], 0.3, 1e-12);  // mitsuba.texture_rho
    }
    // The halves are far apart in the two encodings, so the test tells them apart.
    EXPECT_GT(std::fabs(s.patches[1].rho.r - s.patches[2].rho.r), 0.1);
    EXPECT_EQ(s.textures.size(), 2u);  // sRGB and raw decodes of halves.jpg
    EXPECT_TRUE(hasWarning(s, "cut.jpg': unreadable image"));
    // The header claiming 65535 x 65535 texels (48 GiB decoded as float RGB)
    // is refused before decoding: an error naming texture.max_mb at the
    // bitmap's line.
    const std::string err = loadError(dir, std::string(kLight) + R"(  <shape type="rectangle">
    <bsdf type="diffuse" id="huge"><texture name="reflectance" type="bitmap"><string name="filename" value="huge.jpg"/></texture></bsdf>
  </shape>
)");
    EXPECT_NE(err.find("texture.max_mb"), std::string::npos) << err;
    EXPECT_NE(err.find("scene.xml:7"), std::string::npos) << err;
}

// A point emitter is a light (scene/lights/, envmap: envmap_test.cpp); sunsky is not supported.
TEST(MitsubaLoader, UnsupportedEmittersWarnWithFileAndLine) {
    auto dir = test::tempDir("mts_point");
    Scene s = load(dir, std::string(kLight) + R"(  <emitter type="point"><point name="position" value="0,0,1"/></emitter>
  <emitter type="sunsky"/>
  <integrator type="path"/>
)");
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_STREQ(s.lights[0]->name(), "point");
    EXPECT_FALSE(hasWarning(s, "'point' emitter not supported")) << s.stats.warnings.size();
    EXPECT_TRUE(hasWarning(s, "scene.xml:7: warning: 'sunsky' emitter not supported"));
}

// Bad input: FILE:LINE: error: ... for every kind of mistake.
TEST(MitsubaLoader, BadInputNamesFileAndLine) {
    auto dir = test::tempDir("mts_bad");
    struct Case {
        std::string body, expect;
    };
    const std::vector<Case> cases = {
        {"  <shape type=\"rectangle\">\n  <shape>\n", "scene.xml:4: error: malformed XML"},
        {"  <shape type=\"obj\">\n    <string name=\"filename\" value=\"absent.obj\"/>\n  </shape>\n",
         "scene.xml:3: error: mesh file"},
        {"  <shape type=\"blob\"/>\n", "scene.xml:2: error: unknown shape plugin 'blob'"},
        {"  <shape type=\"rectangle\"><bsdf type=\"velvet\"/></shape>\n", "scene.xml:2: error: unknown bsdf plugin 'velvet'"},
        {"  <frobnicate/>\n", "scene.xml:2: error: unknown element <frobnicate>"},
        {"  <shape type=\"rectangle\">\n    <transform name=\"to_world\"><matrix value=\"1 2 3\"/></transform>\n  </shape>\n",
         "scene.xml:3: error: bad transform: <matrix> needs 16"},
        {"  <shape type=\"rectangle\">\n    <transform name=\"to_world\"><scale value=\"0\"/></transform>\n  </shape>\n",
         "scene.xml:3: error: bad transform: the matrix is singular"},
        {"  <shape type=\"rectangle\">\n    <transform name=\"to_world\"><rotate angle=\"30\"/></transform>\n  </shape>\n",
         "scene.xml:3: error: bad transform: <rotate> needs a non-zero axis"},
        {"  <shape type=\"rectangle\">\n    <transform name=\"to_world\"><translate value=\"1 x 2\"/></transform>\n  </shape>\n",
         "scene.xml:3: error: value: '1 x 2' is not a list of finite numbers"},
        {"  <shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/></shape>\n",
         "scene.xml:2: error: undefined parameter '$r'"},
        {"  <include filename=\"nothere.xml\"/>\n", "scene.xml:2: error: included file"},
    };
    for (const Case& c : cases) {
        std::string e = loadError(dir, c.body);
        EXPECT_NE(e.find(c.expect), std::string::npos) << "expected '" << c.expect << "', got: " << e;
    }
    // The root must be a <scene>.
    auto path = test::writeFile(dir / "root.xml", "<?xml version=\"1.0\"?>\n<shape type=\"obj\"/>\n");
    try {
        loadScene(path.string());
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("root.xml:2: error: the root element must be <scene>"), std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace hrad::scene
