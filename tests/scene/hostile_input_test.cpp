// Hostile scene input, issue 64: recursive formats nested without end,
// include fan-outs, and inputs that are not regular files (FIFOs, devices,
// folders) are clear input errors, never a stack overflow, a hang or an
// endless read. The reproducers are written here, at run time.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

namespace fs = std::filesystem;

/// The message of the InputError loading `path` throws ("no error" if none).
std::string errorOf(const fs::path& path) {
    try {
        loadScene(path.string(), Params{});
    } catch (const InputError& e) {
        return e.what();
    }
    return "no error";
}

std::string repeat(const std::string& s, int n) {
    std::string out;
    out.reserve(s.size() * size_t(n));
    for (int i = 0; i < n; ++i) out += s;
    return out;
}

const char* kLight = R"(  <shape type="rectangle">
    <transform name="to_world"><translate value="0, 0, 10"/></transform>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
)";

TEST(HostileInput, ParsersRefuseNestingWithoutEnd) {
    auto dir = test::tempDir("hostile_depth");
    // Mitsuba XML: 200,000 nested elements (a SIGSEGV in hrad info before).
    const int deep = 200000;
    auto xml = test::writeFile(dir / "deep.xml", "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                                     "<shape type=\"rectangle\">\n" +
                                                     repeat("<bsdf>", deep) + repeat("</bsdf>", deep) +
                                                     "</shape></scene>\n");
    std::string e = errorOf(xml);
    EXPECT_NE(e.find("deep.xml:7: error: elements nested deeper than 128 levels"), std::string::npos) << e;
    // glTF JSON: 200,000 nested arrays in "extras" (tinygltf converts them recursively).
    auto gltf = test::writeFile(dir / "deep.gltf", "{\"asset\": {\"version\": \"2.0\"},\n\"extras\": " +
                                                       repeat("[", deep) + repeat("]", deep) + "}\n");
    e = errorOf(gltf);
    EXPECT_NE(e.find("deep.gltf:2: error: JSON arrays and objects nested deeper than 256"),
              std::string::npos) << e;
}

TEST(HostileInput, IncludeFanOutIsBounded) {
    // Mitsuba: 31 files, each including the next twice: 2^31 parses without
    // a budget (8 GiB, then "Could not allocate").
    auto dir = test::tempDir("hostile_fanout");
    for (int k = 0; k < 31; ++k)
        test::writeFile(dir / ("f" + std::to_string(k) + ".xml"),
                        "<scene version=\"3.0.0\">\n" +
                            (k == 30 ? std::string()
                                     : repeat("  <include filename=\"f" + std::to_string(k + 1) + ".xml\"/>\n", 2)) +
                            "</scene>\n");
    auto top = test::writeFile(dir / "top.xml", "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                                    "  <include filename=\"f0.xml\"/>\n</scene>\n");
    std::string e = errorOf(top);
    EXPECT_NE(e.find("more than 10000 files parsed through <include>"), std::string::npos) << e;
    // MGF: the same tree of includes is bounded by mgf.max_faces (statements executed).
    for (int k = 0; k < 31; ++k)
        test::writeFile(dir / ("m" + std::to_string(k) + ".mgf"),
                        k == 30 ? std::string("v a =\n p 0 0 0\n")
                                : repeat("i m" + std::to_string(k + 1) + ".mgf\n", 2));
    auto mgf = test::writeFile(dir / "top.mgf", "i m0.mgf\n");
    Params small;
    small.set("mgf.max_faces", int64_t(1000));
    e = "no error";
    try {
        loadScene(mgf.string(), small);
    } catch (const InputError& x) {
        e = x.what();
    }
    EXPECT_NE(e.find("mgf.max_faces = 1000"), std::string::npos) << e;
}

TEST(HostileInput, OnlyRegularFilesAreRead) {
    auto dir = test::tempDir("hostile_fifo");
    const fs::path fifo = dir / "fifo.spd";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // A FIFO or a device as a Mitsuba spectrum file blocked, or was read whole.
    for (const std::string& file : {fifo.string(), std::string("/dev/zero")}) {
        auto xml = test::writeFile(
            dir / "spd.xml", "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                 "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"><spectrum "
                                 "name=\"reflectance\" filename=\"" + file + "\"/></bsdf></shape>\n"
                                 "</scene>\n");
        std::string e = errorOf(xml);
        EXPECT_NE(e.find("is not a regular file"), std::string::npos) << file << ": " << e;
    }
    // The scene file itself, whatever its format.
    for (const char* name : {"scene.obj", "scene.xml", "scene.gltf", "scene.mgf", "scene.ply"}) {
        const fs::path p = dir / name;
        ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
        std::string e = errorOf(p);
        EXPECT_NE(e.find("error:"), std::string::npos) << name << ": " << e;
    }
}

