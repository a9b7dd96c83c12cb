// UVs of PLY, .serialized and Mitsuba's analytic shapes (cube, disk, sphere, cylinder)
// under a Mitsuba `bitmap`: a known texel lands where Mitsuba 3 puts it, and a
// patch's rho is the analytic mean of the texels it covers.
//
// The texture is 8 x 8 texels in four constant 4 x 4 quadrants, written raw
// (linear): top-left a (red), top-right b (green), bottom-left c (blue),
// bottom-right d (grey), each at 200/255. Mitsuba's uv (s, t) looks up image
// column s * 8 and row t * 8 from the top (its bitmap texture); hrad's UV is
// (s, 1 - t) (scene/texture.h).
#include <gtest/gtest.h>
#include <stb/stb_image_write.h>  // Debian libstb-dev; implementation in libstb
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.h"
#include "scene/element.h"
#include "scene/loader.h"
#include "scene/mitsuba_serialized.h"
#include "scene/ply_loader.h"
#include "scene/texture.h"
#include "tests/scene/little_endian.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

constexpr double kLevel = 200.0 / 255.0;
const RGB kA(kLevel, 0, 0), kB(0, kLevel, 0), kC(0, 0, kLevel), kD(kLevel, kLevel, kLevel);

void writeQuadrants(const std::filesystem::path& file) {
    unsigned char px[8 * 8 * 3];
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            const RGB q = y < 4 ? (x < 4 ? kA : kB) : (x < 4 ? kC : kD);
            for (int c = 0; c < 3; ++c) px[(y * 8 + x) * 3 + c] = q[c] > 0 ? 200 : 0;
        }
    ASSERT_TRUE(stbi_write_png(file.c_str(), 8, 8, 3, px, 8 * 3));
}

/// The quadrant texel at Mitsuba's uv (s, t), both away from the quadrant borders.
RGB quadrantAt(double s, double t) { return t < 0.5 ? (s < 0.5 ? kA : kB) : (s < 0.5 ? kC : kD); }

std::string bitmapShape(const std::string& shape, const std::string& inner = "") {
    return "  <shape type=\"" + shape + "\">" + inner +
           "\n    <bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"bitmap\">"
           "<string name=\"filename\" value=\"quad.png\"/><boolean name=\"raw\" value=\"true\"/>"
           "</texture></bsdf>\n  </shape>\n";
}

/// A scene of the given shapes and a lamp far above (only its presence matters).
Scene loadShapes(const std::filesystem::path& dir, const std::string& shapes) {
    auto xml = test::writeFile(
        dir / "scene.xml",
        "<scene version=\"3.0.0\">\n"
        "  <shape type=\"rectangle\"><transform name=\"to_world\"><translate value=\"0, 0, 50\"/>"
        "</transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 1, "
        "1\"/></emitter></shape>\n" +
            shapes + "</scene>\n");
    return loadScene(xml.string());
}

std::vector<const Patch*> textured(const Scene& s) {
    std::vector<const Patch*> out;
    for (const Patch& p : s.patches)
        if (patchTexture(s, p)) out.push_back(&p);
    return out;
}

void expectRGB(const RGB& got, const RGB& want, double tol, const std::string& what) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], tol) << what << " channel " << c;
}

