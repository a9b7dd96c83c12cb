// The residual error estimate; see error_estimate.h.
#include "reference/error_estimate.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/log.h"
#include "core/rng.h"
#include "core/timer.h"
#include "reference/light_sampling.h"
#include "scene/element.h"
#include "transport/light_irradiance.h"

namespace hrad::reference {

namespace {

constexpr uint32_t kMiss = std::numeric_limits<uint32_t>::max();

/// The residual's two halves per region and the region each sample's ray hit.
struct Samples {
    std::vector<uint64_t> offset;  ///< per region, first entry in `hit`; size n + 1
    std::vector<uint32_t> hit;     ///< front-hit region of each sample, or kMiss
    std::vector<RGB> r1, r2;       ///< residual of the even and of the odd samples
    uint64_t rays = 0;
};

/// The regions: patches split uniformly so that a region gets about
/// `regionSamples` samples (the residual's average over a Galerkin element
/// vanishes, so regions finer than the solution's elements are what lets
/// its variation inside them be seen: header).
scene::UniformField makeRegions(const scene::Scene& sc, const ErrorEstimateSettings& st) {
    double area = 0;
    size_t reflecting = 0;
    for (const auto& p : sc.patches)
        if (maxComponent(p.rho) > 0) area += p.area, ++reflecting;
    const double regions = double(st.samples) / double(st.regionSamples);
    const double maxArea = regions > double(reflecting) && area > 0 ? area / regions : 0.0;
    return scene::UniformField(sc, scene::uniformLevels(sc, 0, maxArea, st.maxLevel));
}

int samplesPerRegion(const ErrorEstimateSettings& st, const scene::UniformField& regions) {
    size_t reflecting = 0;
    const scene::Scene& sc = regions.scene();
    for (uint32_t p = 0; p < sc.patches.size(); ++p)
        if (maxComponent(sc.patches[p].rho) > 0) reflecting += regions.count(p);
    uint64_t m = reflecting ? st.samples / reflecting : uint64_t(st.maxSamples);
    m = std::clamp<uint64_t>(m, uint64_t(st.minSamples), uint64_t(st.maxSamples));
    return int(m + (m & 1));  // even: two equal halves
}

uint32_t regionAt(const scene::UniformField& regions, uint32_t patch, const Vec2& uv) {
    const scene::Patch& q = regions.scene().patches[patch];
    const int L = regions.level(patch);
    const scene::ElementKey k = scene::keyAt(q.kind, uv.x, uv.y, L);
    return uint32_t(regions.offset(patch) + (k - (scene::ElementKey(1) << (2 * L))));
}

/// H at x = direct light + the solution's reflected radiosity at the hit.
RGB gatherOne(const scene::Scene& sc, const transport::Visibility& vis, const EmitterTable& em,
              const scene::RadiosityField& field, const scene::UniformField& regions, uint32_t pi,
              const Vec3& x, Pcg32& rng, uint32_t& hitRegion, uint64_t& rays) {
    const scene::Patch& p = sc.patches[pi];
    RGB H = directLight(sc, vis, em, x, p.normal, pi, true, rng, rays);
    Vec3 dir = sampleCosine(p.normal, rng);
    ++rays;
    hitRegion = kMiss;
    transport::RayHit h = vis.intersect(x, dir, 0.0, 1e300, pi);
    if (!h.hit) {
        // Escaped: the environment's pi L (scene/lights/; 0 without one).
        if (!sc.lights.empty()) H += 3.14159265358979323846 * transport::environmentRadiance(sc, dir);
        return H;
    }
    const scene::Patch& q = sc.patches[h.patch];
    if (glm::dot(q.normal, dir) >= 0) return H;  // the back of a one-sided patch: B = 0
    Vec3 y = h.point - q.normal * glm::dot(h.point - q.v[0], q.normal);
    if (q.isEmitter()) H += misEmission(q, em.probOfPatch[h.patch], x, p.normal, y, dir);
    Vec2 uv = glm::clamp(scene::patchInverse(q, h.point), Vec2(0.0), Vec2(1.0));
    if (q.kind == scene::PatchKind::Triangle && uv.x + uv.y > 1) uv /= uv.x + uv.y;
    hitRegion = regionAt(regions, h.patch, uv);
    return H + (field.at(h.patch, uv.x, uv.y) - q.emission);
}

std::vector<uint32_t> patchOfRegions(const scene::UniformField& regions) {
    std::vector<uint32_t> patchOf(regions.numElements());
    for (uint32_t p = 0; p < regions.scene().patches.size(); ++p)
        for (size_t i = 0; i < regions.count(p); ++i) patchOf[regions.offset(p) + i] = p;
    return patchOf;
}

Samples sampleResiduals(const scene::Scene& sc, const transport::Visibility& vis,
                        const scene::RadiosityField& field, const scene::UniformField& regions,
                        const ErrorEstimateSettings& st, int m, bool progress) {
    const size_t n = regions.numElements();
    const std::vector<uint32_t> patchOf = patchOfRegions(regions);
    Samples s;
    s.offset.assign(n + 1, 0);
    for (size_t k = 0; k < n; ++k)
        s.offset[k + 1] =
            s.offset[k] + (maxComponent(sc.patches[patchOf[k]].rho) > 0 ? uint64_t(m) : 0);
    s.hit.assign(s.offset[n], kMiss);
    s.r1.assign(n, RGB(0.0));
    s.r2.assign(n, RGB(0.0));
    EmitterTable em(sc);
    std::vector<uint64_t> rays(n, 0);
    ProgressBar bar("error estimate", n, progress);
    tbb::parallel_for(size_t(0), n, [&](size_t ri) {
        const uint32_t pi = patchOf[ri];
        const scene::Patch& p = sc.patches[pi];
        const scene::ElementKey key = regions.key(pi, ri - regions.offset(pi));
        const RGB mean = field.average(pi, key);
        const uint64_t k = s.offset[ri + 1] - s.offset[ri];
        RGB half[2] = {RGB(0.0), RGB(0.0)};
        if (k > 0) {
            Vec3 corners[4];
            const int nc = scene::elementCorners(p, scene::keyDomain(p.kind, key), corners);
            PolygonSampler area(corners, nc);
            Pcg32 rng(hashIds(st.seed, uint64_t(ri)));
            for (uint64_t j = 0; j < k; ++j)
                half[j & 1] += gatherOne(sc, vis, em, field, regions, pi, area.sample(rng), rng,
                                         s.hit[s.offset[ri] + j], rays[ri]);
            for (RGB& h : half) h /= double(k / 2);
        }
        s.r1[ri] = p.emission + p.rho * half[0] - mean;
        s.r2[ri] = p.emission + p.rho * half[1] - mean;
        bar.add(1);
    });
    bar.done();
    for (uint64_t r : rays) s.rays += r;
    return s;
}

/// e = r + rho T^ e by Jacobi iteration over the regions, T^_kl the share of
/// k's samples of parity `half` that hit l: each half's error uses its own
/// samples only, so that the two halves stay independent (header). Returns
/// the iterations used.
int propagate(const scene::UniformField& regions, const std::vector<RGB>& rho, const Samples& s,
              int half, std::vector<RGB>& e) {
    const size_t n = regions.numElements();
    const std::vector<RGB> r = e;
    std::vector<RGB> next(n);
    double scale = 0;
    for (size_t k = 0; k < n; ++k) scale += regions.area(k) * std::fabs(luminance(r[k]));
    for (int it = 1; it <= 500; ++it) {
        double change = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, n), 0.0,
            [&](const tbb::blocked_range<size_t>& range, double acc) {
                for (size_t k = range.begin(); k != range.end(); ++k) {
                    const uint64_t b = s.offset[k], m = s.offset[k + 1] - b;
                    RGB g(0.0);
                    for (uint64_t j = uint64_t(half); j < m; j += 2)
                        if (s.hit[b + j] != kMiss) g += e[s.hit[b + j]];
                    next[k] = r[k] + (m ? rho[k] * (g / double(m / 2)) : RGB(0.0));
                    acc += regions.area(k) * std::fabs(luminance(next[k] - e[k]));
                }
                return acc;
            },
            std::plus<double>());
        e.swap(next);
        if (!(change > 1e-7 * scale)) return it;
    }
    return 500;
}

