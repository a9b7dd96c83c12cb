// Hand-built closed box scenes for the reference and render tests (no loaders).
#pragma once

#include "scene/scene.h"

namespace hrad::test {

/// Adds the six inward-facing faces of the axis-aligned box [lo, hi] with
/// materials m[0..5] (-x, +x, -y, +y, -z, +z). Returns the patch index of
/// the first face.
inline uint32_t addInwardBox(scene::Scene& s, const Vec3& lo, const Vec3& hi, const uint32_t m[6]) {
    uint32_t first = uint32_t(s.patches.size());
    Vec3 a(lo.x, lo.y, lo.z), b(hi.x, lo.y, lo.z), c(hi.x, hi.y, lo.z), d(lo.x, hi.y, lo.z);
    Vec3 e(lo.x, lo.y, hi.z), f(hi.x, lo.y, hi.z), g(hi.x, hi.y, hi.z), h(lo.x, hi.y, hi.z);
    // Counter-clockwise seen from inside (normal pointing into the box).
    s.addQuad(a, d, h, e, m[0]);  // x = lo, normal +x
    s.addQuad(b, f, g, c, m[1]);  // x = hi, normal -x
    s.addQuad(a, e, f, b, m[2]);  // y = lo, normal +y
    s.addQuad(d, c, g, h, m[3]);  // y = hi, normal -y
    s.addQuad(a, b, c, d, m[4]);  // z = lo, normal +z
    s.addQuad(e, h, g, f, m[5]);  // z = hi, normal -z
    return first;
}

/// Furnace: unit cube, every wall E = 1, rho = 0.5; exact B = E/(1-rho) = 2.
inline scene::Scene furnaceBox() {
    scene::Scene s;
    s.name = "test-furnace";
    uint32_t m = s.addMaterial({"wall", RGB(0.5), RGB(1.0)});
    uint32_t ms[6] = {m, m, m, m, m, m};
    addInwardBox(s, Vec3(0.0), Vec3(1.0), ms);
    return s;
}

/// A small Cornell-like closed box: coloured walls, a ceiling of 3x3 tiles
/// whose centre tile is the emitter (so no back face of an emitter faces the
/// room), and a grey blocker standing on the floor (an open-bottom box whose
/// footprint is aligned with the level-2 element grid, so no floor element is
/// partly under it). Every ray leaving the front of a lit element hits the
/// front of another patch: the scene is closed (sum_j F_ij = 1).
inline scene::Scene blockerBox() {
    scene::Scene s;
    s.name = "test-blocker-box";
    uint32_t red = s.addMaterial({"red", RGB(0.6, 0.1, 0.1), RGB(0.0)});
    uint32_t green = s.addMaterial({"green", RGB(0.1, 0.6, 0.1), RGB(0.0)});
    uint32_t white = s.addMaterial({"white", RGB(0.7), RGB(0.0)});
    uint32_t grey = s.addMaterial({"grey", RGB(0.4, 0.45, 0.5), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.2), RGB(10.0, 9.0, 7.0)});
    Vec3 lo(0.0), hi(1.0);
    Vec3 a(lo.x, lo.y, lo.z), b(hi.x, lo.y, lo.z), c(hi.x, hi.y, lo.z), d(lo.x, hi.y, lo.z);
    Vec3 e(lo.x, lo.y, hi.z), f(hi.x, lo.y, hi.z), g(hi.x, hi.y, hi.z), h(lo.x, hi.y, hi.z);
    s.addQuad(a, d, h, e, red);    // x = 0, normal +x
    s.addQuad(b, f, g, c, green);  // x = 1, normal -x
    s.addQuad(a, e, f, b, white);  // floor, normal +y
    s.addQuad(a, b, c, d, grey);   // back z = 0, normal +z
    s.addQuad(e, h, g, f, white);  // front z = 1, normal -z
    // Ceiling y = 1, normal -y, as 3x3 tiles; the centre one emits.
    const double t[4] = {0.0, 0.35, 0.65, 1.0};
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            uint32_t m = (i == 1 && k == 1) ? light : white;
            s.addQuad(Vec3(t[i], 1, t[k]), Vec3(t[i + 1], 1, t[k]), Vec3(t[i + 1], 1, t[k + 1]),
                      Vec3(t[i], 1, t[k + 1]), m);
        }
    // Blocker [0.25,0.5] x [0,0.5] x [0.25,0.5], outward faces, no bottom.
    Vec3 A(0.25, 0, 0.25), B(0.5, 0, 0.25), C(0.5, 0.5, 0.25), D(0.25, 0.5, 0.25);
    Vec3 E(0.25, 0, 0.5), F(0.5, 0, 0.5), G(0.5, 0.5, 0.5), H(0.25, 0.5, 0.5);
    s.addQuad(A, E, H, D, grey);  // -x
    s.addQuad(B, C, G, F, grey);  // +x
    s.addQuad(D, H, G, C, grey);  // top +y
    s.addQuad(A, D, C, B, grey);  // -z
    s.addQuad(E, F, G, H, grey);  // +z
    return s;
}

}  // namespace hrad::test
