// Irradiance from non-area lights; see light_irradiance.h.
#include "transport/light_irradiance.h"

#include <cmath>
#include <limits>

#include "core/rng.h"
#include "core/sampling.h"

namespace hrad::transport {

namespace {
constexpr double kPi = 3.14159265358979323846;

bool blocked(const Visibility& vis, const Vec3& x, const Vec3& dir, double distance,
             uint32_t patch) {
    if (std::isfinite(distance))
        return vis.occluded(Segment{x, x + distance * dir, patch, UINT32_MAX});
    return vis.intersect(x, dir, 0.0, 1e300, patch).hit;
}

/// One direction's score over pi: f / (pi p) with f = L(w) cos t and p the
/// strategies' density, V tested when `vis` is given.
RGB environmentScore(const scene::Light& l, const Visibility* vis, const Vec3& x, const Vec3& n,
                     uint32_t patch, const Vec3& w, bool mis, uint64_t& rays) {
    // Cosine directions alone: p = cos t / pi, f / (pi p) = L. With the
    // light's directions beside them, the balance heuristic (Veach 1997
    // eq. 9.4, equal counts): p = cos t / pi + pdf_light(w) for either kind.
    const double c = mis ? glm::dot(n, w) : 1.0;
    if (!(c > 0)) return RGB(0.0);
    const RGB L = l.radiance(w);
    if (!(maxComponent(L) > 0)) return RGB(0.0);
    if (vis) {
        ++rays;
        if (blocked(*vis, x, w, std::numeric_limits<double>::infinity(), patch)) return RGB(0.0);
    }
    return mis ? L * (c / (c + kPi * l.pdf(w))) : L;
}

/// k x k stratified cosine directions, plus k x k stratified draws of the
/// light's sample() when it is importanceSampled() (light_irradiance.h);
/// `vis` null: V = 1.
RGB environmentIrradiance(const scene::Light& l, const Visibility* vis, const Vec3& x,
                          const Vec3& n, uint32_t patch, int k, uint64_t seed, uint64_t& rays) {
    Pcg32 rng(seed);
    const bool mis = l.importanceSampled();
    RGB sum(0.0);
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
            const double u1 = (i + rng.nextDouble()) / k, u2 = (j + rng.nextDouble()) / k;
            sum += environmentScore(l, vis, x, n, patch, cosineDirection(n, u1, u2), mis, rays);
        }
    if (mis)
        for (int i = 0; i < k; ++i)
            for (int j = 0; j < k; ++j) {
                const double u1 = (i + rng.nextDouble()) / k, u2 = (j + rng.nextDouble()) / k;
                sum += environmentScore(l, vis, x, n, patch, l.sample(x, u1, u2).dir, mis, rays);
            }
    return (kPi / double(k * k)) * sum;
}
}  // namespace

RGB lightIrradiance(const scene::Light& l, const Visibility& vis, const Vec3& x, const Vec3& n,
                    uint32_t patch, int strata, uint64_t seed, uint64_t& rays) {
    if (!l.isDelta()) return environmentIrradiance(l, &vis, x, n, patch, strata, seed, rays);
    const scene::LightSample s = l.sample(x, 0.5, 0.5);
    const double c = glm::dot(n, s.dir);
    if (!(c > 0) || !(maxComponent(s.value) > 0)) return RGB(0.0);
    ++rays;
    if (blocked(vis, x, s.dir, s.distance, patch)) return RGB(0.0);
    return c * s.value;
}

RGB lightIrradianceUnoccluded(const scene::Light& l, const Vec3& x, const Vec3& n, int strata,
                              uint64_t seed) {
    uint64_t rays = 0;
    if (!l.isDelta()) return environmentIrradiance(l, nullptr, x, n, UINT32_MAX, strata, seed, rays);
    const scene::LightSample s = l.sample(x, 0.5, 0.5);
    const double c = glm::dot(n, s.dir);
    return c > 0 ? c * s.value : RGB(0.0);
}

RGB lightsIrradiance(const scene::Scene& s, const Visibility& vis, const Vec3& x, const Vec3& n,
                     uint32_t patch, int strata, uint64_t seed, uint64_t& rays) {
    RGB sum(0.0);
    for (size_t i = 0; i < s.lights.size(); ++i)
        sum += lightIrradiance(*s.lights[i], vis, x, n, patch, strata, hashIds(seed, i), rays);
    return sum;
}

