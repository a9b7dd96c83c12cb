// PLY loading (scene/ply_loader.h).
#include <cstring>
#include <limits>

#include <gtest/gtest.h>

#include <cstring>

#include "core/error.h"
#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

// Two faces: a red quad (face colour) and a white (emitter) triangle; the
// vertex colours are ignored because the faces carry colours.
const char* kAscii = R"(ply
format ascii 1.0
comment test
element vertex 5
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
element face 2
property list uchar int vertex_indices
property uchar red
property uchar green
property uchar blue
end_header
0 0 0 10 10 10
2 0 0 10 10 10
2 1 0 10 10 10
0 1 0 10 10 10
1 0.5 1 10 10 10
4 0 1 2 3 204 51 0
3 4 2 1 255 255 255
)";

TEST(PlyLoader, AsciiWithFaceColours) {
    auto dir = test::tempDir("ply_ascii");
    auto path = test::writeFile(dir / "a.ply", kAscii);
    Params p;
    p.set("ply.emission", 5.0);
    Scene s = loadScene(path.string(), p);
    ASSERT_EQ(s.patches.size(), 2u);
    EXPECT_EQ(s.patches[0].kind, PatchKind::Quad);
    EXPECT_NEAR(s.patches[0].area, 2.0, 1e-12);
    EXPECT_NEAR(s.patches[0].rho.r, 0.8, 1e-12);
    EXPECT_NEAR(s.patches[0].rho.g, 0.2, 1e-12);
    EXPECT_EQ(s.patches[0].emission, RGB(0.0));
    EXPECT_EQ(s.patches[1].emission, RGB(5.0));
    EXPECT_EQ(s.patches[1].rho, RGB(0.0));
    EXPECT_EQ(s.source, "ply");
}

void put(std::string& out, const void* p, size_t n, bool bigEndian) {
    std::string b(static_cast<const char*>(p), n);
    if (bigEndian) std::reverse(b.begin(), b.end());
    out += b;
}

std::string binaryPly(bool bigEndian) {
    std::string out = std::string("ply\nformat ") + (bigEndian ? "binary_big_endian" : "binary_little_endian") +
                      " 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
                      "property float red\nproperty float green\nproperty float blue\n"
                      "element face 2\nproperty list uchar uint vertex_index\nend_header\n";
    const double v[4][3] = {{0, 0, 0}, {3, 0, 0}, {3, 2, 0}, {0, 0, 1}};
    const float c[4][3] = {{0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}, {1, 1, 1}};
    for (int i = 0; i < 4; ++i) {
        for (int k = 0; k < 3; ++k) put(out, &v[i][k], 8, bigEndian);
        for (int k = 0; k < 3; ++k) put(out, &c[i][k], 4, bigEndian);
    }
    uint8_t n = 3;
    uint32_t f0[3] = {0, 1, 2}, f1[3] = {3, 3, 3};
    put(out, &n, 1, bigEndian);
    for (uint32_t i : f0) put(out, &i, 4, bigEndian);
    put(out, &n, 1, bigEndian);
    for (uint32_t i : f1) put(out, &i, 4, bigEndian);  // degenerate: dropped
    return out;
}

TEST(PlyLoader, BinaryBothEndiannessesWithVertexColours) {
    for (bool big : {false, true}) {
        auto dir = test::tempDir(big ? "ply_be" : "ply_le");
        auto path = test::writeFile(dir / "b.ply", binaryPly(big));
        Params p;
        p.set("validate", false);  // no white face: no emitter
        Scene s = loadScene(path.string(), p);
        ASSERT_EQ(s.patches.size(), 1u) << big;
        EXPECT_NEAR(s.patches[0].area, 3.0, 1e-12);
        EXPECT_NEAR(s.patches[0].rho.g, 0.5, 1e-12);
        EXPECT_EQ(s.stats.droppedDegenerate, 1u);
        EXPECT_THROW(loadScene(path.string()), InputError);  // no emitter
    }
}

