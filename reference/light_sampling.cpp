// Sampling shared by the Monte Carlo reference and the error estimate; see
// light_sampling.h.
#include "reference/light_sampling.h"

#include <algorithm>
#include <cmath>

#include "core/sampling.h"
#include "transport/light_irradiance.h"

namespace hrad::reference {

namespace {
constexpr double kPi = 3.14159265358979323846;

Vec3 sampleTriangle(const Vec3& a, const Vec3& b, const Vec3& c, double u1, double u2) {
    double su = std::sqrt(u1);
    double b0 = 1.0 - su, b1 = u2 * su;
    return b0 * a + b1 * b + (1.0 - b0 - b1) * c;
}
}  // namespace

RGB Welford::stdError() const {
    if (n < 2) return RGB(0.0);
    RGB var = glm::max(m2, RGB(0.0)) / double(n - 1);
    return glm::sqrt(var / double(n));
}

PolygonSampler::PolygonSampler(const Vec3* corners, int count) : n(count) {
    for (int i = 0; i < count; ++i) c[i] = corners[i];
    if (n == 4) {
        double a0 = 0.5 * glm::length(glm::cross(c[1] - c[0], c[2] - c[0]));
        double a1 = 0.5 * glm::length(glm::cross(c[2] - c[0], c[3] - c[0]));
        firstFraction = a0 + a1 > 0 ? a0 / (a0 + a1) : 1.0;
    }
}

Vec3 PolygonSampler::sample(Pcg32& rng) const {
    double s = rng.nextDouble(), u1 = rng.nextDouble(), u2 = rng.nextDouble();
    if (n == 3 || s < firstFraction) return sampleTriangle(c[0], c[1], c[2], u1, u2);
    return sampleTriangle(c[0], c[2], c[3], u1, u2);
}

PolygonSampler patchSampler(const scene::Patch& p) {
    return PolygonSampler(p.v.data(), p.numVertices());
}

EmitterTable::EmitterTable(const scene::Scene& s) : probOfPatch(s.patches.size(), 0.0) {
    std::vector<double> w;
    for (uint32_t i = 0; i < s.patches.size(); ++i) {
        const scene::Patch& p = s.patches[i];
        double power = luminance(p.emission) * p.area;
        if (p.isEmitter() && power > 0) {
            patch.push_back(i);
            w.push_back(power);
            shape.push_back(patchSampler(p));
        }
    }
    double total = 0;
    for (double x : w) total += x;
    double acc = 0;
    for (size_t k = 0; k < w.size(); ++k) {
        acc += w[k];
        cdf.push_back(acc / total);
        probOfPatch[patch[k]] = w[k] / total;
    }
    if (!cdf.empty()) cdf.back() = 1.0;
}

size_t EmitterTable::pick(double u) const {
    size_t k = size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
    return std::min(k, cdf.size() - 1);
}

Vec3 sampleCosine(const Vec3& n, Pcg32& rng) {
    double u1 = rng.nextDouble(), u2 = rng.nextDouble();
    return cosineDirection(n, u1, u2);
}

RGB deltaLights(const scene::Scene& s, const transport::Visibility& vis, const Vec3& x,
                const Vec3& n, uint32_t patch, uint64_t& rays) {
    RGB sum(0.0);
    for (const auto& l : s.lights)
        if (l->isDelta()) sum += transport::lightIrradiance(*l, vis, x, n, patch, 1, 0, rays);
    return sum;
}

RGB directLight(const scene::Scene& s, const transport::Visibility& vis, const EmitterTable& em,
                const Vec3& x, const Vec3& n, uint32_t patch, bool mis, Pcg32& rng,
                uint64_t& rays) {
    const RGB lights = s.lights.empty() ? RGB(0.0) : deltaLights(s, vis, x, n, patch, rays);
    return lights + directArea(s, vis, em, x, n, patch, mis, rng, rays);
}

RGB directArea(const scene::Scene& s, const transport::Visibility& vis, const EmitterTable& em,
               const Vec3& x, const Vec3& n, uint32_t patch, bool mis, Pcg32& rng,
               uint64_t& rays) {
    if (em.empty()) return RGB(0.0);
    size_t k = em.pick(rng.nextDouble());
    Vec3 y = em.shape[k].sample(rng);  // drawn even when unused: fixed stream use
    uint32_t e = em.patch[k];
    if (e == patch) return RGB(0.0);  // planar: F = 0
    const scene::Patch& ep = s.patches[e];
    Vec3 d = y - x;
    double r2 = glm::dot(d, d);
    if (!(r2 > 0)) return RGB(0.0);
    Vec3 w = d / std::sqrt(r2);
    double cosX = glm::dot(n, w), cosY = -glm::dot(ep.normal, w);
    if (cosX <= 0 || cosY <= 0) return RGB(0.0);
    ++rays;
    if (vis.occluded(transport::Segment{x, y, patch, e})) return RGB(0.0);
    double a = ep.area * cosX * cosY, b = kPi * em.probOfPatch[e] * r2;
    return ep.emission * (mis ? a / (a + b) : a / b);
}

RGB misEmission(const scene::Patch& q, double probOfQ, const Vec3& x, const Vec3& n,
                const Vec3& y, const Vec3& dir) {
    double cosY = -glm::dot(dir, q.normal);
    Vec3 d = y - x;
    double r2 = glm::dot(d, d);
    double cosX = glm::dot(dir, n);
    double a = q.area * cosX * cosY, b = kPi * probOfQ * r2;
    return a > 0 ? q.emission * (a / (a + b)) : RGB(0.0);
}

}  // namespace hrad::reference