TEST(ShapeUVs, PlyUVsFollowMitsubaAndItsFlipTexCoords) {
    auto dir = test::tempDir("uv_ply");
    writeQuadrants(dir / "quad.png");
    // Mitsuba's uv [0, 1/2]^2 = the top-left quadrant, stored as (u, v).
    test::writeFile(dir / "quad.ply",
                    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                    "property float y\nproperty float z\nproperty float u\nproperty float v\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                    "0 0 0 0 0\n1 0 0 0.5 0\n1 1 0 0.5 0.5\n0 1 0 0 0.5\n4 0 1 2 3\n");
    Scene s = loadShapes(
        dir,
        bitmapShape("ply", "<string name=\"filename\" value=\"quad.ply\"/>") +
            bitmapShape(
                "ply",
                "<string name=\"filename\" value=\"quad.ply\"/><boolean name=\"flip_tex_coords\" "
                "value=\"true\"/><transform name=\"to_world\"><translate value=\"0, 0, "
                "2\"/></transform>"));
    const auto ps = textured(s);
    ASSERT_EQ(ps.size(), 2u);
    for (const Patch* p : ps) {
        ASSERT_EQ(p->kind, PatchKind::Quad);
        const bool flipped = p->v[0].z > 1;
        // Unflipped: the top-left quadrant a; flip_tex_coords: Mitsuba's v is
        // 1 - stored, the bottom-left c. The patch mean is that of the texels
        // as squares (scene/texture.h): over one whole quadrant, its colour.
        const RGB want = flipped ? kC : kA;
        // Texels are floats; the box quadrature is exact on an axis-aligned map.
        expectRGB(p->rho, want, 1e-6, flipped ? "flipped ply" : "ply");
        // The texel near the corner (0.1, 0.1): Mitsuba uv (0.05, 0.05) or (0.05, 0.95).
        const Vec2 at = patchInverse(*p, Vec3(0.2, 0.2, p->v[0].z));
        expectRGB(textureRho(s, *p, at.x, at.y), flipped ? kC : kA, 1e-6, "texel");
    }
}

TEST(ShapeUVs, PlyLoaderKeepsEveryUVPropertyPairWhenAsked) {
    auto dir = test::tempDir("uv_ply_names");
    const char* pairs[4][2] = {
        {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
    for (const auto& pr : pairs) {
        const std::string name = std::string(pr[0]) + ".ply";
        auto f = test::writeFile(
            dir / name,
            std::string("ply\nformat ascii 1.0\nelement vertex 3\n"
                        "property float x\nproperty float y\nproperty float z\nproperty float ") +
                pr[0] + "\nproperty float " + pr[1] +
                "\nelement face 1\nproperty list uchar int vertex_indices\n"
                "end_header\n0 0 0 0.1 0.2\n1 0 0 0.3 0.4\n0 1 0 0.5 0.6\n3 0 1 2\n");
        PlyOptions o;
        Scene plain = loadPly(f.string(), o);
        EXPECT_TRUE(plain.cornerUVs.empty()) << name << ": not kept unless asked";
        o.keepUVs = true;
        Scene s = loadPly(f.string(), o);
        ASSERT_EQ(s.patches.size(), 1u);
        const auto* uv = patchUVs(s, s.patches[0]);
        ASSERT_TRUE(uv) << name;
        const float want[3][2] = {{0.1f, 0.2f}, {0.3f, 0.4f}, {0.5f, 0.6f}};
        for (int k = 0; k < 3; ++k) {
            // The patch keeps the input's corner order (a triangle).
            const Vec3 x = s.patches[0].v[size_t(k)];
            const int src = x.x > 0.5 ? 1 : x.y > 0.5 ? 2 : 0;
            EXPECT_FLOAT_EQ((*uv)[size_t(k)].x, want[src][0]) << name;
            EXPECT_FLOAT_EQ((*uv)[size_t(k)].y, want[src][1]) << name;
        }
    }
}

using test::put;
using test::putFloat;

/// A one-mesh .serialized file (version 4, single precision) with texture
/// coordinates (flag 0x0002) after the positions, as the format documents.
std::string serializedWithUVs(const std::vector<float>& pos, const std::vector<float>& uv,
                              const std::vector<uint32_t>& idx) {
    std::string raw;
    put(raw, uint32_t(0x1000 | 0x0002));
    raw += "mesh";
    raw += '\0';
    put(raw, uint64_t(pos.size() / 3));
    put(raw, uint64_t(idx.size() / 3));
    for (float f : pos) putFloat(raw, f);
    for (float f : uv) putFloat(raw, f);
    for (uint32_t i : idx) put(raw, i);
    uLongf n = compressBound(uLong(raw.size()));
    std::string z(n, '\0');
    EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(z.data()), &n,
                        reinterpret_cast<const Bytef*>(raw.data()), uLong(raw.size()), 9),
              Z_OK);
    z.resize(n);
    std::string f;
    put(f, uint16_t(0x041C));
    put(f, uint16_t(4));
    f += z;
    put(f, uint64_t(0));
    put(f, uint32_t(1));
    return f;
}

TEST(ShapeUVs, SerializedTexcoordsAreMitsubasUV) {
    auto dir = test::tempDir("uv_serialized");
    writeQuadrants(dir / "quad.png");
    // A unit square as two triangles; its uv is the top-right quadrant's
    // interior (texels 4.5 .. 7.5 across, 0.5 .. 3.5 down), where the bilinear
    // texture is the constant b: each triangle's mean is b exactly.
    const std::vector<float> pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const std::vector<float> uv = {9 / 16.f,  1 / 16.f, 15 / 16.f, 1 / 16.f,
                                   15 / 16.f, 7 / 16.f, 9 / 16.f,  7 / 16.f};
    test::writeFile(dir / "quad.serialized", serializedWithUVs(pos, uv, {0, 1, 2, 0, 2, 3}));
    Scene s = loadShapes(
        dir, bitmapShape("serialized", "<string name=\"filename\" value=\"quad.serialized\"/>"));
    const auto ps = textured(s);
    ASSERT_EQ(ps.size(), 2u);
    for (const Patch* p : ps) {
        expectRGB(p->rho, kB, 1e-6, "serialized mean");
        // Mitsuba's uv at x is (9/16 + 6/16 x, 1/16 + 6/16 y): the point (0.5, 0.1)
        // is at (3/4, 0.0975), the top-right quadrant (a v-flip would give d).
        const Vec2 at = patchInverse(*p, Vec3(0.5, 0.1, 0));
        const Vec2 st = uvAt(*p, *patchUVs(s, *p), at.x, at.y);
        EXPECT_NEAR(st.x, 0.75, 1e-6);
        EXPECT_NEAR(st.y, 1 - (1 / 16.0 + 6 / 16.0 * 0.1), 1e-6);
    }
}

TEST(ShapeUVs, NonFiniteSerializedTexcoordIsAnInputErrorAtItsOffset) {
    auto dir = test::tempDir("uv_serialized_nan");
    const std::vector<float> pos = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const std::vector<float> uv = {0, 0, 1, 0, 0, std::nanf("")};
    const auto f = test::writeFile(dir / "bad.serialized", serializedWithUVs(pos, uv, {0, 1, 2}));
    try {
        readSerialized(f.string(), 0, 100);
        FAIL() << "a NaN texture coordinate must be refused";
    } catch (const InputError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("vertex 2 has a non-finite texture coordinate"), std::string::npos) << m;
        EXPECT_NE(m.find("byte offset"), std::string::npos) << m;
    }
}