std::string errorOf(const std::string& path) {
    try {
        loadScene(path);
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(PlyLoader, ErrorsNameFileAndLine) {
    auto dir = test::tempDir("ply_err");
    std::string text = kAscii;
    std::string nanText = text;
    nanText.replace(nanText.find("2 1 0 10"), 8, "2 nan 0 10");
    auto nan = test::writeFile(dir / "nan.ply", nanText);
    EXPECT_NE(errorOf(nan.string()).find(nan.string() + ":19"), std::string::npos) << errorOf(nan.string());
    std::string badText = text;
    badText.replace(badText.find("2 0 0 10"), 8, "2 0 x 10");
    auto bad = test::writeFile(dir / "bad.ply", badText);
    EXPECT_NE(errorOf(bad.string()).find(bad.string() + ":18"), std::string::npos) << errorOf(bad.string());
    std::string missText = text;
    missText.replace(missText.find("3 4 2 1"), 7, "3 4 2 9");
    auto miss = test::writeFile(dir / "miss.ply", missText);
    EXPECT_NE(errorOf(miss.string()).find(miss.string() + ":23"), std::string::npos) << errorOf(miss.string());
}


// Issue 16 reproducers: element lines are parsed strictly and checked against the file size.
// Issue 16: body numbers are strict too: non-finite or partial numbers and
// integers out of their type's range are errors with the line (ASCII) or the
// byte offset (binary), not values for the scene check to trip over later.
TEST(PlyLoader, BodyNumbersAreStrictWithLineOrOffset) {
    auto dir = test::tempDir("ply_strict_body");
    struct Case { const char* from; const char* to; int line; };
    for (const Case& c : {Case{"2 1 0 10 10 10", "2 nan 0 10 10 10", 19}, Case{"0 1 0 10 10 10", "0 1 0 300 10 10", 20},
                          Case{"1 0.5 1 10 10 10", "1 0.5 1e999 10 10 10", 21}, Case{"2 0 0 10", "2 0 0x 10", 18}}) {
        std::string text = kAscii;
        text.replace(text.find(c.from), std::string(c.from).size(), c.to);
        auto path = test::writeFile(dir / "a.ply", text);
        std::string e = errorOf(path.string());
        EXPECT_NE(e.find(path.string() + ":" + std::to_string(c.line) + ":"), std::string::npos) << c.to << ": " << e;
    }
    std::string bin = binaryPly(false);
    size_t body = bin.find("end_header\n") + 11;
    double nan = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(&bin[body + 8], &nan, 8);  // vertex 0, y
    auto path = test::writeFile(dir / "b.ply", bin);
    std::string e = errorOf(path.string());
    EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
    EXPECT_NE(e.find("byte offset " + std::to_string(body + 16)), std::string::npos) << e;
}

TEST(PlyLoader, HostileElementHeadersAreErrorsWithLine) {
    auto dir = test::tempDir("ply_hostile");
    const std::string head = "ply\nformat ascii 1.0\n";
    struct Case { std::string name, text, expect; };
    std::vector<Case> cases = {
        {"sci.ply", head + "element vertex 4e3\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
         ":3: error"},
        {"huge.ply", head + "element vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
         "bytes of data"},
        {"twice.ply", head + "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                             "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                             "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n0 0 0\n0 0 0 1 2 3\n",
         "declared twice"},
        {"noprops.ply", "ply\nformat binary_little_endian 1.0\nelement junk 1000000000000000\nend_header\n",
         "no properties"},
    };
    for (const Case& c : cases) {
        auto path = test::writeFile(dir / c.name, c.text);
        std::string err = errorOf(path.string());
        EXPECT_NE(err.find(path.string() + ":"), std::string::npos) << err;
        EXPECT_NE(err.find(c.expect), std::string::npos) << c.name << ": " << err;
    }
}

}  // namespace
}  // namespace hrad::scene
