// Directions for rays leaving a surface: shared by the Monte Carlo reference
// (reference/montecarlo.cpp), the final gather (render/final_gather.cpp),
// the reachability pass (transport/reachability.cpp) and the stand-in
// transfers (cluster/link.cpp, which also draws directions towards a sender
// polygon by solid angle).
#pragma once

#include <algorithm>
#include <cmath>

#include "core/types.h"

namespace hrad {

/// Orthonormal basis (t, b) around the unit vector n (Duff et al. 2017,
/// "Building an Orthonormal Basis, Revisited", JCGT 6(1)).
inline void orthonormalBasis(const Vec3& n, Vec3& t, Vec3& b) {
    double sign = std::copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z);
    double c = n.x * n.y * a;
    t = Vec3(1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x);
    b = Vec3(c, sign + n.y * n.y * a, -n.y);
}

/// Cosine-weighted unit direction about n (Malley's method: a uniform point
/// on the unit disc, radius sqrt(u1) and angle 2 pi u2, lifted onto the
/// hemisphere), pdf cos(theta) / pi.
inline Vec3 cosineDirection(const Vec3& n, double u1, double u2) {
    double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
    double z = std::sqrt(std::max(0.0, 1.0 - u1));
    Vec3 t, b;
    orthonormalBasis(n, t, b);
    return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + z * n);
}

/// Solid angle of the spherical triangle of the unit vectors a, b, c
/// (Van Oosterom & Strackee 1983: tan(Omega / 2) = |a . (b x c)| /
/// (1 + a.b + b.c + c.a)); stable for small triangles, where the angle
/// excess alpha + beta + gamma - pi cancels.
inline double sphericalTriangleArea(const Vec3& a, const Vec3& b, const Vec3& c) {
    const double num = std::fabs(glm::dot(a, glm::cross(b, c)));
    const double den = 1.0 + glm::dot(a, b) + glm::dot(b, c) + glm::dot(c, a);
    return 2.0 * std::atan2(num, den);  // num >= 0: in [0, 2 pi]
}

/// A direction uniformly distributed over the solid angle of the spherical
/// triangle of the unit vectors a, b, c, whose solid angle is `area`
/// (sphericalTriangleArea), from (u1, u2) in [0, 1)^2: Arvo 1995,
/// "Stratified Sampling of Spherical Triangles" (SIGGRAPH), Figure 2.
/// The first variable sets the sub-triangle a, b, c' of solid angle
/// u1 * area, the second the point on the arc from b to c'.
inline Vec3 sphericalTriangleDirection(const Vec3& a, const Vec3& b, const Vec3& c, double area,
                                       double u1, double u2) {
    // alpha, the angle at a, between the great circles a-b and a-c.
    auto tangentAt = [](const Vec3& p, const Vec3& q) {
        const Vec3 t = q - glm::dot(q, p) * p;
        const double l = glm::length(t);
        return l > 0.0 ? t / l : Vec3(0.0);
    };
    const Vec3 tb = tangentAt(a, b), tc = tangentAt(a, c);
    const double cosAlpha = std::clamp(glm::dot(tb, tc), -1.0, 1.0);
    const double alpha = std::acos(cosAlpha), sinAlpha = std::sin(alpha);
    const double cosC = std::clamp(glm::dot(a, b), -1.0, 1.0);  // side c: the arc a-b
    const double areaHat = u1 * area;
    const double s = std::sin(areaHat - alpha), t = std::cos(areaHat - alpha);
    const double u = t - cosAlpha;
    const double v = s + sinAlpha * cosC;
    const double qDen = (v * s + u * t) * sinAlpha;
    double q = qDen != 0.0 ? ((v * t - u * s) * cosAlpha - v) / qDen : 1.0;
    q = std::clamp(q, -1.0, 1.0);
    // c' on the arc from a to c with cos(a, c') = q.
    const Vec3 cHat = q * a + std::sqrt(std::max(0.0, 1.0 - q * q)) * tc;
    // A point on the arc from b to c', uniform in the sub-triangle's area.
    const double z = 1.0 - u2 * (1.0 - glm::dot(cHat, b));
    const Vec3 w = tangentAt(b, cHat);
    return glm::normalize(z * b + std::sqrt(std::max(0.0, 1.0 - z * z)) * w);
}

}  // namespace hrad
