// MGF loading (scene/mgf_loader.h).
#include <gtest/gtest.h>

#include "core/error.h"
#include "scene/loader.h"
#include "scene/mgf_loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

// Main file: a named colour, a white emitter quad, a red floor quad, an
// include of a unit-triangle file translated and arrayed 3 times, and one of
// each primitive.
const char* kMain = R"(# test scene
c red =
	cxy 0.64 0.33
m lamp =
	c
	rd 0.2
	ed 100
m floor =
	c red
	rd 0.15
	rs 0.1 0.02
v a =
	p 0 0 0
	n 0 0 1
v b =
	p 2 0 0
v c = \
	
	p 2 3 0
v d =
	p 0 3 0
m floor
f a b c d
m lamp
f d c b a
m floor
xf -t 10 0 0
i sub/tri.mgf -t 0 0 1 -a 3 -t 0 0 2
xf
m floor
v ctr =
	p 0 0 5
	n 0 0 1
v top =
	p 0 0 7
sph ctr 1
cyl ctr 0.5 top
cone ctr 1 top 0
ring ctr 0.5 1
torus ctr 1 2
v q0 =
	p 0 0 10
v q1 =
	p 1 0 10
v q2 =
	p 1 1 10
v q3 =
	p 0 1 10
prism q0 q1 q2 q3 2
o thing
o
)";

const char* kTri = R"(v t0 =
	p 0 0 0
v t1 =
	p 1 0 0
v t2 =
	p 0 1 0
f t0 t1 t2
)";

TEST(MgfLoader, CountsAreasColoursIncludesAndPrimitives) {
    auto dir = test::tempDir("mgf_ok");
    test::writeFile(dir / "sub" / "tri.mgf", kTri);
    auto path = test::writeFile(dir / "scene.mgf", kMain);
    Params params;
    params.set("mgf.resolution", int64_t(8));
    Scene s = loadScene(path.string(), params);
    EXPECT_TRUE(params.unusedKeys().empty());
    const int R = 8;
    size_t sph = size_t(R * mgfSphereBands(R)), torus = size_t(R * mgfTorusBands(R));
    size_t expected = 2 + 3 + sph + R + R + R + torus + 6;
    EXPECT_EQ(s.patches.size(), expected);
    EXPECT_EQ(s.numEmitters(), 1u);
    EXPECT_EQ(s.stats.ignoredStatements, 1u);  // rs
    // Colours: white (cxy default 1/3) emitter E = 100 grey; red rho luminance 0.5.
    const Patch& lamp = s.patches[1];
    EXPECT_NEAR(lamp.emission.r, 100.0, 1e-9);
    EXPECT_NEAR(lamp.emission.g, 100.0, 1e-9);
    EXPECT_NEAR(lamp.rho.b, 0.2, 1e-12);
    EXPECT_NEAR(lamp.normal.z, -1.0, 1e-12);
    const Patch& floor = s.patches[0];
    EXPECT_NEAR(floor.area, 6.0, 1e-12);
    EXPECT_NEAR(floor.normal.z, 1.0, 1e-12);
    // The Rec.709 red primary with luminance 0.15: only the red channel,
    // r = 0.15 / Y(red primary): 0.15 / 0.2126 with D65 white, 0.15 / 0.256 = 0.585
    // with the default equal-energy white.
    RGB red = chromaticityToRgb(0.64, 0.33, 0.15);
    EXPECT_NEAR(floor.rho.r, red.r, 1e-12);
    EXPECT_GT(floor.rho.r, 0.5);
    EXPECT_LT(floor.rho.r, 0.9);
    EXPECT_NEAR(floor.rho.g, 0.0, 1e-9);
    EXPECT_NEAR(floor.rho.b, 0.0, 1e-9);
    // Include with -t then an array -a 3 -t 0 0 2: triangles at z = 1, 3, 5, x + 10.
    for (int k = 0; k < 3; ++k) {
        const Patch& t = s.patches[2 + size_t(k)];
        EXPECT_NEAR(t.v[0].x, 10.0, 1e-12);
        EXPECT_NEAR(t.v[0].z, 1.0 + 2.0 * k, 1e-12);
        EXPECT_NEAR(t.area, 0.5, 1e-12);
    }
    // Prism: unit square base at z = 10 (counter-clockwise around +z, so its
    // front faces +z) extruded by 2 away from its front (mgflib): a closed box
    // z in [8, 10] of area 2*1 + 4*2 = 10, all faces outward.
    double prismA = 0;
    for (size_t i = s.patches.size() - 6; i < s.patches.size(); ++i) {
        const Patch& p = s.patches[i];
        prismA += p.area;
        EXPECT_GT(glm::dot(p.normal, p.centroid() - Vec3(0.5, 0.5, 9)), 0.0);
    }
    EXPECT_NEAR(prismA, 10.0, 1e-12);
    // Sphere faces point outward; its area approaches 4 pi from below.
    double sphA = 0;
    for (size_t i = 5; i < 5 + sph; ++i) {
        sphA += s.patches[i].area;
        EXPECT_GT(glm::dot(s.patches[i].normal, s.patches[i].centroid() - Vec3(0, 0, 5)), 0.0);
    }
    EXPECT_LT(sphA, 4 * kPi);
    EXPECT_GT(sphA, 0.8 * 4 * kPi);
    // Ring: annulus 0.5..1 facing +z, area = R/2 sin(2pi/R) (1 - 0.25).
    double ringA = 0;
    size_t ring0 = 5 + sph + 2 * size_t(R);
    for (size_t i = ring0; i < ring0 + R; ++i) {
        ringA += s.patches[i].area;
        EXPECT_NEAR(s.patches[i].normal.z, 1.0, 1e-12);
    }
    EXPECT_NEAR(ringA, 0.5 * R * std::sin(2 * kPi / R) * 0.75, 1e-12);
}

