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
    "plates:perpendicular:W:H:L, plates:occluded:W:H:D:S:Z (0 < Z < D), office:N";

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
Scene makeOffice(int n) {
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
            // Desk near the -z wall: top 1.2 x 0.7 x 0.04 at 0.72 m, four legs.
            {
                double dx = x0 + 0.2, dz = z0 + 0.3;
                addBox(s, {dx, 0.72, dz}, {dx + 1.2, 0.76, dz + 0.7}, deskM);
                for (int k = 0; k < 4; ++k) {
                    double lx = dx + ((k & 1) ? 1.1 : 0.05), lz = dz + ((k & 2) ? 0.6 : 0.05);
                    addBox(s, {lx, 0.0, lz}, {lx + 0.05, 0.72, lz + 0.05}, metalM, 4 | 8);
                }
            }
            // Chair in front of the desk.
            {
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
    finish(s, fmt::format("office:{}", n));
    return s;
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
        if (parts.size() != 2) throwInputError(where, "office needs a grid size N; {}", kUsage);
        double v = parseArg(spec, parts[1], "N");
        if (!(v >= 1 && v <= 64 && std::floor(v) == v))
            throwInputError(where, "office:N needs an integer N in [1, 64], got '{}'", parts[1]);
        Scene s = makeOffice(int(v));
        s.name = spec;
        return s;
    }
    throwInputError(where, "unknown built-in scene '{}'; {}", head, kUsage);
}

}  // namespace hrad::scene