/// Per root patch, the area-weighted mean of its regions' values.
std::vector<RGB> perPatch(const scene::UniformField& regions, const std::vector<RGB>& v) {
    const scene::Scene& sc = regions.scene();
    std::vector<RGB> out(sc.patches.size(), RGB(0.0));
    for (uint32_t p = 0; p < sc.patches.size(); ++p) {
        const double A = sc.patches[p].area;
        if (!(A > 0)) continue;
        for (size_t k = regions.offset(p); k < regions.offset(p) + regions.count(p); ++k)
            out[p] += (regions.area(k) / A) * v[k];
    }
    return out;
}

struct Sums {
    double l2Cross = 0, l2Den = 0, l1Num = 0, l1Den = 0, noise = 0, resid = 0;
    double solution = 0, exact = 0, exactVar = 0;
};

void addPatch(Sums& t, const scene::Patch& p, double mean, const RGB& e1, const RGB& e2,
              const RGB& r) {
    const double a = p.area, y1 = luminance(e1), y2 = luminance(e2);
    const double exact = mean + 0.5 * (y1 + y2);
    t.l1Num += a * std::sqrt(std::max(0.0, y1 * y2));
    t.l1Den += a * std::fabs(exact - luminance(p.emission));
    if (p.isEmitter()) return;
    t.l2Cross += a * y1 * y2;
    t.l2Den += a * exact * exact;
    t.noise += a * 0.25 * (y1 - y2) * (y1 - y2);
    t.resid += a * luminance(r) * luminance(r);
    t.solution += a * mean;
    t.exact += a * exact;
    t.exactVar += a * a * 0.25 * (y1 - y2) * (y1 - y2);  // Var(mean of halves) = (y1 - y2)^2 / 4
}

}  // namespace