// Mitsuba 3's cube (src/shapes/cube.cpp): per face, the corners at uv (0, 0),
// (1, 0) and (0, 1) of its vertex and texcoord tables.
struct CubeFace {
    Vec3 normal, o, u, v;
};
const CubeFace kCubeFaces[6] = {{{0, -1, 0}, {-1, -1, -1}, {-1, -1, 1}, {1, -1, -1}},
                                {{0, 1, 0}, {1, 1, 1}, {-1, 1, 1}, {1, 1, -1}},
                                {{1, 0, 0}, {1, -1, 1}, {1, 1, 1}, {1, -1, -1}},
                                {{0, 0, 1}, {-1, -1, 1}, {-1, 1, 1}, {1, -1, 1}},
                                {{-1, 0, 0}, {-1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}},
                                {{0, 0, -1}, {-1, 1, -1}, {-1, -1, -1}, {1, 1, -1}}};

TEST(ShapeUVs, CubeFacesCarryMitsubasParametrisation) {
    auto dir = test::tempDir("uv_cube");
    writeQuadrants(dir / "quad.png");
    Scene s = loadShapes(dir, bitmapShape("cube"));
    const auto ps = textured(s);
    ASSERT_EQ(ps.size(), 6u);
    for (const CubeFace& f : kCubeFaces) {
        const Patch* face = nullptr;
        for (const Patch* p : ps)
            if (glm::dot(p->normal, f.normal) > 0.999) face = p;
        ASSERT_TRUE(face);
        // Every face covers the whole texture: its mean is the texture's, (a + b + c + d) / 4.
        expectRGB(face->rho, 0.25 * (kA + kB + kC + kD), 1e-6, "cube face mean");
        for (double sv : {0.25, 0.75})
            for (double tv : {0.25, 0.75}) {
                const Vec3 x = f.o + sv * (f.u - f.o) + tv * (f.v - f.o);
                const Vec2 at = patchInverse(*face, x);
                expectRGB(textureRho(s, *face, at.x, at.y), quadrantAt(sv, tv), 1e-6, "cube texel");
            }
    }
}

