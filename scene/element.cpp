#include "scene/element.h"

#include <cmath>

#include "core/error.h"

namespace hrad::scene {

Vec3 Patch::point(double u, double v) const {
    if (kind == PatchKind::Quad)
        return (1 - u) * (1 - v) * this->v[0] + u * (1 - v) * this->v[1] + u * v * this->v[2] +
               (1 - u) * v * this->v[3];
    return this->v[0] + u * (this->v[1] - this->v[0]) + v * (this->v[2] - this->v[0]);
}

Vec3 Patch::centroid() const { return elementCentroid(*this, Domain{}); }

Domain childDomain(PatchKind kind, const Domain& d, int child) {
    double k = 0.5 * d.h;
    if (kind == PatchKind::Quad) {
        switch (child) {
            case 0: return {d.u0, d.v0, k};
            case 1: return {d.u0 + k, d.v0, k};
            case 2: return {d.u0 + k, d.v0 + k, k};
            default: return {d.u0, d.v0 + k, k};
        }
    }
    switch (child) {
        case 0: return {d.u0, d.v0, k};
        case 1: return {d.u0 + k, d.v0, k};
        case 2: return {d.u0, d.v0 + k, k};
        default: return {d.u0 + k, d.v0 + k, -k};
    }
}

Domain keyDomain(PatchKind kind, ElementKey key) {
    Domain d;
    int level = keyLevel(key);
    for (int l = 0; l < level; ++l) d = childDomain(kind, d, keyChildAt(key, l));
    return d;
}

int childContaining(PatchKind kind, const Domain& d, double u, double v) {
    double a = (u - d.u0) / d.h, b = (v - d.v0) / d.h;
    if (kind == PatchKind::Quad) return a < 0.5 ? (b < 0.5 ? 0 : 3) : (b < 0.5 ? 1 : 2);
    if (a >= 0.5) return 1;
    if (b >= 0.5) return 2;
    if (a + b <= 0.5) return 0;
    return 3;
}

ElementKey keyAt(PatchKind kind, double u, double v, int level) {
    ElementKey k = kRootKey;
    Domain d;
    for (int l = 0; l < level; ++l) {
        int c = childContaining(kind, d, u, v);
        k = childKey(k, c);
        d = childDomain(kind, d, c);
    }
    return k;
}

int elementCorners(const Patch& p, const Domain& d, Vec3 out[4]) {
    if (p.kind == PatchKind::Quad) {
        out[0] = p.point(d.u0, d.v0);
        out[1] = p.point(d.u0 + d.h, d.v0);
        out[2] = p.point(d.u0 + d.h, d.v0 + d.h);
        out[3] = p.point(d.u0, d.v0 + d.h);
        return 4;
    }
    // A point reflection of the parametric triangle (h < 0) is a rotation by
    // pi in the plane, so corner order keeps the patch's orientation.
    out[0] = p.point(d.u0, d.v0);
    out[1] = p.point(d.u0 + d.h, d.v0);
    out[2] = p.point(d.u0, d.v0 + d.h);
    return 3;
}

double polygonArea(const Vec3* pts, int n) {
    // Newell's method: half the length of the sum of edge cross products.
    Vec3 s(0.0);
    for (int i = 0; i < n; ++i) s += glm::cross(pts[i], pts[(i + 1) % n]);
    return 0.5 * glm::length(s);
}

double elementArea(const Patch& p, const Domain& d) {
    Vec3 c[4];
    int n = elementCorners(p, d, c);
    if (n == 3) return 0.5 * glm::length(glm::cross(c[1] - c[0], c[2] - c[0]));
    // Planar quad: half the cross product of the diagonals.
    return 0.5 * glm::length(glm::cross(c[2] - c[0], c[3] - c[1]));
}

Vec3 elementCentroid(const Patch& p, const Domain& d) {
    Vec3 c[4];
    int n = elementCorners(p, d, c);
    if (n == 3) return (c[0] + c[1] + c[2]) / 3.0;
    // Area-weighted centroid of the two triangles (c0,c1,c2) and (c0,c2,c3).
    double a1 = glm::length(glm::cross(c[1] - c[0], c[2] - c[0]));
    double a2 = glm::length(glm::cross(c[2] - c[0], c[3] - c[0]));
    if (a1 + a2 <= 0) return 0.25 * (c[0] + c[1] + c[2] + c[3]);
    return (a1 * (c[0] + c[1] + c[2]) + a2 * (c[0] + c[2] + c[3])) / (3.0 * (a1 + a2));
}

double elementJacobian(const Patch& p, const Domain& d, double a, double b) {
    double h2 = d.h * d.h;
    if (p.kind == PatchKind::Triangle)
        return glm::length(glm::cross(p.v[1] - p.v[0], p.v[2] - p.v[0])) * h2;
    Vec2 uv = domainParam(d, a, b);
    Vec3 du = (1 - uv.y) * (p.v[1] - p.v[0]) + uv.y * (p.v[2] - p.v[3]);
    Vec3 dv = (1 - uv.x) * (p.v[3] - p.v[0]) + uv.x * (p.v[2] - p.v[1]);
    return glm::length(glm::cross(du, dv)) * h2;
}

Vec2 clampToPatchDomain(PatchKind kind, Vec2 uv) {
    if (kind == PatchKind::Quad) return glm::clamp(uv, Vec2(0.0), Vec2(1.0));
    uv = glm::max(uv, Vec2(0.0));
    double s = uv.x + uv.y;
    if (s > 1) uv /= s;
    return uv;
}

Vec2 patchInverse(const Patch& p, const Vec3& x) {
    if (p.kind == PatchKind::Triangle) {
        // Barycentric coordinates by least squares in the plane.
        Vec3 e1 = p.v[1] - p.v[0], e2 = p.v[2] - p.v[0], w = x - p.v[0];
        double d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
        double w1 = glm::dot(w, e1), w2 = glm::dot(w, e2);
        double det = d11 * d22 - d12 * d12;
        if (det <= 0) return {0.0, 0.0};
        return {(d22 * w1 - d12 * w2) / det, (d11 * w2 - d12 * w1) / det};
    }
    // Bilinear inversion by Newton's method on the plane-projected residual;
    // convex planar quads have an injective map, so this converges from the
    // centre in a few steps.
    Vec2 uv(0.5, 0.5);
    for (int it = 0; it < 20; ++it) {
        Vec3 r = p.point(uv.x, uv.y) - x;
        Vec3 du = (1 - uv.y) * (p.v[1] - p.v[0]) + uv.y * (p.v[2] - p.v[3]);
        Vec3 dv = (1 - uv.x) * (p.v[3] - p.v[0]) + uv.x * (p.v[2] - p.v[1]);
        double a = glm::dot(du, du), b = glm::dot(du, dv), c = glm::dot(dv, dv);
        double r1 = glm::dot(r, du), r2 = glm::dot(r, dv);
        double det = a * c - b * b;
        if (det <= 0) break;
        Vec2 step((c * r1 - b * r2) / det, (a * r2 - b * r1) / det);
        uv -= step;
        if (std::fabs(step.x) + std::fabs(step.y) < 1e-14) break;
    }
    return uv;
}

}  // namespace hrad::scene
