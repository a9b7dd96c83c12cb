// Parametric sub-elements of root patches, shared by every solver.
//
// An element is a node of a root patch's quadtree: quads split into four
// quads at the edge midpoints and the centre, triangles into four triangles at
// the edge midpoints (the middle child is inverted). An element is named by a
// key: a leading 1 bit followed by two bits per level giving the child index
// (so the root is key 1, its children 4..7). Keys make containment a prefix
// test, which lets the error metric average any field exactly over any
// reference region.
//
// The parametric domain of a key is (u0, v0, h):
//   quad:      [u0, u0+h] x [v0, v0+h] in the bilinear (u,v) of Patch::point
//   triangle:  corners (u0,v0), (u0+h,v0), (u0,v0+h) in the barycentric (u,v)
//              of Patch::point; h < 0 for inverted (middle) triangles.
// u0, v0, h are dyadic rationals, exact in float to 24 levels and in double to
// 52, so parametric positions carry no round-off.
//
// Children of a quad domain (u0,v0,h), with k = h/2:
//   0: (u0, v0)   1: (u0+k, v0)   2: (u0+k, v0+k)   3: (u0, v0+k)
// Children of a triangle domain (u0,v0,h), with k = h/2:
//   0: (u0, v0, k)   1: (u0+k, v0, k)   2: (u0, v0+k, k)   3: (u0+k, v0+k, -k)
#pragma once

#include <array>
#include <cstdint>

#include "scene/scene.h"

namespace hrad::scene {

using ElementKey = uint64_t;
inline constexpr ElementKey kRootKey = 1;
inline constexpr int kMaxLevel = 30;

inline int keyLevel(ElementKey k) { return (63 - __builtin_clzll(k)) / 2; }
/// True for the key of an element of a quadtree (for keys read from files):
/// non-zero, its leading 1 bit at an even position, at most kMaxLevel levels.
inline bool isValidKey(ElementKey k) {
    return k != 0 && ((63 - __builtin_clzll(k)) & 1) == 0 && keyLevel(k) <= kMaxLevel;
}
inline ElementKey childKey(ElementKey k, int child) { return (k << 2) | uint64_t(child); }
inline ElementKey parentKey(ElementKey k) { return k >> 2; }
inline int childIndexOf(ElementKey k) { return int(k & 3u); }
/// True when `inner` is `outer` or one of its descendants.
inline bool keyContains(ElementKey outer, ElementKey inner) {
    int lo = keyLevel(outer), li = keyLevel(inner);
    return li >= lo && (inner >> (2 * (li - lo))) == outer;
}
/// Child index at `level`+1 on the path from the root to `k` (level < keyLevel(k)).
inline int keyChildAt(ElementKey k, int level) {
    return int((k >> (2 * (keyLevel(k) - level - 1))) & 3u);
}

struct Domain {
    double u0 = 0.0, v0 = 0.0, h = 1.0;
};

Domain childDomain(PatchKind kind, const Domain& d, int child);
Domain keyDomain(PatchKind kind, ElementKey key);

/// Which child of domain d contains parametric point (u,v) (assumed inside d).
int childContaining(PatchKind kind, const Domain& d, double u, double v);
/// Key of the level-`level` element containing (u,v).
ElementKey keyAt(PatchKind kind, double u, double v, int level);

/// Parametric (u,v) of local coordinates (a,b) of a domain: for quads
/// (a,b) in [0,1]^2; for triangles barycentric-like a,b >= 0, a+b <= 1.
inline Vec2 domainParam(const Domain& d, double a, double b) {
    return {d.u0 + a * d.h, d.v0 + b * d.h};
}

/// 3D corners of an element; returns the number of corners (3 or 4), counter-
/// clockwise seen from the patch front (inverted triangles are reordered).
int elementCorners(const Patch& p, const Domain& d, Vec3 out[4]);
/// Local coordinates (a, b) of corner i in elementCorners order: quads
/// (0,0) (1,0) (1,1) (0,1), triangles (0,0) (1,0) (0,1).
inline Vec2 cornerLocal(PatchKind kind, int i) {
    static constexpr double q[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    static constexpr double t[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    return kind == PatchKind::Quad ? Vec2(q[i][0], q[i][1]) : Vec2(t[i][0], t[i][1]);
}
/// Exact area of the element (planar polygon area of its corners).
double elementArea(const Patch& p, const Domain& d);
/// Area centroid of the element.
Vec3 elementCentroid(const Patch& p, const Domain& d);
/// Point at local coordinates (a,b) of the element (see domainParam).
inline Vec3 elementPoint(const Patch& p, const Domain& d, double a, double b) {
    Vec2 uv = domainParam(d, a, b);
    return p.point(uv.x, uv.y);
}
/// A point of the element from (a, b) in [0, 1)^2, uniform by area on a
/// triangle's domain ((a, b) folded into a + b <= 1) and by the local map on
/// a quad's.
inline Vec3 elementSamplePoint(const Patch& p, const Domain& d, double a, double b) {
    if (p.kind == PatchKind::Triangle && a + b > 1) {
        a = 1 - a;
        b = 1 - b;
    }
    return elementPoint(p, d, a, b);
}
/// Jacobian |dP/da x dP/db| at local (a,b): the area density of the local map.
double elementJacobian(const Patch& p, const Domain& d, double a, double b);

/// Inverse of Patch::point for a point on (or projected onto) the patch plane.
Vec2 patchInverse(const Patch& p, const Vec3& x);

/// The nearest parameters inside a patch's domain: [0,1]^2 for quads, the
/// triangle a, b >= 0, a + b <= 1 (scaled back along the ray from 0) otherwise.
Vec2 clampToPatchDomain(PatchKind kind, Vec2 uv);

/// Area of a planar polygon given its corners in order (Newell's method).
double polygonArea(const Vec3* pts, int n);

}  // namespace hrad::scene
