// Directions for rays leaving a surface: shared by the Monte Carlo reference
// (reference/montecarlo.cpp), the final gather (render/final_gather.cpp) and
// the reachability pass (transport/reachability.cpp).
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

}  // namespace hrad
