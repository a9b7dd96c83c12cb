// Built-in scenes (see builtin.h). All geometry is deterministic.
#include "scene/builtin.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/error.h"
#include "scene/triangulate.h"

namespace hrad::scene {

namespace {

const char* kUsage =
    "valid built-in scenes: cornell, furnace[:rho[:E[:side]]], plates:parallel:W:H:D, "
    "plates:perpendicular:W:H:L, plates:occluded:W:H:D:S:Z (0 < Z < D), office:N, office:N:T "
    "(tessellated furniture, T in [1, 64])";

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    size_t start = 0;
    while (true) {
        size_t p = s.find(sep, start);
        out.push_back(s.substr(start, p == std::string::npos ? std::string::npos : p - start));
        if (p == std::string::npos) break;
        start = p + 1;
    }
    return out;
}

double parseArg(const std::string& spec, const std::string& text, const char* what) {
    char* end = nullptr;
    double v = std::strtod(text.c_str(), &end);
    if (text.empty() || !end || *end != '\0' || !std::isfinite(v))
        throwInputError(SourceLocation{spec, 0, 0}, "built-in scene '{}': {} '{}' is not a number; {}",
                        spec, what, text, kUsage);
    return v;
}

double parsePositive(const std::string& spec, const std::string& text, const char* what) {
    double v = parseArg(spec, text, what);
    if (!(v > 0))
        throwInputError(SourceLocation{spec, 0, 0}, "built-in scene '{}': {} must be > 0, got {}",
                        spec, what, v);
    return v;
}

/// Adds quad a,b,c,d, reversing the order when its normal points away from
/// `facing` (so callers state intent, not winding).
void quadFacing(Scene& s, Vec3 a, Vec3 b, Vec3 c, Vec3 d, const Vec3& facing, uint32_t m) {
    Vec3 n = glm::cross(c - a, d - b);
    if (glm::dot(n, facing) < 0) std::swap(b, d);
    addPolygon(s, {a, b, c, d}, m);
}

/// Axis-aligned box with outward faces; `skip` is a bit mask of faces not
/// emitted (1:-x 2:+x 4:-y 8:+y 16:-z 32:+z), e.g. faces resting on the floor.
void addBox(Scene& s, const Vec3& lo, const Vec3& hi, uint32_t m, unsigned skip = 0) {
    Vec3 p[8];
    for (int i = 0; i < 8; ++i)
        p[i] = Vec3((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
    if (!(skip & 1)) quadFacing(s, p[0], p[2], p[6], p[4], Vec3(-1, 0, 0), m);
    if (!(skip & 2)) quadFacing(s, p[1], p[3], p[7], p[5], Vec3(1, 0, 0), m);
    if (!(skip & 4)) quadFacing(s, p[0], p[1], p[5], p[4], Vec3(0, -1, 0), m);
    if (!(skip & 8)) quadFacing(s, p[2], p[3], p[7], p[6], Vec3(0, 1, 0), m);
    if (!(skip & 16)) quadFacing(s, p[0], p[1], p[3], p[2], Vec3(0, 0, -1), m);
    if (!(skip & 32)) quadFacing(s, p[4], p[5], p[7], p[6], Vec3(0, 0, 1), m);
}

/// A planar grid of quads base + a*dirA + b*dirB over the cut positions,
/// facing `facing`; cells for which skip(a0,a1,b0,b1) is true are left out.
template <typename Skip>
void addGrid(Scene& s, const Vec3& base, const Vec3& dirA, const Vec3& dirB,
             const std::vector<double>& cutsA, const std::vector<double>& cutsB,
             const Vec3& facing, uint32_t m, Skip skip) {
    for (size_t i = 0; i + 1 < cutsA.size(); ++i)
        for (size_t j = 0; j + 1 < cutsB.size(); ++j) {
            double a0 = cutsA[i], a1 = cutsA[i + 1], b0 = cutsB[j], b1 = cutsB[j + 1];
            if (skip(a0, a1, b0, b1)) continue;
            quadFacing(s, base + a0 * dirA + b0 * dirB, base + a1 * dirA + b0 * dirB,
                       base + a1 * dirA + b1 * dirB, base + a0 * dirA + b1 * dirB, facing, m);
        }
}

void finish(Scene& s, const std::string& name) {
    s.name = name;
    s.source = "builtin";
    s.stats.inputFaces = s.patches.size();
}

/// A camera without a film: the image size is the renderer's.
Camera pinhole(Vec3 eye, Vec3 target, Vec3 up, double fovYDegrees) {
    Camera c;
    c.eye = eye;
    c.target = target;
    c.up = up;
    c.fovYDegrees = fovYDegrees;
    return c;
}

// ---- Tessellated furniture for office:N:T --------------------------------
//
// Connected triangle meshes as real models have them: every mesh is closed
// (watertight, consistently oriented outward) and neighbouring triangles share
// their vertices. Patches carry their own corner positions, so "shared" means
// bit-identical: every vertex is computed once from integer grid coordinates
// and stored in an index table, and each triangle copies the positions from
// that table (a face-cluster builder finds the connectivity by welding equal
// positions). Every triangle must survive Scene::addTriangle (non-degenerate),
// so the counts documented in builtin.h are exact; a dropped one is a bug.

/// An indexed triangle mesh emitted into the scene as root patches.
struct MeshBuilder {
    std::vector<Vec3> vertices;
    std::vector<std::array<uint32_t, 3>> triangles;
    uint32_t add(const Vec3& p) {
        vertices.push_back(p);
        return uint32_t(vertices.size() - 1);
    }
    void tri(uint32_t a, uint32_t b, uint32_t c) { triangles.push_back({a, b, c}); }
    void emit(Scene& s, uint32_t material) const {
        for (const auto& t : triangles) {
            bool added = s.addTriangle(vertices[t[0]], vertices[t[1]], vertices[t[2]], material);
            HRAD_CHECK_MSG(added, "office tessellation made a degenerate triangle");
        }
    }
};

/// A closed surface of revolution (sphere topology): `rings` rings of `segs`
/// vertices ring(i, j) (i = 0 nearest `bottom`, j around the axis from +x
/// towards +z), closed by a fan to each pole. With
/// the rings ordered so that the profile (bottom pole, rings, top pole) runs
/// counter-clockwise in the (r, y) half-plane, the normals point outward:
/// at a vertex the tangents are dP/di and dP/dj and cross(dP/di, dP/dj) is
/// the outward normal (for a cylinder wall, dP/di = +y, dP/dj = the azimuth
/// direction). 2 segs rings triangles, segs rings + 2 vertices.
template <typename Ring>
void addRevolved(Scene& s, int rings, int segs, const Vec3& bottom, const Vec3& top, Ring ring,
                 uint32_t material) {
    MeshBuilder m;
    uint32_t pb = m.add(bottom);
    std::vector<uint32_t> idx(size_t(rings) * size_t(segs));
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segs; ++j) idx[size_t(i) * segs + j] = m.add(ring(i, j));
    uint32_t pt = m.add(top);
    auto at = [&](int i, int j) { return idx[size_t(i) * segs + size_t(j % segs)]; };
    for (int j = 0; j < segs; ++j) m.tri(pb, at(0, j), at(0, j + 1));
    for (int i = 0; i + 1 < rings; ++i)
        for (int j = 0; j < segs; ++j) {
            uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
            m.tri(a, b, c);
            m.tri(a, c, d);
        }
    for (int j = 0; j < segs; ++j) m.tri(at(rings - 1, j), pt, at(rings - 1, j + 1));
    m.emit(s, material);
}

/// A lathe: the profile (r_k, y_k), k = 0..K-1 (every r_k > 0), revolved
/// about the vertical axis through `axis` with `segs` segments, closed by the
/// poles (0, bottomY) and (0, topY). The profile runs counter-clockwise in
/// the (r, y) half-plane (outward from the bottom pole, up the outside, back
/// in over the top) so that the normals point outward.
void addLathe(Scene& s, const Vec3& axis, const std::vector<std::array<double, 2>>& profile,
              double bottomY, double topY, int segs, uint32_t material) {
    std::vector<double> cs(static_cast<size_t>(segs)), sn(static_cast<size_t>(segs));
    for (int j = 0; j < segs; ++j) {
        double phi = 2.0 * kPi * j / segs;
        cs[size_t(j)] = std::cos(phi);
        sn[size_t(j)] = std::sin(phi);
    }
    // Azimuth phi runs from +x towards +z: at phi = 0 on a vertical wall
    // dP/di = +y, dP/dj = +z and cross(+y, +z) = +x, outward.
    addRevolved(
        s, int(profile.size()), segs, axis + Vec3(0, bottomY, 0), axis + Vec3(0, topY, 0),
        [&](int i, int j) {
            const auto& rp = profile[size_t(i)];
            return axis + Vec3(rp[0] * cs[size_t(j)], rp[1], rp[0] * sn[size_t(j)]);
        },
        material);
}

/// A closed cylinder of radius r from y0 to y1 on the vertical axis through
/// `axis` (caps are fans): `bands` bands along its height, bands + 1 rings.
void addCylinder(Scene& s, const Vec3& axis, double r, double y0, double y1, int bands, int segs,
                 uint32_t material) {
    std::vector<std::array<double, 2>> prof;
    for (int k = 0; k <= bands; ++k) prof.push_back({r, y0 + (y1 - y0) * k / bands});
    addLathe(s, axis, prof, y0, y1, segs, material);
}

/// A closed "grid box": the surface of the unit cube [0,1]^3 mapped through
/// `map` (an orientation-preserving deformation: a box, a bent slab, a
/// cushion), each face a grid of na x nb, nb x nc or nc x na cells, each cell
/// two triangles: 4 (na nb + nb nc + nc na) triangles, outward normals.
/// Vertices on cube edges and corners are shared by the faces meeting there.
template <typename Map>
void addGridBox(Scene& s, int na, int nb, int nc, Map map, uint32_t material) {
    MeshBuilder m;
    const int n[3] = {na, nb, nc};
    // One index per surface lattice point (i, j, k), i in [0, na] etc.
    std::vector<uint32_t> idx(size_t(na + 1) * size_t(nb + 1) * size_t(nc + 1), UINT32_MAX);
    auto vert = [&](int i, int j, int k) {
        uint32_t& slot = idx[(size_t(i) * size_t(nb + 1) + size_t(j)) * size_t(nc + 1) + size_t(k)];
        if (slot == UINT32_MAX) slot = m.add(map(double(i) / na, double(j) / nb, double(k) / nc));
        return slot;
    };
    for (int a = 0; a < 3; ++a) {
        int b = (a + 1) % 3, c = (a + 2) % 3;  // e_b x e_c = e_a
        for (int side = 0; side < 2; ++side)
            for (int p = 0; p < n[b]; ++p)
                for (int q = 0; q < n[c]; ++q) {
                    auto at = [&](int dp, int dq) {
                        int g[3];
                        g[a] = side ? n[a] : 0;
                        g[b] = p + dp;
                        g[c] = q + dq;
                        return vert(g[0], g[1], g[2]);
                    };
                    uint32_t v0 = at(0, 0), v1 = at(1, 0), v2 = at(1, 1), v3 = at(0, 1);
                    if (side) {  // outward +a: counter-clockwise in (b, c)
                        m.tri(v0, v1, v2);
                        m.tri(v0, v2, v3);
                    } else {
                        m.tri(v0, v2, v1);
                        m.tri(v0, v3, v2);
                    }
                }
    }
    m.emit(s, material);
}

/// The furniture of one room of office:N:T (see builtin.h for the counts):
/// room corner (x0, 0, z0), tessellation t >= 1, s = 8 t segments around.
void addTessellatedFurniture(Scene& s, double x0, double z0, int t, uint32_t deskM, uint32_t metalM,
                             uint32_t chairM, uint32_t potM, uint32_t leafM, uint32_t cupM) {
    const int segs = 8 * t;
    // Desk near the -z wall: top 1.2 x 0.04 x 0.7 at 0.72 m (grid 12t x 1 x
    // 7t), four cylinder legs (r 2.5 cm, 8t bands) reaching 1 cm into the top
    // and standing 2 mm above the floor (so no leg cap lies in the floor plane).
    const double dx = x0 + 0.2, dz = z0 + 0.3;
    addGridBox(
        s, 12 * t, 1, 7 * t,
        [&](double u, double v, double w) {
            return Vec3(dx + 1.2 * u, 0.72 + 0.04 * v, dz + 0.7 * w);
        },
        deskM);
    for (int k = 0; k < 4; ++k) {
        Vec3 axis(dx + ((k & 1) ? 1.15 : 0.05), 0.0, dz + ((k & 2) ? 0.65 : 0.05));
        addCylinder(s, axis, 0.025, 0.002, 0.73, 8 * t, segs, metalM);
    }
    // Three cups on the desk: lathes with an outer wall (2t bands), a rim,
    // an inner wall (2t bands) down to an inner bottom 8 mm above the base.
    const double cupX[3] = {0.3, 0.45, 0.9}, cupZ[3] = {0.2, 0.5, 0.35};
    for (int c = 0; c < 3; ++c) {
        const double y0 = 0.761, hgt = 0.1;
        std::vector<std::array<double, 2>> prof;
        for (int k = 0; k <= 2 * t; ++k) {
            double f = double(k) / (2 * t);
            prof.push_back({0.035 + 0.01 * f, y0 + hgt * f});
        }
        for (int k = 0; k <= 2 * t; ++k) {
            double f = double(k) / (2 * t);
            prof.push_back({0.041 - 0.01 * f, y0 + hgt - (hgt - 0.008) * f});
        }
        addLathe(s, Vec3(dx + cupX[c], 0.0, dz + cupZ[c]), prof, y0, y0 + 0.008, segs, cupM);
    }
    // Chair in front of the desk: a cushioned seat (grid 6t x 1 x 6t, top
    // bulging 2 cm), a back bent on an arc of radius 0.5 m (grid 8t along the
    // arc x 6t up x 1 through its 3 cm thickness), four cylinder legs (r 2 cm,
    // 4t bands).
    const double cx = x0 + 0.75, cz = z0 + 1.15;
    addGridBox(
        s, 6 * t, 1, 6 * t,
        [&](double u, double v, double w) {
            double bulge = 0.02 * v * std::sin(kPi * u) * std::sin(kPi * w);
            return Vec3(cx + 0.45 * u, 0.42 + 0.05 * v + bulge, cz + 0.45 * w);
        },
        chairM);
    {
        const double rad = 0.5, phi0 = std::asin(0.45), ax = cx + 0.225, az = cz + 0.45 - rad;
        addGridBox(
            s, 8 * t, 6 * t, 1,
            [&](double u, double v, double w) {
                double phi = -phi0 + 2.0 * phi0 * u, rho = rad - 0.03 + 0.03 * w;
                return Vec3(ax + rho * std::sin(phi), 0.46 + 0.49 * v, az + rho * std::cos(phi));
            },
            chairM);
    }
    for (int k = 0; k < 4; ++k) {
        Vec3 axis(cx + ((k & 1) ? 0.41 : 0.04), 0.0, cz + ((k & 2) ? 0.41 : 0.04));
        addCylinder(s, axis, 0.02, 0.002, 0.43, 4 * t, segs, metalM);
    }
    // A potted plant in the (-x, +z) corner: a tapered pot (lathe: wall of
    // 4t bands, rim, soil 5 cm below the rim) and three overlapping bumpy
    // spheres of foliage (4t latitude bands, 4t - 1 rings).
    const Vec3 pot(x0 + 0.45, 0.0, z0 + 3.5);
    {
        std::vector<std::array<double, 2>> prof;
        for (int k = 0; k <= 4 * t; ++k) {
            double f = double(k) / (4 * t);
            prof.push_back({0.15 + 0.05 * f, 0.002 + 0.348 * f});
        }
        prof.push_back({0.185, 0.35});
        prof.push_back({0.185, 0.30});
        addLathe(s, pot, prof, 0.002, 0.30, segs, potM);
    }
    const Vec3 leafC[3] = {pot + Vec3(0.0, 0.52, 0.0), pot + Vec3(0.1, 0.68, -0.05),
                           pot + Vec3(-0.08, 0.78, 0.06)};
    const double leafR[3] = {0.2, 0.15, 0.12};
    for (int k = 0; k < 3; ++k) {
        const int bands = 4 * t;
        const Vec3 c = leafC[k];
        const double r0 = leafR[k];
        addRevolved(
            s, bands - 1, segs, c - Vec3(0, r0, 0), c + Vec3(0, r0, 0),
            [&](int i, int j) {
                double theta = kPi * (i + 1) / bands;  // polar angle from the bottom pole
                double phi = 2.0 * kPi * j / segs;
                double r = r0 * (1.0 + 0.08 * std::sin(5.0 * theta + k) * std::sin(4.0 * phi));
                return c + Vec3(r * std::sin(theta) * std::cos(phi), -r * std::cos(theta),
                                r * std::sin(theta) * std::sin(phi));
            },
            leafM);
    }
}

}  // namespace

const std::vector<std::string>& builtinNames() {
    static const std::vector<std::string> names = {"cornell", "furnace", "plates", "office"};
    return names;
}

// The Cornell box as published by the Cornell Program of Computer Graphics
// ("Cornell Box Data", http://www.graphics.cornell.edu/online/box/data.html),
// coordinates in mm exactly as measured. Reflectances and the light's emission
// are the RGB values of Cardenas & McGuire's CornellBox-Original.mtl (Williams
// College 2011, derived from the same data; ../shared/scenes/cornell-box):
// white Kd (0.725, 0.71, 0.68), red (0.63, 0.065, 0.05), green (0.14, 0.45,
// 0.091), light Kd 0.78 and Ke (17, 12, 4), which exposes the box well.
// Differences from the raw data, on purpose:
//   - the light is a quad of its own 0.1 mm below a full (hole-free) ceiling,
//     facing down, so the box stays closed and the light never coincides with
//     the ceiling plane;
//   - the red (left) wall of the measured data is not planar (its corners are
//     3.2 mm off one plane), so it goes through addPolygon and becomes two
//     triangles; every other wall and block face is a planar quad.
// The blocks' bottom faces are omitted (they rest on the floor). 17 patches.
// Camera: the published camera (eye (278, 273, -800) looking down +z, 35 mm
// focal length, 25 mm film: vertical fov 2 atan(12.5/35) = 39.31 degrees).
Scene makeCornellBox() {
    Scene s;
    uint32_t white = s.addMaterial({"white", RGB(0.725, 0.71, 0.68), RGB(0.0)});
    uint32_t red = s.addMaterial({"red", RGB(0.63, 0.065, 0.05), RGB(0.0)});
    uint32_t green = s.addMaterial({"green", RGB(0.14, 0.45, 0.091), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.78, 0.78, 0.78), RGB(17.0, 12.0, 4.0)});
    auto face = [&](std::initializer_list<Vec3> v, uint32_t m) { addPolygon(s, std::vector<Vec3>(v), m); };
    // Light (y = 548.8 in the data, lowered by 0.1 mm).
    face({{343.0, 548.7, 227.0}, {343.0, 548.7, 332.0}, {213.0, 548.7, 332.0}, {213.0, 548.7, 227.0}}, light);
    // Floor, ceiling, back wall (white).
    face({{552.8, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 559.2}, {549.6, 0.0, 559.2}}, white);
    face({{556.0, 548.8, 0.0}, {556.0, 548.8, 559.2}, {0.0, 548.8, 559.2}, {0.0, 548.8, 0.0}}, white);
    face({{549.6, 0.0, 559.2}, {0.0, 0.0, 559.2}, {0.0, 548.8, 559.2}, {556.0, 548.8, 559.2}}, white);
    // Right wall (green, x = 0) and left wall (red, x ~ 550).
    face({{0.0, 0.0, 559.2}, {0.0, 0.0, 0.0}, {0.0, 548.8, 0.0}, {0.0, 548.8, 559.2}}, green);
    face({{552.8, 0.0, 0.0}, {549.6, 0.0, 559.2}, {556.0, 548.8, 559.2}, {556.0, 548.8, 0.0}}, red);
    // Short block.
    face({{130.0, 165.0, 65.0}, {82.0, 165.0, 225.0}, {240.0, 165.0, 272.0}, {290.0, 165.0, 114.0}}, white);
    face({{290.0, 0.0, 114.0}, {290.0, 165.0, 114.0}, {240.0, 165.0, 272.0}, {240.0, 0.0, 272.0}}, white);
    face({{130.0, 0.0, 65.0}, {130.0, 165.0, 65.0}, {290.0, 165.0, 114.0}, {290.0, 0.0, 114.0}}, white);
    face({{82.0, 0.0, 225.0}, {82.0, 165.0, 225.0}, {130.0, 165.0, 65.0}, {130.0, 0.0, 65.0}}, white);
    face({{240.0, 0.0, 272.0}, {240.0, 165.0, 272.0}, {82.0, 165.0, 225.0}, {82.0, 0.0, 225.0}}, white);
    // Tall block.
    face({{423.0, 330.0, 247.0}, {265.0, 330.0, 296.0}, {314.0, 330.0, 456.0}, {472.0, 330.0, 406.0}}, white);
    face({{423.0, 0.0, 247.0}, {423.0, 330.0, 247.0}, {472.0, 330.0, 406.0}, {472.0, 0.0, 406.0}}, white);
    face({{472.0, 0.0, 406.0}, {472.0, 330.0, 406.0}, {314.0, 330.0, 456.0}, {314.0, 0.0, 456.0}}, white);
    face({{314.0, 0.0, 456.0}, {314.0, 330.0, 456.0}, {265.0, 330.0, 296.0}, {265.0, 0.0, 296.0}}, white);
    face({{265.0, 0.0, 296.0}, {265.0, 330.0, 296.0}, {423.0, 330.0, 247.0}, {423.0, 0.0, 247.0}}, white);
    s.camera = pinhole(Vec3(278.0, 273.0, -800.0), Vec3(278.0, 273.0, 0.0), Vec3(0.0, 1.0, 0.0),
                      2.0 * std::atan(12.5 / 35.0) * 180.0 / kPi);
    finish(s, "cornell");
    return s;
}