TEST(MgfLoader, MirrorKeepsFacesFrontAndNegativeRadiusTurnsInward) {
    auto dir = test::tempDir("mgf_mirror");
    auto path = test::writeFile(dir / "m.mgf", R"(m e =
	ed 1
v a =
	p 0 0 0
v b =
	p 1 0 0
v c =
	p 0 1 0
xf -mx
f a b c
xf
sph a -1
)");
    Scene s = loadScene(path.string());
    EXPECT_NEAR(s.patches[0].normal.z, 1.0, 1e-12);
    EXPECT_EQ(s.upAxis, 2);  // MGF is z-up (for the automatic camera)
    EXPECT_NEAR(s.patches[0].v[1].x + s.patches[0].v[2].x + s.patches[0].v[0].x, -1.0, 1e-12);
    for (size_t i = 1; i < s.patches.size(); ++i)
        EXPECT_LT(glm::dot(s.patches[i].normal, s.patches[i].centroid()), 0.0);
}

TEST(MgfLoader, NeutralChromaticityIsGreyWithEWhite) {
    RGB g = chromaticityToRgb(1.0 / 3, 1.0 / 3, 0.7);
    EXPECT_NEAR(g.r, 0.7, 1e-12);
    EXPECT_NEAR(g.g, 0.7, 1e-12);
    EXPECT_NEAR(g.b, 0.7, 1e-12);
    RGB d = chromaticityToRgb(0.3127, 0.3290, 0.7, "D65");
    EXPECT_NEAR(d.r, 0.7, 1e-4);
    EXPECT_NEAR(d.b, 0.7, 1e-4);
}