/// Mitsuba's uv of a point on the unit disk (disk.cpp): (r, phi / 2 pi).
Vec2 diskUV(const Vec3& x) {
    double phi = std::atan2(x.y, x.x);
    if (phi < 0) phi += 2 * kPi;
    return {std::hypot(x.x, x.y), phi / (2 * kPi)};
}
/// Mitsuba's uv of a direction from the sphere's centre (sphere.cpp): (phi / 2 pi, theta / pi).
Vec2 sphereUV(const Vec3& x) {
    double phi = std::atan2(x.y, x.x);
    if (phi < 0) phi += 2 * kPi;
    return {phi / (2 * kPi), std::acos(std::clamp(x.z / glm::length(x), -1.0, 1.0)) / kPi};
}

TEST(ShapeUVs, DiskAndSphereFollowMitsubasParametrisation) {
    auto dir = test::tempDir("uv_round");
    writeQuadrants(dir / "quad.png");
    Scene s = loadShapes(
        dir, bitmapShape("disk") +
                 bitmapShape("sphere", "<point name=\"center\" x=\"0\" y=\"0\" z=\"10\"/>"));
    const auto ps = textured(s);
    const int n = 24;  // mitsuba.resolution's default: n disk wedges, n x n/2 sphere faces
    ASSERT_EQ(ps.size(), size_t(n + n * n / 2));
    size_t checkedTexels = 0;
    for (const Patch* p : ps) {
        const bool sphere = p->v[0].z > 5;
        // At the face's parametric centre the linear UV differs from Mitsuba's
        // curved map by the facet's size: the disk's r and phi are linear
        // along the rim chords (|dr| < 1 - cos(pi / n) relative, 1.7e-2 with
        // the rim's u = 1 on a polygon scaled to area pi); the sphere's theta is
        // off by O((pi / rings)^2). 0.02 is below one segment (1 / 24 = 0.042).
        const double a = p->kind == PatchKind::Quad ? 0.5 : 1.0 / 3;
        const Vec3 x = p->point(a, a) - (sphere ? Vec3(0, 0, 10) : Vec3(0.0));
        const Vec2 want = sphere ? sphereUV(x) : diskUV(x);
        const Vec2 st = uvAt(*p, *patchUVs(s, *p), a, a);
        EXPECT_NEAR(st.x, want.x, 0.02) << (sphere ? "sphere" : "disk");
        EXPECT_NEAR(st.y, 1 - want.y, 0.02) << (sphere ? "sphere" : "disk");
        // A face whose corners all lie inside one quadrant's interior (half a
        // texel from its borders) shows that quadrant's texel everywhere.
        const auto& uv = *patchUVs(s, *p);
        auto inside = [](double c) {
            return std::fabs(c - 0.5) > 1 / 16.0 && c > 1 / 16.0 && c < 15 / 16.0;
        };
        bool interior = true;
        for (int k = 0; k < p->numVertices(); ++k)
            interior = interior && inside(uv[size_t(k)].x) && inside(uv[size_t(k)].y);
        if (!interior) continue;
        expectRGB(p->rho, quadrantAt(want.x, want.y), 1e-6, sphere ? "sphere face" : "disk face");
        ++checkedTexels;
    }
    EXPECT_GT(checkedTexels, 50u);
}