// The furnace: a closed cube [0,side]^3 of six inward-facing quads, all with
// reflectance rho and emission E. Every surface sees only the cube (sum of
// form factors 1), so the exact solution is B = E / (1 - rho) everywhere.
Scene makeFurnace(double rho, double emission, double side) {
    Scene s;
    uint32_t m = s.addMaterial({"furnace", RGB(rho), RGB(emission)});
    Vec3 c(0.5 * side);
    for (int axis = 0; axis < 3; ++axis)
        for (int hi = 0; hi < 2; ++hi) {
            Vec3 o(0.0), a(0.0), b(0.0);
            o[axis] = hi ? side : 0.0;
            a[(axis + 1) % 3] = side;
            b[(axis + 2) % 3] = side;
            Vec3 inward(0.0);
            inward[axis] = hi ? -1.0 : 1.0;
            quadFacing(s, o, o + a, o + a + b, o + b, inward, m);
        }
    s.camera = pinhole(Vec3(0.5 * side, 0.5 * side, 0.05 * side), Vec3(0.5 * side, 0.5 * side, side),
                      Vec3(0.0, 1.0, 0.0), 90.0);
    finish(s, fmt::format("furnace:{}:{}:{}", rho, emission, side));
    return s;
}

// Two directly opposed W x H rectangles at distance D (the textbook parallel-
// plates configuration, Cohen & Wallace 1993 appendix): the receiver lies in
// z = 0 facing +z, [0,W] x [0,H]; the sender lies in z = D facing -z. The
// sender emits E = 1; both have rho = 0.5 (so interreflection between the two
// is part of the exact two-patch solution B1 = E + rho F12 B2, B2 = rho F21 B1).
Scene makeParallelPlates(double w, double h, double d) {
    Scene s;
    uint32_t emitter = s.addMaterial({"sender", RGB(0.5), RGB(1.0)});
    uint32_t receiver = s.addMaterial({"receiver", RGB(0.5), RGB(0.0)});
    quadFacing(s, Vec3(0, 0, 0), Vec3(w, 0, 0), Vec3(w, h, 0), Vec3(0, h, 0), Vec3(0, 0, 1), receiver);
    quadFacing(s, Vec3(0, 0, d), Vec3(w, 0, d), Vec3(w, h, d), Vec3(0, h, d), Vec3(0, 0, -1), emitter);
    s.camera = pinhole(Vec3(0.5 * w, -1.5 * std::max(w, h), 0.5 * d), Vec3(0.5 * w, 0.5 * h, 0.5 * d),
                      Vec3(0, 0, 1), 45.0);
    finish(s, fmt::format("plates:parallel:{}:{}:{}", w, h, d));
    return s;
}

