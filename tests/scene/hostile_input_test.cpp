// Hostile scene input, issue 64: recursive formats nested without end,
// include fan-outs, and inputs that are not regular files (FIFOs, devices,
// folders) are clear input errors, never a stack overflow, a hang or an
// endless read. The reproducers are written here, at run time.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <cstring>
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
    // MGF: the same tree of includes. Files are read once, but the includes
    // ran until mgf.max_faces = 2e7 statements (46 s); at the defaults they
    // now stop at mgf.max_includes, before the next include is looked up.
    for (int k = 0; k < 31; ++k)
        test::writeFile(dir / ("m" + std::to_string(k) + ".mgf"),
                        k == 30 ? std::string("v a =\n p 0 0 0\n")
                                : repeat("i m" + std::to_string(k + 1) + ".mgf\n", 2));
    auto mgf = test::writeFile(dir / "top.mgf", "i m0.mgf\n");
    e = errorOf(mgf);
    EXPECT_NE(e.find("error: more than mgf.max_includes = 100000 include statements executed"), std::string::npos)
        << e;
    Params few;
    few.set("mgf.max_includes", int64_t(10));
    e = "no error";
    try {
        loadScene(mgf.string(), few);
    } catch (const InputError& x) {
        e = x.what();
    }
    EXPECT_NE(e.find("mgf.max_includes = 10 "), std::string::npos) << e;
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

// Budgets before the allocation they guard (issue 64): a 61 KB glTF of 10^4
// nodes each instancing one 10^4-triangle mesh built 2 * 10^7 triangles
// before the face count stopped it; it is now refused from the node tree and
// the accessors' counts, naming gltf.max_faces, before any triangle is made.
TEST(HostileInput, GltfInstancingIsBudgetedBeforeBuilding) {
    auto dir = test::tempDir("hostile_gltf_instances");
    const int tris = 10000, nodes = 10000;
    std::string bin(48 + 6 * size_t(tris), '\0');
    const float v[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    std::memcpy(bin.data(), v, sizeof(v));
    for (int i = 0; i < 3 * tris; ++i) {
        const uint16_t k = uint16_t(i % 3);
        std::memcpy(bin.data() + 48 + 2 * size_t(i), &k, 2);
    }
    test::writeFile(dir / "mesh.bin", bin);
    std::string nodeList, sceneNodes;
    for (int i = 0; i < nodes; ++i) {
        nodeList += std::string(i ? "," : "") + "{\"mesh\":0}";
        sceneNodes += std::string(i ? "," : "") + std::to_string(i);
    }
    auto gltf = test::writeFile(
        dir / "inst.gltf",
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[" + sceneNodes + "]}],\n\"nodes\":[" +
            nodeList + "],\n\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\",\"min\":[0,0,0],"
            "\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5123,\"count\":" + std::to_string(3 * tris) +
            ",\"type\":\"SCALAR\"}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":48},{\"buffer\":0,\"byteOffset\":48,"
            "\"byteLength\":" + std::to_string(6 * tris) + "}],\"buffers\":[{\"uri\":\"mesh.bin\",\"byteLength\":" +
            std::to_string(bin.size()) + "}]}\n");
    std::string e = errorOf(gltf);
    EXPECT_NE(e.find("error: the scene yields more than gltf.max_faces = 20000000 triangles (2001 mesh instances "
                     "counted so far make 20010000)"), std::string::npos) << e;
}

// Silent wrong successes (issue 64): each was loaded with exit 0.
TEST(HostileInput, OutOfRangeValuesAreErrorsNotDrops) {
    auto dir = test::tempDir("hostile_silent");
    // glTF baseColorFactor with 3 numbers gave rho 0.99 (tinygltf's default, clamped).
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    test::writeFile(dir / "tri.bin", std::string(reinterpret_cast<const char*>(v), sizeof(v)));
    auto gltf = test::writeFile(
        dir / "bc.gltf",
        "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
        "{\"POSITION\":0},\"material\":0}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,"
        "\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"buffers\":[{\"uri\":\"tri.bin\",\"byteLength\":36}],\"materials\":[{\"emissiveFactor\":[1,1,1],"
        "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5]}}]}\n");
    std::string e = errorOf(gltf);
    EXPECT_NE(e.find("baseColorFactor"), std::string::npos) << e;
    EXPECT_NE(e.find("error:"), std::string::npos) << e;
    // Faces too large for doubles in the formats without their own check
    // (OBJ, PLY, glTF node scales) were dropped as degenerate.
    const std::string light = "mtllib l.mtl\nusemtl l\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    test::writeFile(dir / "l.mtl", "newmtl l\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    auto obj = test::writeFile(dir / "huge.obj", light + "v 0 0 1e200\nv 1e200 0 1e200\nv 0 1e200 1e200\nf 4 5 6\n");
    e = errorOf(obj);
    EXPECT_NE(e.find("huge.obj: error: 1 faces are too large for double precision"), std::string::npos) << e;
    auto ply = test::writeFile(dir / "huge.ply",
                               "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                               "property double z\nelement face 1\nproperty list uchar int vertex_indices\n"
                               "end_header\n0 0 0\n1e200 0 0\n0 1e200 0\n3 0 1 2\n");
    e = errorOf(ply);
    EXPECT_NE(e.find("huge.ply: error: 1 faces are too large for double precision"), std::string::npos) << e;
}

}  // namespace
}  // namespace hrad::scene
