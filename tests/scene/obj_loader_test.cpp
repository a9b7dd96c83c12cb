// OBJ/MTL loading (scene/obj_loader.h).
#include <gtest/gtest.h>

#include "core/error.h"
#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

const char* kMtl = R"(newmtl wall
Kd 0.5 0.25 0.125
newmtl lamp
Kd 0.1 0.1 0.1
Ke 10 8 6
)";

// A triangle with no material (before any usemtl), then a quad, a triangle,
// a pentagon, an L-shaped hexagon (area 4) and an emitting quad.
const char* kObj = R"(v 9 9 9
v 10 9 9
v 9 10 9
f 1 2 3
mtllib test.mtl
v 0 0 0
v 2 0 0
v 2 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 0 1 1
v 0 0 2
v 2 0 2
v 3 1 2
v 1 2 2
v -1 1 2
v 0 0 3
v 3 0 3
v 3 1 3
v 1 1 3
v 1 2 3
v 0 2 3
usemtl wall
f 4 5 6 7
f 8 9 10
f 11 12 13 14 15
f 16 17 18 19 20 21
usemtl lamp
f 7 6 5 4
)";

TEST(ObjLoader, CountsAreasAndColours) {
    auto dir = test::tempDir("obj_ok");
    test::writeFile(dir / "test.mtl", kMtl);
    auto path = test::writeFile(dir / "test.obj", kObj);
    Scene s = loadScene(path.string());
    EXPECT_EQ(s.source, "obj");
    EXPECT_EQ(s.stats.inputFaces, 6u);
    // quad 1 + triangle 1 + pentagon 3 + hexagon 4 + lamp quad 1 + default triangle 1
    EXPECT_EQ(s.patches.size(), 11u);
    EXPECT_EQ(s.count(PatchKind::Quad), 2u);
    EXPECT_EQ(s.stats.triangulatedFaces, 2u);
    EXPECT_EQ(s.stats.defaultMaterialFaces, 1u);
    ASSERT_EQ(s.materials.size(), 3u);
    EXPECT_EQ(s.materials[0].name, "wall");
    EXPECT_NEAR(s.materials[0].rho.g, 0.25, 1e-7);
    EXPECT_NEAR(s.materials[1].emission.r, 10.0, 1e-6);
    EXPECT_EQ(s.materials[2].name, "default");
    EXPECT_EQ(s.materials[2].rho, RGB(0.5));
    EXPECT_EQ(s.numEmitters(), 1u);
    double hexA = 0, pentA = 0;
    for (const auto& p : s.patches) {
        double z = p.v[0].z;
        if (z == 3) hexA += p.area;
        if (z == 2) pentA += p.area;
    }
    EXPECT_NEAR(hexA, 4.0, 1e-12);  // L shape: 3x1 + 1x1... (3*1 + 1*1) = 4
    // Pentagon (0,0),(2,0),(3,1),(1,2),(-1,1): shoelace area 5.
    EXPECT_NEAR(pentA, 5.0, 1e-12);
    bool warned = false;
    for (const auto& w : s.stats.warnings) warned |= w.find("1 faces have no material") != std::string::npos;
    EXPECT_TRUE(warned);
}

