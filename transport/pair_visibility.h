// The visibility fraction of one pair of elements, for FormFactorEngine
// (transport/formfactor.h): a kernel-weighted fraction of unblocked segments
// between area-uniform points of the two (vis_sampling = area), or of
// segments along directions over each element's solid angle, weighted by
// multiple importance sampling (solid_angle, the default; Arvo 1995,
// Veach & Guibas 1995). Internal to transport/.
#pragma once

#include <cstdint>

#include "transport/formfactor.h"
#include "transport/visibility.h"

namespace hrad::transport::detail {

constexpr int kMaxVisRays = 1024;

/// Point-to-point kernel cos_r cos_s / (pi r^2) (0 when either cosine <= 0).
inline double kernel(const Vec3& x, const Vec3& nx, const Vec3& y, const Vec3& ny) {
    Vec3 d = y - x;
    double r2 = glm::dot(d, d);
    double cx = glm::dot(nx, d), cy = -glm::dot(ny, d);
    if (cx <= 0.0 || cy <= 0.0 || r2 <= 0.0) return 0.0;
    return cx * cy / (kPi * r2 * r2);
}

/// Visibility between stratified samples on two elements.
struct VisEstimate {
    double fraction = 1.0;  ///< kernel-weighted unblocked fraction
    bool partial = false;   ///< some facing segments blocked, some not
    uint32_t cast = 0;
};

/// The visibility of r and s with `rays` segments (the same segments for (r,
/// s) and (s, r)); a non-zero salt draws another, independent set.
VisEstimate pairVisibility(const Visibility& vis, const scene::Scene& sc, const ElementRef& r,
                           const ElementRef& s, int rays, VisSampling sampling, uint64_t salt = 0);

}  // namespace hrad::transport::detail