ErrorEstimateSettings ErrorEstimateSettings::fromParams(const Params& params,
                                                        const std::string& prefix) {
    Params::Scope scope(params, "error estimate");
    auto key = [&](const char* k) { return prefix + "." + k; };
    ErrorEstimateSettings s;
    s.samples = uint64_t(params.getInt(
        {key("samples"), "error estimate: residual samples over the whole scene"},
        int64_t(s.samples), 1000, int64_t(1) << 40));
    s.regionSamples = int(params.getInt(
        {key("region_samples"),
         "error estimate: samples per region the patches are split for (finer regions see more "
         "of the error inside the solution's elements)"},
        s.regionSamples, 2, 1 << 20));
    s.maxLevel = int(params.getInt(
        {key("max_level"), "error estimate: subdivision level of its regions at most"},
        s.maxLevel, 0, 12));
    s.minSamples = int(params.getInt(
        {key("min_samples"), "error estimate: samples per region at least"}, s.minSamples, 2,
        1 << 20));
    s.maxSamples = int(params.getInt(
        {key("max_samples"), "error estimate: samples per region at most"}, s.maxSamples,
        s.minSamples, 1 << 24));
    s.seed = uint64_t(params.getInt({key("seed"), "error estimate: seed of its rays"},
                                    int64_t(s.seed), 0, std::numeric_limits<int64_t>::max()));
    return s;
}

std::string ErrorEstimateSettings::describe() const {
    return fmt::format("samples={} region_samples={} max_level={} min_samples={} max_samples={} "
                       "seed={}",
                       samples, regionSamples, maxLevel, minSamples, maxSamples, seed);
}

ErrorEstimate estimateError(const scene::Scene& scene, const transport::Visibility& visibility,
                            const scene::RadiosityField& field,
                            const ErrorEstimateSettings& settings, bool showProgress) {
    Timer timer;
    const size_t n = scene.patches.size();
    const scene::UniformField regions = makeRegions(scene, settings);
    ErrorEstimate out;
    out.regions = regions.numElements();
    out.samplesPerRegion = samplesPerRegion(settings, regions);
    Samples s = sampleResiduals(scene, visibility, field, regions, settings,
                                out.samplesPerRegion, showProgress);
    std::vector<RGB> rho(regions.numElements());
    const std::vector<uint32_t> patchOf = patchOfRegions(regions);
    for (size_t k = 0; k < rho.size(); ++k) rho[k] = scene.patches[patchOf[k]].rho;
    std::vector<RGB> e1 = s.r1, e2 = s.r2, rMean(s.r1.size());
    for (size_t k = 0; k < rMean.size(); ++k) rMean[k] = 0.5 * (s.r1[k] + s.r2[k]);
    out.iterations = std::max(propagate(regions, rho, s, 0, e1), propagate(regions, rho, s, 1, e2));
    const std::vector<RGB> p1 = perPatch(regions, e1), p2 = perPatch(regions, e2),
                           pr = perPatch(regions, rMean);
    Sums t;
    out.perPatch.resize(n);
    for (size_t p = 0; p < n; ++p) {
        const double mean = luminance(field.average(uint32_t(p), scene::kRootKey));
        addPatch(t, scene.patches[p], mean, p1[p], p2[p], pr[p]);
        out.perPatch[p] = 0.5 * (p1[p] + p2[p]);
    }
    auto rel = [](double num, double den) {
        return den > 0 ? std::sqrt(std::max(0.0, num) / den) : 0.0;
    };
    out.l2NonEmitter = rel(t.l2Cross, t.l2Den);
    out.noiseL2 = rel(t.noise, t.l2Den);
    out.residualL2 = rel(t.resid, t.l2Den);
    out.l1Reflected = t.l1Den > 0 ? t.l1Num / t.l1Den : 0.0;
    out.meanRatio = t.exact > 0 ? t.solution / t.exact : 1.0;
    // Patches independent: the standard error of sum A e, relative to sum A B*.
    out.meanRatioNoise = t.exact > 0 ? out.meanRatio * std::sqrt(t.exactVar) / t.exact : 0.0;
    out.rays = s.rays;
    out.seconds = timer.seconds();
    spdlog::debug("error estimate: {} regions, {} samples each, {} rays, {} iterations, {:.2f} s",
                  out.regions, out.samplesPerRegion, out.rays, out.iterations, out.seconds);
    return out;
}

}  // namespace hrad::reference