// Instances of a shape the loader skips made no face, so the face budget
// never stopped them (10^8: 50 s, and 7.6 GiB of warnings, one each).
TEST(HostileInput, SkippedInstancesAreCountedAndBounded) {
    auto dir = test::tempDir("hostile_instances");
    auto scene = [&](int n) {
        return test::writeFile(dir / "inst.xml",
                               "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                   "  <shape type=\"shapegroup\" id=\"g\"><shape type=\"hair\"/></shape>\n" +
                                   repeat("  <shape type=\"instance\"><ref id=\"g\"/></shape>\n", n) +
                                   "</scene>\n");
    };
    Scene s = loadScene(scene(300).string(), Params{});
    size_t hair = 0;
    for (const std::string& w : s.stats.warnings)
        if (w.find("'hair' shapes cannot be made into polygons") != std::string::npos) {
            ++hair;
            EXPECT_NE(w.find("(300 times in all)"), std::string::npos) << w;
        }
    EXPECT_EQ(hair, 1u);
    Params p;
    p.set("mitsuba.max_faces", int64_t(100));
    std::string e;
    try {
        loadScene(scene(300).string(), p);
    } catch (const InputError& x) {
        e = x.what();
    }
    EXPECT_NE(e.find("instantiates more than 100 shapes (setting mitsuba.max_faces"), std::string::npos) << e;
    // The face budget is checked before an analytic shape's faces are made.
    auto sphere = test::writeFile(dir / "sphere.xml", "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                                          "  <shape type=\"sphere\"/>\n</scene>\n");
    Params fine;
    fine.set("mitsuba.resolution", int64_t(4096));
    fine.set("mitsuba.max_faces", int64_t(1000000));
    e = "no error";
    try {
        loadScene(sphere.string(), fine);
    } catch (const InputError& x) {
        e = x.what();
    }
    EXPECT_NE(e.find("sphere.xml:6: error: this sphere at mitsuba.resolution = 4096 makes 8388608 faces"),
              std::string::npos) << e;
}

// Each emission finite, their power still overflowed: emitted_power null, exit 0.
TEST(HostileInput, EmittedPowerMustBeFinite) {
    auto dir = test::tempDir("hostile_ke");
    test::writeFile(dir / "hot.mtl", "newmtl hot\nKd 0.5 0.5 0.5\nKe 1e308 1e308 1e308\n");
    auto obj = test::writeFile(dir / "hot.obj", "mtllib hot.mtl\nv 0 0 0\nv 10 0 0\nv 0 10 0\nusemtl hot\nf 1 2 3\n");
    std::string e = errorOf(obj);
    EXPECT_NE(e.find("the emitted power"), std::string::npos) << e;
}

// A sphere of radius 1e200 (Mitsuba, MGF) or a scale that overflows made
// faces whose areas overflow: dropped as degenerate, exit 0.
TEST(HostileInput, ShapesTooLargeForDoublesAreErrors) {
    auto dir = test::tempDir("hostile_huge");
    auto xml = test::writeFile(dir / "huge.xml", "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                                     "  <shape type=\"sphere\"><float name=\"radius\" value=\"1e200\"/></shape>\n"
                                                     "</scene>\n");
    std::string e = errorOf(xml);
    EXPECT_NE(e.find("huge.xml:6: error: the shape's coordinates reach"), std::string::npos) << e;
    auto scaled = test::writeFile(dir / "scaled.xml", "<scene version=\"3.0.0\">\n" + std::string(kLight) +
                                                          "  <shape type=\"rectangle\"><transform name=\"to_world\">"
                                                          "<scale value=\"1e300\"/><scale value=\"1e300\"/></transform></shape>\n"
                                                          "</scene>\n");
    e = errorOf(scaled);
    EXPECT_NE(e.find("scaled.xml:6: error:"), std::string::npos) << e;
    auto mgf = test::writeFile(dir / "huge.mgf", "m light =\n  ed 10\nv c =\n  p 0 0 0\nsph c 1e200\n");
    e = errorOf(mgf);
    EXPECT_NE(e.find("huge.mgf:5: error: sph: radius"), std::string::npos) << e;
}

}  // namespace
}  // namespace hrad::scene
