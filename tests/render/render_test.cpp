// Rendering and export: uniform furnace image, reconstruction, EXR/PNG/PLY files.
#include "render/render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "reference/fullmatrix.h"
#include "render/camera.h"
#include "render/image.h"
#include "render/ply_export.h"
#include "tests/reference/box_scenes.h"
#include "tests/test_util.h"

namespace hrad::render {
namespace {

scene::Camera insideFurnace() {
    scene::Camera c;
    c.eye = Vec3(0.5, 0.5, 0.95);
    c.target = Vec3(0.45, 0.5, 0.0);
    c.up = Vec3(0, 1, 0);
    c.fovYDegrees = 70.0;
    return c;
}

scene::Scene unitSquare() {
    scene::Scene s;
    uint32_t m = s.addMaterial({"grey", RGB(0.5), RGB(1.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), m);
    return s;
}

class FurnaceRender : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        scene_ = new scene::Scene(test::furnaceBox());
        vis_ = new transport::Visibility(*scene_);
        reference::FullMatrixSettings st;
        st.level = 2;
        result_ =
            new reference::FullMatrixResult(reference::solveFullMatrix(*scene_, *vis_, st, false));
    }
    static void TearDownTestSuite() {
        delete result_;
        delete vis_;
        delete scene_;
    }
    static scene::Scene* scene_;
    static transport::Visibility* vis_;
    static reference::FullMatrixResult* result_;
};
scene::Scene* FurnaceRender::scene_ = nullptr;
transport::Visibility* FurnaceRender::vis_ = nullptr;
reference::FullMatrixResult* FurnaceRender::result_ = nullptr;

TEST_F(FurnaceRender, ImageIsUniformTwo) {
    for (bool interpolate : {false, true}) {
        RenderSettings rs;
        rs.width = 64;
        rs.height = 48;
        rs.spp = 4;
        rs.interpolate = interpolate;
        Image img = renderField(*scene_, *vis_, *result_->field, insideFurnace(), rs);
        ASSERT_EQ(img.pixels.size(), 64u * 48u);
        // Inside a closed box every pixel sees a wall; B = 2 within the
        // full-matrix accuracy (1e-3).
        for (const RGB& p : img.pixels)
            ASSERT_NEAR(maxComponent(glm::abs(p - RGB(2.0))), 0.0, 2e-3)
                << "interpolate " << interpolate;
    }
}

TEST_F(FurnaceRender, BackFacesAreBlackUnlessAsked) {
    // The automatic camera looks at the box from outside: only back faces.
    RenderSettings rs;
    rs.width = rs.height = 32;
    scene::Camera cam = cameraFor(*scene_);  // no scene camera: auto
    Image black = renderField(*scene_, *vis_, *result_->field, cam, rs);
    rs.backFacesBlack = false;
    Image front = renderField(*scene_, *vis_, *result_->field, cam, rs);
    int hits = 0;
    for (size_t i = 0; i < black.pixels.size(); ++i) {
        EXPECT_EQ(black.pixels[i], RGB(0.0));
        if (front.pixels[i] != RGB(0.0)) {
            ++hits;
            EXPECT_NEAR(front.pixels[i].r, 2.0, 2e-3);
        }
    }
    // The box fills a good part of the auto camera's view and is centred.
    EXPECT_GT(hits, 32 * 32 / 8);
    EXPECT_NE(front.at(16, 16), RGB(0.0));
}

/// A closed box [0,X] x [0,Y] x [0,Z] (faces facing inwards).
scene::Scene closedBox(double X, double Y, double Z, int upAxis) {
    scene::Scene s;
    s.upAxis = upAxis;
    uint32_t m = s.addMaterial(scene::Material{});
    Vec3 p[8];
    for (int i = 0; i < 8; ++i) p[i] = Vec3(i & 1 ? X : 0, i & 2 ? Y : 0, i & 4 ? Z : 0);
    // Each face once; opposite faces have opposite normals, so the vector
    // area is zero whichever way they face.
    s.addQuad(p[0], p[1], p[3], p[2], m);
    s.addQuad(p[4], p[6], p[7], p[5], m);
    s.addQuad(p[0], p[4], p[5], p[1], m);
    s.addQuad(p[2], p[3], p[7], p[6], m);
    s.addQuad(p[0], p[2], p[6], p[4], m);
    s.addQuad(p[1], p[5], p[7], p[3], m);
    return s;
}

int largestAxis(const Vec3& v) {
    Vec3 a = glm::abs(v);
    return a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
}

TEST(AutoCamera, UsesTheFormatsUpAxisAndTheLongestHorizontalExtent) {
    struct Case {
        Vec3 size;
        int up, longest;
    };
    // A long hall, z-up (MGF) and y-up (OBJ/glTF), long along either
    // horizontal axis; the last case is a flat y-up slab whose smallest
    // extent is its up axis.
    for (Case c : {Case{Vec3(10, 2, 3), 2, 0}, Case{Vec3(2, 10, 3), 2, 1},
                   Case{Vec3(10, 3, 2), 1, 0}, Case{Vec3(2, 3, 10), 1, 2},
                   Case{Vec3(10, 0.5, 4), 1, 0}}) {
        scene::Scene s = closedBox(c.size.x, c.size.y, c.size.z, c.up);
        ASSERT_EQ(s.patches.size(), 6u);
        scene::Camera cam = autoCamera(s);
        Vec3 up(0.0);
        up[c.up] = 1.0;
        EXPECT_EQ(cam.up, up) << c.size.x << " " << c.size.y << " " << c.size.z;
        Vec3 view = cam.target - cam.eye;
        EXPECT_EQ(largestAxis(view), c.longest);
        // Seen from above: the eye is higher than the target.
        EXPECT_GT(cam.eye[c.up], cam.target[c.up]);
        // The frame built from it is upright: its up vector has a positive
        // component along the scene's up axis.
        CameraFrame f(cam, 8, 8);
        EXPECT_GT(f.up[c.up], 0.5);
    }
}

TEST(AutoCamera, InteriorViewIsLevelInTheFormatsUpAxis) {
    // A tall z-up nave (smallest extent x, not z): the interior camera's up is
    // z, and it looks horizontally.
    scene::Scene s = closedBox(4, 20, 12, 2);
    transport::Visibility vis(s);
    scene::Camera cam = interiorCamera(s, vis);
    EXPECT_EQ(cam.up, Vec3(0, 0, 1));
    EXPECT_NEAR((cam.target - cam.eye).z, 0.0, 1e-12);
}

TEST(Render, ConstantReconstructionShowsLeafValues) {
    scene::Scene s = unitSquare();
    transport::Visibility vis(s);
    scene::UniformField f(s, {1});
    for (int i = 0; i < 4; ++i) f.value(size_t(i)) = RGB(double(i + 1));
    scene::Camera cam;
    cam.eye = Vec3(0.5, 0.5, 2.0);
    cam.target = Vec3(0.5, 0.5, 0.0);
    cam.fovYDegrees = 20.0;  // the square fills the whole view
    RenderSettings rs;
    rs.width = rs.height = 16;
    rs.interpolate = false;  // flat: each leaf's own value
    Image img = renderField(s, vis, f, cam, rs);
    // Children: 0 (u<.5,v<.5) 1 (u>.5,v<.5) 2 (u>.5,v>.5) 3 (u<.5,v>.5);
    // x right = +u, image y down = -v.
    EXPECT_EQ(img.at(2, 13), RGB(1.0));
    EXPECT_EQ(img.at(13, 13), RGB(2.0));
    EXPECT_EQ(img.at(13, 2), RGB(3.0));
    EXPECT_EQ(img.at(2, 2), RGB(4.0));
}

// renderFields casts each ray once for several fields; every image equals
// renderField's for that field (jittered samples and interpolation included).
TEST(Render, SeveralFieldsInOneCastMatchSeparateRenders) {
    scene::Scene s = unitSquare();
    transport::Visibility vis(s);
    scene::UniformField a(s, {1}), b(s, {2});
    for (int i = 0; i < 4; ++i) a.value(size_t(i)) = RGB(double(i + 1), 0.5, 0.25);
    for (int i = 0; i < 16; ++i) b.value(size_t(i)) = RGB(0.1 * i, 1.0, double(i % 3));
    scene::Camera cam;
    cam.eye = Vec3(0.3, 0.6, 1.5);
    cam.target = Vec3(0.5, 0.5, 0.0);
    cam.fovYDegrees = 50.0;  // the square and some background
    RenderSettings rs;
    rs.width = 12;
    rs.height = 9;
    rs.spp = 4;
    rs.interpolate = true;
    std::vector<Image> both = renderFields(s, vis, {&a, &b}, cam, rs);
    ASSERT_EQ(both.size(), 2u);
    Image ia = renderField(s, vis, a, cam, rs), ib = renderField(s, vis, b, cam, rs);
    EXPECT_EQ(both[0].pixels, ia.pixels);
    EXPECT_EQ(both[1].pixels, ib.pixels);
    EXPECT_NE(ia.pixels, ib.pixels);
}

TEST(Render, VertexInterpolationAveragesLeavesAtCorners) {
    scene::Scene s = unitSquare();
    scene::UniformField f(s, {1});
    for (int i = 0; i < 4; ++i) f.value(size_t(i)) = RGB(double(i + 1));
    VertexInterpolation vi(f);
    EXPECT_NEAR(vi.at(0, 0.5, 0.5).r, 2.5, 1e-12);  // all four leaves
    EXPECT_NEAR(vi.at(0, 0.0, 0.0).r, 1.0, 1e-12);  // only leaf 0
    EXPECT_NEAR(vi.at(0, 0.5, 0.0).r, 1.5, 1e-12);  // leaves 0 and 1
    EXPECT_NEAR(vi.at(0, 0.0, 0.5).r, 2.5, 1e-12);  // leaves 0 and 3
    // Centre of leaf 0: bilinear mean of its corners 1, 1.5, 2.5, 2.5.
    EXPECT_NEAR(vi.at(0, 0.25, 0.25).r, 1.875, 1e-12);
    EXPECT_NEAR(vi.cornerValue(0, 6, 2).r, 3.0, 1e-12);  // (1,1): leaf 2 alone

    // Triangles: a single triangle at level 1 (three corner children and the
    // inverted middle one). The midpoint of edge v0-v1 touches children 0, 1, 3.
    scene::Scene t;
    uint32_t m = t.addMaterial({"grey", RGB(0.5), RGB(1.0)});
    t.addTriangle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), m);
    scene::UniformField g(t, {1});
    for (int i = 0; i < 4; ++i) g.value(size_t(i)) = RGB(double(i + 1));
    VertexInterpolation vt(g);
    EXPECT_NEAR(vt.at(0, 0.5, 0.0).r, (1.0 + 2.0 + 4.0) / 3.0, 1e-12);
    EXPECT_NEAR(vt.at(0, 0.0, 0.0).r, 1.0, 1e-12);
}