std::string errorOf(const std::string& text, const std::string& name) {
    auto dir = test::tempDir("mgf_err_" + name);
    auto path = test::writeFile(dir / (name + ".mgf"), text);
    try {
        loadScene(path.string());
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

const char* kTriangle = "v a =\n\tp 0 0 0\nv b =\n\tp 1 0 0\nv c =\n\tp 0 1 0\n";

TEST(MgfLoader, ErrorsNameFileAndLine) {
    std::string e = errorOf(std::string("m l =\n\ted 1\n") + "v a =\n\tp 0 nan 0\n", "nan");
    EXPECT_NE(e.find("nan.mgf:4"), std::string::npos) << e;
    e = errorOf(std::string("m l =\n\ted 1\n") + "v a =\n\tp 0 1.2.3 0\n", "badnum");
    EXPECT_NE(e.find("badnum.mgf:4"), std::string::npos) << e;
    e = errorOf(std::string("m l =\n\ted 1\n") + kTriangle + "f a b zz\n", "missing");
    EXPECT_NE(e.find("missing.mgf:9"), std::string::npos) << e;
    EXPECT_NE(e.find("zz"), std::string::npos);
    e = errorOf(std::string("m shiny =\n\trd 1.5\n") + kTriangle + "f a b c\n", "rho");
    EXPECT_NE(e.find("rho.mgf:2"), std::string::npos) << e;
    EXPECT_NE(e.find("shiny"), std::string::npos);
    e = errorOf(std::string("m dull =\n\trd 0.5\n") + kTriangle + "f a b c\n", "dark");
    EXPECT_NE(e.find("dark.mgf"), std::string::npos) << e;
    EXPECT_NE(e.find("no emitter"), std::string::npos);
    e = errorOf(std::string("m l =\n\ted 1\n") + kTriangle + "xf -t 1 0\nf a b c\nxf\n", "xf");
    EXPECT_NE(e.find("xf.mgf:9"), std::string::npos) << e;
    e = errorOf("i nosuch.mgf\n", "include");
    EXPECT_NE(e.find("include.mgf:1"), std::string::npos) << e;
}

// Issue 16: `xf -a 999999` nested twice is 10^12 copies; it used to run
// without end while memory grew. It now stops at mgf.max_faces with the line.
TEST(MgfLoader, NestedArraysStopAtMaxFaces) {
    std::string text = std::string("m l =\n\ted 1\n") + kTriangle +
                       "xf -a 999999 -t 1 0 0\nxf -a 999999 -t 0 1 0\nf a b c\nxf\nxf\n";
    std::string e = errorOf(text, "nested");
    EXPECT_NE(e.find("nested.mgf:10"), std::string::npos) << e;
    EXPECT_NE(e.find("mgf.max_faces"), std::string::npos) << e;
    // Two arrays in one xf: the product is refused before the list is built.
    e = errorOf(std::string("m l =\n\ted 1\n") + kTriangle +
                    "xf -a 999999 -t 1 0 0 -a 999999 -t 0 1 0\nf a b c\nxf\n",
                "product");
    EXPECT_NE(e.find("product.mgf:9"), std::string::npos) << e;
    EXPECT_NE(e.find("mgf.max_faces"), std::string::npos) << e;
    // A smaller bound, as a setting: 5 x 5 faces against max_faces = 20.
    auto dir = test::tempDir("mgf_maxfaces");
    auto path = test::writeFile(dir / "grid.mgf", std::string("m l =\n\ted 1\n") + kTriangle +
                                                      "xf -a 5 -t 2 0 0\nxf -a 5 -t 0 2 0\nf a b c\nxf\nxf\n");
    Params p;
    EXPECT_EQ(loadScene(path.string(), p).patches.size(), 25u);
    p.set("mgf.max_faces", int64_t(20));
    try {
        loadScene(path.string(), p);
        ADD_FAILURE() << "25 faces loaded with mgf.max_faces = 20";
    } catch (const InputError& err) {
        EXPECT_NE(std::string(err.what()).find("mgf.max_faces = 20"), std::string::npos) << err.what();
    }
}

TEST(MgfLoader, TransformOverflowIsAnErrorAtTheFace) {
    std::string e = errorOf(std::string("m l =\n\ted 1\n") + kTriangle +
                                "xf -s 1e200\nxf -s 1e200\nf a b c\nxf\nxf\n",
                            "overflow");
    EXPECT_NE(e.find("overflow.mgf:11"), std::string::npos) << e;
    EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
}

TEST(MgfLoader, IncludeOfAFolderIsAnError) {
    auto dir = test::tempDir("mgf_incdir");
    std::filesystem::create_directories(dir / "sub");
    auto path = test::writeFile(dir / "top.mgf", std::string("m l =\n\ted 1\n") + kTriangle +
                                                     "f a b c\ni sub\n");
    try {
        loadScene(path.string());
        ADD_FAILURE() << "a folder was included as an empty file";
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_NE(m.find("top.mgf:10"), std::string::npos) << m;
        EXPECT_NE(m.find("folder"), std::string::npos) << m;
    }
    // A device would be read without end.
    auto dev = test::writeFile(dir / "dev.mgf", std::string("m l =\n\ted 1\n") + kTriangle + "f a b c\ni /dev/zero\n");
    try {
        loadScene(dev.string());
        ADD_FAILURE() << "/dev/zero was included";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("dev.mgf:10"), std::string::npos) << e.what();
    }
}

TEST(MgfLoader, UnknownEntitiesWarnOnceAndDegenerateFacesAreCounted) {
    auto dir = test::tempDir("mgf_warn");
    auto path = test::writeFile(dir / "w.mgf", std::string("m l =\n\ted 1\n") + kTriangle +
                                                   "v d =\n\tp 2 0 0\nfoo 1\nfoo 2\nf a b d\nf a b c\n");
    Scene s = loadScene(path.string());
    EXPECT_EQ(s.patches.size(), 1u);
    EXPECT_EQ(s.stats.droppedDegenerate, 1u);
    EXPECT_EQ(s.stats.ignoredStatements, 2u);
    size_t foo = 0;
    for (const auto& w : s.stats.warnings) foo += w.find("'foo'") != std::string::npos;
    EXPECT_EQ(foo, 1u);
}

}  // namespace
}  // namespace hrad::scene