TEST(ObjLoader, DefaultRhoSetting) {
    auto dir = test::tempDir("obj_default");
    auto path = test::writeFile(dir / "a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    Params p;
    p.set("obj.default_rho", 0.25);
    p.set("validate", false);
    Scene s = loadScene(path.string(), p);
    EXPECT_EQ(s.patches[0].rho, RGB(0.25));
    EXPECT_TRUE(p.unusedKeys().empty());
}

std::string errorOf(const std::string& path) {
    try {
        loadScene(path);
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(ObjLoader, ErrorsNameFileAndLine) {
    auto dir = test::tempDir("obj_err");
    auto nan = test::writeFile(dir / "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
    EXPECT_NE(errorOf(nan.string()).find(nan.string() + ":3"), std::string::npos) << errorOf(nan.string());
    auto inf = test::writeFile(dir / "inf.obj", "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n");
    EXPECT_NE(errorOf(inf.string()).find(inf.string() + ":2"), std::string::npos);
    auto bad = test::writeFile(dir / "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1x 0\nf 1 2 3\n");
    EXPECT_NE(errorOf(bad.string()).find(bad.string() + ":3"), std::string::npos);
    auto missing = test::writeFile(dir / "missing.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n# c\nf 1 2 7\n");
    EXPECT_NE(errorOf(missing.string()).find(missing.string() + ":5"), std::string::npos);
    test::writeFile(dir / "bright.mtl", "# lib\n\nnewmtl glow\nKd 0.5 1.2 0.5\nKe 1 1 1\n");
    auto bright = test::writeFile(dir / "bright.obj", "mtllib bright.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glow\nf 1 2 3\n");
    Params strict;  // scene.clamp_rho = 0: Kd >= 1 is an error (the default clamps it)
    strict.set("scene.clamp_rho", 0.0);
    std::string e;
    try {
        loadScene(bright.string(), strict);
    } catch (const InputError& x) {
        e = x.what();
    }
    EXPECT_NE(e.find((dir / "bright.mtl").string() + ":4"), std::string::npos) << e;  // the Kd line
    EXPECT_NE(e.find("glow"), std::string::npos);
    auto dark = test::writeFile(dir / "dark.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    e = errorOf(dark.string());
    EXPECT_NE(e.find(dark.string()), std::string::npos);
    EXPECT_NE(e.find("no emitter"), std::string::npos);
}

// Issue 16: MTL numbers are parsed by hrad, strictly; tinyobjloader read these
// as 0 or (r, 0, 0) without a word.
TEST(ObjLoader, MtlNumbersAreStrict) {
    auto dir = test::tempDir("obj_mtl_strict");
    const std::string obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    auto path = test::writeFile(dir / "s.obj", obj);
    for (const char* line : {"Kd abc 0.5 0.5", "Ke 10x 10 10", "Ke inf 10 10", "Kd", "Kd 0.5 0.5",
                             "Kd nan 0 0", "Ns 1e400", "d", "Kd spectral a.spd"}) {
        test::writeFile(dir / "m.mtl", std::string("# lib\nnewmtl a\n") + line + "\nKe 1 1 1\n");
        std::string e = errorOf(path.string());
        EXPECT_NE(e.find((dir / "m.mtl").string() + ":3"), std::string::npos) << line << ": " << e;
    }
    // `Kd 0.7` is grey (MTL spec: g = b = r when only r is given), not (0.7, 0, 0).
    test::writeFile(dir / "m.mtl", "newmtl a\nKd 0.7\nKe 1\n");
    Scene s = loadScene(path.string());
    ASSERT_EQ(s.patches.size(), 1u);
    EXPECT_EQ(s.patches[0].rho, RGB(0.7));
    EXPECT_EQ(s.materials[s.patches[0].material].emission, RGB(1.0));
}

TEST(ObjLoader, MissingMaterialLibraryIsAnErrorAtItsLine) {
    auto dir = test::tempDir("obj_no_mtllib");
    auto path = test::writeFile(dir / "a.obj", "# c\nmtllib nosuch.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl l\nf 1 2 3\n");
    std::string e = errorOf(path.string());
    EXPECT_NE(e.find(path.string() + ":2"), std::string::npos) << e;
    EXPECT_NE(e.find("nosuch.mtl"), std::string::npos) << e;
    EXPECT_EQ(e.find("no emitter"), std::string::npos) << e;
}

TEST(ObjLoader, DegenerateFacesAreCounted) {
    auto dir = test::tempDir("obj_degen");
    test::writeFile(dir / "l.mtl", "newmtl l\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    auto path = test::writeFile(dir / "d.obj",
                                "mtllib l.mtl\nusemtl l\nv 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\nf 1 1 1\n");
    Scene s = loadScene(path.string());
    EXPECT_EQ(s.patches.size(), 1u);
    EXPECT_EQ(s.stats.droppedDegenerate, 2u);
}

}  // namespace
}  // namespace hrad::scene
