// Sampling shared by the Monte Carlo reference (reference/montecarlo.h) and
// the residual error estimate (reference/error_estimate.h): uniform points on
// patches, emitters chosen by power, and next-event estimation of the direct
// light with multiple importance sampling (Veach 1997, sec. 9.2, balance
// heuristic: an emitter point and a cosine-distributed hit both score
// E_e a / (a + b), a = A_e cos t_x cos t_y, b = pi p_e r^2).
#pragma once

#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "core/types.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::reference {

/// Running mean and sum of squared deviations (Welford 1962), per channel.
struct Welford {
    uint64_t n = 0;
    RGB mean{0.0}, m2{0.0};
    void add(const RGB& x) {
        ++n;
        RGB d = x - mean;
        mean += d / double(n);
        m2 += d * (x - mean);
    }
    /// Standard error of the mean, sqrt(s^2 / n) with the unbiased s^2.
    RGB stdError() const;
};

/// Uniform point by area on a planar convex polygon of 3 or 4 corners (a
/// quad is the fan (c0,c1,c2), (c0,c2,c3), picked in proportion to area;
/// a triangle by the square-root mapping, Osada et al. 2002).
struct PolygonSampler {
    Vec3 c[4];
    int n = 3;
    double firstFraction = 1.0;  ///< area of (c0,c1,c2) / total

    PolygonSampler() = default;
    PolygonSampler(const Vec3* corners, int count);
    Vec3 sample(Pcg32& rng) const;
};
PolygonSampler patchSampler(const scene::Patch& p);

/// Emitters chosen in proportion to their power luminance(E) * A.
struct EmitterTable {
    std::vector<uint32_t> patch;
    std::vector<double> cdf;  ///< cdf[i] = P(choose one of 0..i); last is 1
    std::vector<PolygonSampler> shape;
    std::vector<double> probOfPatch;  ///< selection probability per scene patch (0: not an emitter)

    explicit EmitterTable(const scene::Scene& s);
    bool empty() const { return patch.empty(); }
    size_t pick(double u) const;
};

/// Cosine-weighted direction about n, pdf cos t / pi (core/sampling.h).
Vec3 sampleCosine(const Vec3& n, Pcg32& rng);

/// Direct light at x (front of `patch`, normal n) by next-event estimation:
/// from the area emitters `em` (one emitter point, MIS-weighted when `mis`)
/// plus every delta light of the scene (point, spot, sun: one shadow ray
/// each, exact; scene/lights/light.h). Environments are not drawn here: a
/// cosine ray that escapes picks up pi L(w), which for a constant sky is
/// already the ideal density (pdf cos t / pi is proportional to the
/// unoccluded integrand); an importance-sampled map is drawn beside it by
/// the walk (reference/montecarlo.h, transport::sampledEnvironmentDirect).
/// `rays` counts the shadow rays.
RGB directLight(const scene::Scene& s, const transport::Visibility& vis, const EmitterTable& em,
                const Vec3& x, const Vec3& n, uint32_t patch, bool mis, Pcg32& rng,
                uint64_t& rays);

/// Only the area emitters' part of directLight().
RGB directArea(const scene::Scene& s, const transport::Visibility& vis, const EmitterTable& em,
               const Vec3& x, const Vec3& n, uint32_t patch, bool mis, Pcg32& rng,
               uint64_t& rays);
/// Only the delta lights' part of directLight().
RGB deltaLights(const scene::Scene& s, const transport::Visibility& vis, const Vec3& x,
                const Vec3& n, uint32_t patch, uint64_t& rays);

/// The MIS weight's share of an emitter q hit at y by a cosine ray from x
/// (normal n, direction dir): q.emission * a / (a + b) (header).
RGB misEmission(const scene::Patch& q, double probOfQ, const Vec3& x, const Vec3& n,
                const Vec3& y, const Vec3& dir);

}  // namespace hrad::reference