// The parallel plates of makeParallelPlates (receiver patch 0, sender patch
// 1) with an S x S square occluder (patch 2) parallel to both, centred over
// the receiver's centre at height Z (0 < Z < D): [W/2 - S/2, W/2 + S/2] x
// [H/2 - S/2, H/2 + S/2] x {Z}. It faces the receiver and is black (rho = 0,
// E = 0), so it only removes light: B1 = rho F12 B2 + ... with F12 the
// occluded form factor. Made to isolate the hemicube's third failing, that
// visibility is decided from the sample points only (Cohen & Wallace 1993
// ch. 4): from a point x of the receiver the occluder's shadow on the sender
// plane is the square of side S D / Z centred at x + (D / Z)(c - x), c the
// occluder's centre. A small occluder close to the receiver (S >= W Z / D and
// S >= H Z / D) hides the whole sender from the receiver's centre, so a
// hemicube at the centre gives F = 0 at every resolution, while the shadow
// moves off the sender for points a short way from the centre and the true
// area-averaged F stays well above 0.
Scene makeOccludedPlates(double w, double h, double d, double side, double z) {
    HRAD_CHECK_MSG(z > 0 && z < d, "occluder height {} must lie in (0, {})", z, d);
    Scene s = makeParallelPlates(w, h, d);
    uint32_t black = s.addMaterial({"occluder", RGB(0.0), RGB(0.0)});
    double x0 = 0.5 * (w - side), y0 = 0.5 * (h - side);
    quadFacing(s, Vec3(x0, y0, z), Vec3(x0 + side, y0, z), Vec3(x0 + side, y0 + side, z),
               Vec3(x0, y0 + side, z), Vec3(0, 0, -1), black);
    finish(s, fmt::format("plates:occluded:{}:{}:{}:{}:{}", w, h, d, side, z));
    return s;
}