int elementMeanPoints(const scene::Patch& p, const scene::Domain& d, int m, std::vector<Vec3>& x,
                      std::vector<double>& w) {
    x.clear();
    w.clear();
    if (p.kind == scene::PatchKind::Quad) {
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j) {
                const double a = (i + 0.5) / m, b = (j + 0.5) / m;
                x.push_back(scene::elementPoint(p, d, a, b));
                w.push_back(scene::elementJacobian(p, d, a, b));
            }
    } else {
        for (int i = 0; i < m; ++i)
            for (int j = 0; i + j < m; ++j) {  // upward sub-triangles: m(m+1)/2
                x.push_back(scene::elementPoint(p, d, (i + 1.0 / 3) / m, (j + 1.0 / 3) / m));
                w.push_back(1.0);
            }
        for (int i = 0; i + 1 < m; ++i)
            for (int j = 0; i + j + 1 < m; ++j) {  // downward: m(m-1)/2
                x.push_back(scene::elementPoint(p, d, (i + 2.0 / 3) / m, (j + 2.0 / 3) / m));
                w.push_back(1.0);
            }
    }
    double sum = 0;
    for (double v : w) sum += v;
    for (double& v : w) v /= sum;
    return int(x.size());
}

RGB elementLightsIrradiance(const scene::Scene& s, const Visibility& vis, uint32_t patch,
                            const scene::Domain& d, int m, int strata, uint64_t seed,
                            uint64_t& rays) {
    const scene::Patch& p = s.patches[patch];
    std::vector<Vec3> x;
    std::vector<double> w;
    const int n = elementMeanPoints(p, d, m, x, w);
    RGB sum(0.0);
    for (int k = 0; k < n; ++k)
        sum += w[k] * lightsIrradiance(s, vis, x[k], p.normal, patch, strata, hashIds(seed, k), rays);
    return sum;
}

RGB environmentRadiance(const scene::Scene& s, const Vec3& dir) {
    RGB L(0.0);
    for (const auto& l : s.lights) L += l->radiance(dir);
    return L;
}

bool hasSampledEnvironment(const scene::Scene& s) {
    for (const auto& l : s.lights)
        if (l->importanceSampled()) return true;
    return false;
}

namespace {
/// The power heuristic's score of direction w for light l, drawn by either
/// strategy (header): with a = n_l pdf_l(w), b = n_c cos t / pi, a light
/// draw scores a f / (a^2 + b^2) and a cosine draw b f / (a^2 + b^2),
/// f = L(w) cos t; `fromLight` says which.
RGB powerScore(const scene::Light& l, const Vec3& n, const Vec3& w, int nl, int nc,
               bool fromLight) {
    const double c = glm::dot(n, w);
    if (!(c > 0)) return RGB(0.0);
    const RGB L = l.radiance(w);
    if (!(maxComponent(L) > 0)) return RGB(0.0);
    const double a = nl * l.pdf(w), b = nc * c / kPi;
    return L * (c * (fromLight ? a : b) / (a * a + b * b));
}
}  // namespace

RGB sampledEnvironmentDirect(const scene::Scene& s, const Visibility& vis, const Vec3& x,
                             const Vec3& n, uint32_t patch, int lightSamples, int cosineSamples,
                             Pcg32& rng, uint64_t& rays) {
    // m x m strata of the unit square when n_l = m^2 (Veach 1997 sec. 2.7),
    // else independent draws.
    const int m = int(std::lround(std::sqrt(double(lightSamples))));
    const bool strata = m * m == lightSamples;
    RGB sum(0.0);
    for (const auto& l : s.lights) {
        if (!l->importanceSampled()) continue;
        for (int k = 0; k < lightSamples; ++k) {
            double u1 = rng.nextDouble(), u2 = rng.nextDouble();
            if (strata) u1 = (k % m + u1) / m, u2 = (k / m + u2) / m;
            const Vec3 w = l->sample(x, u1, u2).dir;
            const RGB e = powerScore(*l, n, w, lightSamples, cosineSamples, true);
            if (!(maxComponent(e) > 0)) continue;
            ++rays;
            if (!blocked(vis, x, w, std::numeric_limits<double>::infinity(), patch)) sum += e;
        }
    }
    return sum;
}

RGB sampledEnvironmentEscape(const scene::Scene& s, const Vec3& n, const Vec3& dir,
                             int lightSamples, int cosineSamples) {
    RGB sum(0.0);
    for (const auto& l : s.lights)
        if (l->importanceSampled())
            sum += powerScore(*l, n, dir, lightSamples, cosineSamples, false);
    return sum;
}

RGB unsampledEnvironmentRadiance(const scene::Scene& s, const Vec3& dir) {
    RGB L(0.0);
    for (const auto& l : s.lights)
        if (!l->importanceSampled()) L += l->radiance(dir);
    return L;
}

bool hasEnvironment(const scene::Scene& s) {
    for (const auto& l : s.lights)
        if (!l->isDelta()) return true;
    return false;
}

double lightsPower(const scene::Scene& s) {
    const double R = 0.5 * s.bounds().diagonal();
    double p = 0.0;
    for (const auto& l : s.lights) p += l->power(R);
    return p;
}

}  // namespace hrad::transport