TEST(Render, SettingsFromParams) {
    Params p;
    p.set("render.width", int64_t(320));
    p.set("render.interpolate", true);
    p.set("render.back_faces", std::string("front"));
    RenderSettings s = RenderSettings::fromParams(p);
    EXPECT_EQ(s.width, 320);
    EXPECT_EQ(s.height, 512);
    EXPECT_TRUE(s.interpolate);
    EXPECT_FALSE(s.backFacesBlack);
    EXPECT_NO_THROW(p.reportUnused());
    Params bad;
    bad.set("render.spp", int64_t(0));
    EXPECT_THROW(RenderSettings::fromParams(bad), InputError);
}

TEST(Render, ExplicitCameraFromParams) {
    Params p;
    p.set("render.eye", std::string("278, 273, -800"));
    p.set("render.target", std::string("278,273,0"));
    p.set("render.fov", 39.3);
    RenderSettings s = RenderSettings::fromParams(p);
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.camera->eye, Vec3(278, 273, -800));
    EXPECT_EQ(s.camera->target, Vec3(278, 273, 0));
    EXPECT_EQ(s.camera->up, Vec3(0, 1, 0));
    EXPECT_EQ(s.camera->fovYDegrees, 39.3);
    EXPECT_NO_THROW(p.reportUnused());
    EXPECT_NE(s.describe().find("eye=(278,273,-800)"), std::string::npos) << s.describe();
    EXPECT_FALSE(RenderSettings::fromParams(Params{}).camera.has_value());

    auto message = [](std::initializer_list<std::pair<const char*, std::string>> kv) {
        Params q;
        int line = 1;
        for (const auto& [k, v] : kv) q.set(k, v, SourceLocation{"s.toml", line++, 1});
        try {
            RenderSettings::fromParams(q);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    std::string m = message({{"render.eye", "0,0,1"}});
    EXPECT_NE(m.find("render.target"), std::string::npos) << m;
    m = message({{"render.eye", "0,0"}, {"render.target", "0,0,0"}});
    EXPECT_NE(m.find("s.toml:1"), std::string::npos) << m;
    EXPECT_NE(m.find("not a vector"), std::string::npos) << m;
    m = message({{"render.eye", "0,0,1"}, {"render.target", "0,0,nan"}});
    EXPECT_NE(m.find("s.toml:2"), std::string::npos) << m;
    m = message({{"render.eye", "0,0,1"}, {"render.target", "0,0,1"}});
    EXPECT_NE(m.find("equals"), std::string::npos) << m;
    m = message({{"render.eye", "0,0,1"}, {"render.target", "0,0,0"}, {"render.up", "0,0,2"}});
    EXPECT_NE(m.find("s.toml:3"), std::string::npos) << m;
    EXPECT_NE(m.find("parallel"), std::string::npos) << m;
    m = message({{"render.up", "0,0,1"}});
    EXPECT_NE(m.find("needs an explicit camera"), std::string::npos) << m;
}

TEST(Image, ExrRoundTrip) {
    auto dir = test::tempDir("exr");
    Image img(5, 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x) img.at(x, y) = RGB(0.1 * x, 2.0 + y, 1000.0 * (x + 1));
    std::string path = (dir / "a.exr").string();
    writeExr(img, path);
    Image back = readExr(path);
    ASSERT_EQ(back.width, 5);
    ASSERT_EQ(back.height, 3);
    for (size_t i = 0; i < img.pixels.size(); ++i)
        for (int c = 0; c < 3; ++c)  // half: 11-bit significand
            EXPECT_NEAR(back.pixels[i][c], img.pixels[i][c],
                        1e-3 * std::fabs(img.pixels[i][c]) + 1e-7);
    EXPECT_THROW(writeExr(img, (dir / "no/such/dir/a.exr").string()), InputError);
}

uint32_t be32(const unsigned char* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}

TEST(Image, PngHasSignatureAndSize) {
    auto dir = test::tempDir("png");
    Image img(37, 11);
    for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = RGB(double(i % 13));
    std::string path = (dir / "a.png").string();
    writePng(img, path);
    std::ifstream in(path, std::ios::binary);
    unsigned char h[24];
    ASSERT_TRUE(in.read(reinterpret_cast<char*>(h), 24));
    const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    EXPECT_EQ(std::memcmp(h, sig, 8), 0);
    EXPECT_EQ(std::memcmp(h + 12, "IHDR", 4), 0);
    EXPECT_EQ(be32(h + 16), 37u);
    EXPECT_EQ(be32(h + 20), 11u);
    EXPECT_THROW(writePng(img, (dir / "no/such/dir/a.png").string()), InputError);
}

TEST(Image, ToneMapping) {
    EXPECT_EQ(encodeSrgb8(0.0), 0);
    EXPECT_EQ(encodeSrgb8(1.0), 255);
    EXPECT_EQ(encodeSrgb8(7.0), 255);
    EXPECT_EQ(encodeSrgb8(0.5), 188);  // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
    // 99th percentile of 1..100 (equal weights) is 99.
    std::vector<RGB> v;
    for (int i = 1; i <= 100; ++i) v.push_back(RGB(double(i)));
    EXPECT_NEAR(autoExposure(v), 1.0 / 99.0, 1e-12);
    EXPECT_EQ(autoExposure({RGB(0.0)}), 1.0);
}

TEST(Ply, HeaderCountsAndSize) {
    auto dir = test::tempDir("ply");
    scene::Scene s = test::furnaceBox();
    scene::UniformField f(s, scene::uniformLevels(s, 1, 0));
    for (size_t i = 0; i < f.numElements(); ++i) f.value(i) = RGB(2.0, 1.0, double(i));
    std::string path = (dir / "a.ply").string();
    PlyCounts counts = writePly(f, path);
    EXPECT_EQ(counts.faces, 24u);
    EXPECT_EQ(counts.vertices, 96u);

    std::ifstream in(path, std::ios::binary);
    std::string line, header;
    long vertices = -1, faces = -1;
    while (std::getline(in, line)) {
        header += line + "\n";
        std::istringstream ls(line);
        std::string a, b;
        long n = 0;
        if (ls >> a >> b >> n && a == "element") (b == "vertex" ? vertices : faces) = n;
        if (line == "end_header") break;
    }
    EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
    EXPECT_EQ(vertices, 96);
    EXPECT_EQ(faces, 24);
    EXPECT_NE(header.find("property float radiosity_r"), std::string::npos);
    // Body: 96 * (3 float + 3 uchar) + 24 * (uchar count + 4 int + 3 float).
    auto bodyStart = in.tellg();
    in.seekg(0, std::ios::end);
    EXPECT_EQ(long(in.tellg() - bodyStart), 96 * 15 + 24 * (1 + 16 + 12));
    // First face's linear radiosity survives (float).
    in.seekg(bodyStart + std::streamoff(96 * 15 + 17));
    float r[3];
    in.read(reinterpret_cast<char*>(r), sizeof r);
    EXPECT_EQ(r[0], 2.0f);
    EXPECT_EQ(r[1], 1.0f);
    EXPECT_EQ(r[2], 0.0f);
}

}  // namespace
}  // namespace hrad::render