// Two rectangles sharing the edge x in [0, L] on the x axis, at a right angle:
// the sender (emitter, E = 1) lies in y = 0, z in [0, W], facing +y...
// precisely: sender [0,L] x {0} x [0,W] facing +y; receiver [0,L] x [0,H] x {0}
// facing +z. Both face into the quadrant y, z > 0; both have rho = 0.5.
Scene makePerpendicularPlates(double w, double h, double l) {
    Scene s;
    uint32_t emitter = s.addMaterial({"sender", RGB(0.5), RGB(1.0)});
    uint32_t receiver = s.addMaterial({"receiver", RGB(0.5), RGB(0.0)});
    quadFacing(s, Vec3(0, 0, 0), Vec3(l, 0, 0), Vec3(l, 0, w), Vec3(0, 0, w), Vec3(0, 1, 0), emitter);
    quadFacing(s, Vec3(0, 0, 0), Vec3(l, 0, 0), Vec3(l, h, 0), Vec3(0, h, 0), Vec3(0, 0, 1), receiver);
    double r = std::max({w, h, l});
    s.camera = pinhole(Vec3(0.5 * l, 1.5 * r, 1.5 * r), Vec3(0.5 * l, 0.0, 0.0), Vec3(0, 1, 0), 50.0);
    finish(s, fmt::format("plates:perpendicular:{}:{}:{}", w, h, l));
    return s;
}