/// Mitsuba 3's uv of point x on a cylinder from p0 to p1 (cylinder.cpp):
/// local = the inverse of translate(p0) to_frame(Frame(d / |d|)) scale(r, r,
/// |d|); uv = (atan2(y, x) / 2 pi in [0, 1), z). The frame's (s, t) is Duff
/// et al.'s basis (JCGT 6(1), 2017, listing 3), written out here.
Vec2 cylinderUV(const Vec3& x, const Vec3& p0, const Vec3& p1) {
    const Vec3 d = p1 - p0, n = glm::normalize(d);
    const double sg = n.z >= 0 ? 1.0 : -1.0, a = -1.0 / (sg + n.z), b = n.x * n.y * a;
    const Vec3 fs(1 + sg * n.x * n.x * a, sg * b, -sg * n.x), ft(b, sg + n.y * n.y * a, -n.y);
    const Vec3 q = x - p0;
    double phi = std::atan2(glm::dot(q, ft), glm::dot(q, fs));
    if (phi < 0) phi += 2 * M_PI;
    return {phi / (2 * M_PI), glm::dot(q, n) / glm::length(d)};
}

TEST(ShapeUVs, CylinderFollowsMitsubasParametrisation) {
    auto dir = test::tempDir("uv_cylinder");
    writeQuadrants(dir / "quad.png");
    // A tilted axis, so that Mitsuba's frame is not the identity.
    const Vec3 p0(1, 2, 3), p1(1.3, 2.4, 5);
    Scene s = loadShapes(dir, bitmapShape("cylinder",
                                          "<point name=\"p0\" x=\"1\" y=\"2\" z=\"3\"/>"
                                          "<point name=\"p1\" x=\"1.3\" y=\"2.4\" z=\"5\"/>"
                                          "<float name=\"radius\" value=\"0.5\"/>"));
    const auto ps = textured(s);
    ASSERT_EQ(ps.size(), 24u);  // mitsuba.resolution's default: 24 facets
    int left = 0, right = 0;
    for (const Patch* p : ps) {
        // At the facet's mid-angle (a = 1/2) a chord point has Mitsuba's angle
        // exactly (symmetry), and z is linear along the axis: the linear UV
        // is Mitsuba's there up to the float UVs (1e-6). b = 1/4 is nearer
        // p0, so hrad's v = 1 - z = 3/4 tells the v direction.
        const Vec3 x = p->point(0.5, 0.25);
        const Vec2 want = cylinderUV(x, p0, p1);
        const Vec2 st = uvAt(*p, *patchUVs(s, *p), 0.5, 0.25);
        EXPECT_NEAR(st.x - std::floor(st.x), want.x, 1e-6);
        EXPECT_NEAR(want.y, 0.25, 1e-9);
        EXPECT_NEAR(st.y, 1 - want.y, 1e-6);
        // Each facet spans v in [0, 1]: over a whole period in v the repeat-
        // wrapped bilinear mean of a column is (top + bottom) / 2. A facet
        // whose u lies inside one half (half a texel from its borders) has
        // that half's mean: (a + c) / 2 left, (b + d) / 2 right.
        const auto& uv = *patchUVs(s, *p);
        const double lo = std::min(uv[0].x, uv[1].x), hi = std::max(uv[0].x, uv[1].x);
        if (lo > 1 / 16.0 && hi < 0.5 - 1 / 16.0) {
            expectRGB(p->rho, 0.5 * (kA + kC), 1e-6, "left facet");
            ++left;
        } else if (lo > 0.5 + 1 / 16.0 && hi < 1 - 1 / 16.0) {
            expectRGB(p->rho, 0.5 * (kB + kD), 1e-6, "right facet");
            ++right;
        }
    }
    EXPECT_GE(left, 8);
    EXPECT_GE(right, 8);
}

}  // namespace
}  // namespace hrad::scene