// office:N -- an N x N grid of furnished rooms (y up, metres). Each room is
// 4 x 4 m, 3 m high, with 0.2 m thick walls between rooms; neighbouring rooms
// are connected by 1 x 2.1 m doorways (walls are split into panels around the
// opening; the opening's jambs, head and threshold close the wall slab).
// Floors and ceilings are 1 m tiles, walls 1 m-ish panels. Per room: a ceiling
// luminaire (1.2 x 0.6 m quad 1 cm below the ceiling, E = (30, 27, 22)), a desk
// (top + 4 legs), a chair (seat, back, 4 legs) and a bookcase with 12 books.
// Surfaces of the rooms face into the rooms; furniture boxes face outward.
// Room (0,0) occupies x, z in [0, 4]; about 240 patches per room.
//
// office:N:T -- the same rooms with the desk and the chair made of connected,
// closed triangle meshes at tessellation T, plus three cups on the desk and a
// potted plant (addTessellatedFurniture; counts in builtin.h).
Scene makeOffice(int n, int tess) {
    HRAD_CHECK_MSG(n >= 1 && tess >= 0, "office:{}:{}: bad arguments", n, tess);
    Scene s;
    uint32_t wallM = s.addMaterial({"wall", RGB(0.70, 0.70, 0.66), RGB(0.0)});
    uint32_t floorM = s.addMaterial({"floor", RGB(0.45, 0.33, 0.22), RGB(0.0)});
    uint32_t ceilM = s.addMaterial({"ceiling", RGB(0.80, 0.80, 0.80), RGB(0.0)});
    uint32_t lightM = s.addMaterial({"luminaire", RGB(0.50, 0.50, 0.50), RGB(30.0, 27.0, 22.0)});
    uint32_t deskM = s.addMaterial({"desk", RGB(0.55, 0.40, 0.25), RGB(0.0)});
    uint32_t metalM = s.addMaterial({"metal", RGB(0.30, 0.30, 0.32), RGB(0.0)});
    uint32_t chairM = s.addMaterial({"chair", RGB(0.15, 0.20, 0.45), RGB(0.0)});
    uint32_t shelfM = s.addMaterial({"shelf", RGB(0.60, 0.55, 0.45), RGB(0.0)});
    uint32_t bookM[3] = {s.addMaterial({"book_red", RGB(0.55, 0.10, 0.08), RGB(0.0)}),
                         s.addMaterial({"book_green", RGB(0.10, 0.40, 0.15), RGB(0.0)}),
                         s.addMaterial({"book_blue", RGB(0.10, 0.15, 0.50), RGB(0.0)})};
    // Materials of the tessellated furniture only (office:N keeps its list).
    uint32_t potM = 0, leafM = 0, cupM = 0;
    if (tess > 0) {
        potM = s.addMaterial({"pot", RGB(0.55, 0.30, 0.20), RGB(0.0)});
        leafM = s.addMaterial({"leaves", RGB(0.12, 0.35, 0.10), RGB(0.0)});
        cupM = s.addMaterial({"cup", RGB(0.85, 0.85, 0.82), RGB(0.0)});
    }

    const double S = 4.0, H = 3.0, T = 0.2, P = S + T;
    const double doorLo = 1.5, doorHi = 2.5, doorTop = 2.1;
    const std::vector<double> tiles = {0, 1, 2, 3, 4};
    const std::vector<double> wallS = {0, 1, doorLo, doorHi, 3, 4};
    const std::vector<double> wallH = {0, 1, doorTop, H};
    const Vec3 X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1);
    auto noSkip = [](double, double, double, double) { return false; };
    auto doorSkip = [&](double s0, double s1, double h0, double) {
        return s0 >= doorLo && s1 <= doorHi && h0 < doorTop;
    };

    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double x0 = i * P, z0 = j * P;
            const Vec3 o(x0, 0, z0);
            addGrid(s, o, Z, X, tiles, tiles, Y, floorM, noSkip);
            addGrid(s, o + H * Y, X, Z, tiles, tiles, -Y, ceilM, noSkip);
            // Walls: -x (door if i > 0), +x (door if i < n-1), -z, +z.
            auto wall = [&](const Vec3& base, const Vec3& along, const Vec3& inward, bool door) {
                if (door)
                    addGrid(s, base, along, Y, wallS, wallH, inward, wallM, doorSkip);
                else
                    addGrid(s, base, along, Y, wallS, wallH, inward, wallM, noSkip);
            };
            wall(o, Z, X, i > 0);
            wall(o + S * X, Z, -X, i + 1 < n);
            wall(o, X, Z, j > 0);
            wall(o + S * Z, X, -Z, j + 1 < n);
            // Doorway through the wall slab to the +x and +z neighbours.
            if (i + 1 < n) {
                Vec3 a = o + S * X + doorLo * Z, b = o + S * X + doorHi * Z;
                quadFacing(s, a, a + T * X, a + T * X + doorTop * Y, a + doorTop * Y, Z, wallM);
                quadFacing(s, b, b + T * X, b + T * X + doorTop * Y, b + doorTop * Y, -Z, wallM);
                quadFacing(s, a + doorTop * Y, a + doorTop * Y + T * X, b + doorTop * Y + T * X,
                           b + doorTop * Y, -Y, wallM);
                quadFacing(s, a, a + T * X, b + T * X, b, Y, floorM);
            }
            if (j + 1 < n) {
                Vec3 a = o + S * Z + doorLo * X, b = o + S * Z + doorHi * X;
                quadFacing(s, a, a + T * Z, a + T * Z + doorTop * Y, a + doorTop * Y, X, wallM);
                quadFacing(s, b, b + T * Z, b + T * Z + doorTop * Y, b + doorTop * Y, -X, wallM);
                quadFacing(s, a + doorTop * Y, a + doorTop * Y + T * Z, b + doorTop * Y + T * Z,
                           b + doorTop * Y, -Y, wallM);
                quadFacing(s, a, a + T * Z, b + T * Z, b, Y, floorM);
            }
            // Luminaire.
            {
                double y = H - 0.01;
                Vec3 a(x0 + 1.4, y, z0 + 1.7);
                quadFacing(s, a, a + 1.2 * X, a + 1.2 * X + 0.6 * Z, a + 0.6 * Z, -Y, lightM);
            }
            if (tess > 0)
                addTessellatedFurniture(s, x0, z0, tess, deskM, metalM, chairM, potM, leafM, cupM);
            // Desk near the -z wall: top 1.2 x 0.7 x 0.04 at 0.72 m, four legs.
            if (tess == 0) {
                double dx = x0 + 0.2, dz = z0 + 0.3;
                addBox(s, {dx, 0.72, dz}, {dx + 1.2, 0.76, dz + 0.7}, deskM);
                for (int k = 0; k < 4; ++k) {
                    double lx = dx + ((k & 1) ? 1.1 : 0.05), lz = dz + ((k & 2) ? 0.6 : 0.05);
                    addBox(s, {lx, 0.0, lz}, {lx + 0.05, 0.72, lz + 0.05}, metalM, 4 | 8);
                }
            }
            // Chair in front of the desk.
            if (tess == 0) {
                double cx = x0 + 0.75, cz = z0 + 1.15;
                addBox(s, {cx, 0.42, cz}, {cx + 0.45, 0.46, cz + 0.45}, chairM);
                addBox(s, {cx, 0.46, cz + 0.41}, {cx + 0.45, 0.95, cz + 0.45}, chairM, 4);
                for (int k = 0; k < 4; ++k) {
                    double lx = cx + ((k & 1) ? 0.39 : 0.02), lz = cz + ((k & 2) ? 0.39 : 0.02);
                    addBox(s, {lx, 0.0, lz}, {lx + 0.04, 0.42, lz + 0.04}, metalM, 4 | 8);
                }
            }
            // Bookcase against the +x wall: two sides, five boards, 4 books on
            // each of the three middle boards.
            {
                double bx0 = x0 + S - 0.35, bx1 = x0 + S, bz0 = z0 + 2.8, bz1 = z0 + 3.8;
                addBox(s, {bx0, 0.0, bz0}, {bx1, 1.9, bz0 + 0.03}, shelfM, 2 | 4);
                addBox(s, {bx0, 0.0, bz1 - 0.03}, {bx1, 1.9, bz1}, shelfM, 2 | 4);
                for (int k = 0; k < 5; ++k) {
                    double y = 0.05 + k * 0.45;
                    if (y + 0.03 > 1.9) y = 1.87;
                    addBox(s, {bx0, y, bz0 + 0.03}, {bx1, y + 0.03, bz1 - 0.03}, shelfM, 2 | 16 | 32);
                    if (k >= 1 && k <= 3)
                        for (int b = 0; b < 4; ++b) {
                            double z = bz0 + 0.08 + b * 0.2, hgt = 0.25 + 0.03 * ((b + k) % 3);
                            addBox(s, {bx0 + 0.05, y + 0.03, z}, {bx1 - 0.05, y + 0.03 + hgt, z + 0.05},
                                   bookM[(b + k) % 3], 4);
                        }
                }
            }
        }
    s.camera = pinhole(Vec3(3.6, 1.6, 3.6), Vec3(0.5, 1.0, 0.5), Vec3(0, 1, 0), 60.0);
    finish(s, tess > 0 ? fmt::format("office:{}:{}", n, tess) : fmt::format("office:{}", n));
    return s;
}

uint64_t officePatches(int n, int tess) {
    // office:N: 225 patches per room (floor 16, ceiling 16, walls 4 x 15 --
    // a doorway removes 2 wall cells from each of its two walls and adds 4
    // doorway quads --, luminaire 1, desk 22, chair 27, bookcase 23, books
    // 60). office:N:T: the desk and chair boxes (49 quads) become the meshes
    // of addTessellatedFurniture:
    //   desk top        grid 12t x 1 x 7t    336 t^2 +  76 t
    //   4 desk legs     8t bands, s = 8t     4 (128 t^2 + 16 t)
    //   3 cups          4t + 2 rings         3 (64 t^2 + 32 t)
    //   chair seat      grid 6t x 1 x 6t     144 t^2 +  48 t
    //   chair back      grid 8t x 6t x 1     192 t^2 +  56 t
    //   4 chair legs    4t bands             4 (64 t^2 + 16 t)
    //   pot             4t + 3 rings          64 t^2 +  48 t
    //   3 foliage balls 4t - 1 rings         3 (64 t^2 - 16 t)
    //   sum                                 1888 t^2 + 404 t
    const uint64_t rooms = uint64_t(n) * uint64_t(n), t = uint64_t(tess);
    if (tess == 0) return 225 * rooms;
    return rooms * (225 - 49 + 1888 * t * t + 404 * t);
}

Scene makeBuiltin(const std::string& spec) {
    std::vector<std::string> parts = split(spec, ':');
    const std::string& head = parts[0];
    SourceLocation where{spec, 0, 0};
    if (head == "cornell") {
        if (parts.size() != 1) throwInputError(where, "'cornell' takes no arguments; {}", kUsage);
        return makeCornellBox();
    }
    if (head == "furnace") {
        if (parts.size() > 4) throwInputError(where, "too many arguments; {}", kUsage);
        double rho = parts.size() > 1 ? parseArg(spec, parts[1], "rho") : 0.5;
        double e = parts.size() > 2 ? parseArg(spec, parts[2], "E") : 1.0;
        double side = parts.size() > 3 ? parsePositive(spec, parts[3], "side") : 1.0;
        Scene s = makeFurnace(rho, e, side);
        s.name = spec;
        return s;
    }
    if (head == "plates" && parts.size() > 1 && parts[1] == "occluded") {
        if (parts.size() != 7) throwInputError(where, "malformed plates:occluded scene; {}", kUsage);
        double w = parsePositive(spec, parts[2], "W");
        double h = parsePositive(spec, parts[3], "H");
        double d = parsePositive(spec, parts[4], "D");
        double side = parsePositive(spec, parts[5], "S");
        double z = parsePositive(spec, parts[6], "Z");
        if (!(z < d))
            throwInputError(where, "built-in scene '{}': occluder height Z must be < D, got Z = {}, D = {}",
                            spec, z, d);
        Scene s = makeOccludedPlates(w, h, d, side, z);
        s.name = spec;
        return s;
    }
    if (head == "plates") {
        if (parts.size() != 5 || (parts[1] != "parallel" && parts[1] != "perpendicular"))
            throwInputError(where, "malformed plates scene; {}", kUsage);
        double a = parsePositive(spec, parts[2], "W");
        double b = parsePositive(spec, parts[3], "H");
        double c = parsePositive(spec, parts[4], parts[1] == "parallel" ? "D" : "L");
        Scene s = parts[1] == "parallel" ? makeParallelPlates(a, b, c) : makePerpendicularPlates(a, b, c);
        s.name = spec;
        return s;
    }
    if (head == "office") {
        if (parts.size() != 2 && parts.size() != 3)
            throwInputError(where, "office needs a grid size N and optionally a tessellation T; {}",
                            kUsage);
        double v = parseArg(spec, parts[1], "N");
        if (!(v >= 1 && v <= 64 && std::floor(v) == v))
            throwInputError(where, "office:N needs an integer N in [1, 64], got '{}'", parts[1]);
        int tess = 0;
        if (parts.size() == 3) {
            double t = parseArg(spec, parts[2], "T");
            if (!(t >= 1 && t <= kOfficeMaxTessellation && std::floor(t) == t))
                throwInputError(where,
                                "office:N:T needs an integer tessellation T in [1, {}], got '{}'",
                                kOfficeMaxTessellation, parts[2]);
            tess = int(t);
            uint64_t count = officePatches(int(v), tess);
            if (count > kOfficeMaxPatches)
                throwInputError(where,
                                "office:{}:{} would have {} patches, more than the limit of {} "
                                "(about 200 bytes each before solving); use a smaller N or T",
                                int(v), tess, count, kOfficeMaxPatches);
        }
        Scene s = makeOffice(int(v), tess);
        s.name = spec;
        return s;
    }
    throwInputError(where, "unknown built-in scene '{}'; {}", head, kUsage);
}

}  // namespace hrad::scene
