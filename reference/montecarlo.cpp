// Monte Carlo region reference; see montecarlo.h for the estimator and settings.
#include "reference/montecarlo.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/log.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/timer.h"
#include "reference/light_sampling.h"
#include "scene/element.h"
#include "transport/light_irradiance.h"

namespace hrad::reference {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// One region's random walks. Not shared between tasks.
class Walker {
  public:
    Walker(const scene::Scene& s, const transport::Visibility& vis, const EmitterTable& em,
           const MonteCarloSettings& st)
        : scene_(s), vis_(vis), em_(em), maxDepth_(st.maxDepth), mis_(st.mis),
          hasEnv_(transport::hasEnvironment(s)),
          envMis_(st.environmentMis && transport::hasSampledEnvironment(s)) {}

    uint64_t rays = 0;

    /// H_est(x): gathered radiosity at x (on patch `patch`, front side).
    RGB gather(Vec3 x, uint32_t patch, Pcg32& rng) {
        RGB H(0.0), beta(1.0);
        for (int depth = 0;; ++depth) {
            const scene::Patch& p = scene_.patches[patch];
            // Light paths ending after depth + 1 segments: NEE at x_depth ...
            H += beta * direct(x, p.normal, patch, rng);
            if (envMis_)  // the sampled environments' light draw (balance heuristic)
                H += beta * transport::sampledEnvironmentDirect(scene_, vis_, x, p.normal, patch,
                                                                1, 1, rng, rays);
            // ... and (with MIS) the emitter hit by the cosine ray below.
            Vec3 dir = sampleCosine(p.normal, rng);
            ++rays;
            transport::RayHit hit = vis_.intersect(x, dir, 0.0, 1e300, patch);
            if (!hit.hit) {
                if (hasEnv_) H += beta * escaped(p.normal, dir);
                break;
            }
            const scene::Patch& q = scene_.patches[hit.patch];
            double cosY = -glm::dot(dir, q.normal);
            if (cosY <= 0) break;  // back face: B = 0 there
            // Put the hit exactly on q's plane (Embree's t is float).
            Vec3 y = hit.point - q.normal * glm::dot(hit.point - q.v[0], q.normal);
            if (mis_ && q.isEmitter())
                H += beta * misEmission(q, em_.probOfPatch[hit.patch], x, p.normal, y, dir);
            if (maxDepth_ > 0 && depth + 2 > maxDepth_) break;  // next NEE: depth + 2 segments
            beta *= q.rho;
            double survive = maxComponent(q.rho);
            if (survive <= 0) break;
            if (depth + 1 >= kRouletteDepth) {
                if (rng.nextDouble() >= survive) break;
                beta /= survive;
            }
            x = y;
            patch = hit.patch;
        }
        return H;
    }

  private:
    RGB direct(const Vec3& x, const Vec3& n, uint32_t patch, Pcg32& rng) {
        return directLight(scene_, vis_, em_, x, n, patch, mis_, rng, rays);
    }

    /// What a cosine ray of direction dir that left the scene scores.
    RGB escaped(const Vec3& n, const Vec3& dir) const {
        // Cosine alone: pi L by the cosine pdf.
        if (!envMis_) return kPi * transport::environmentRadiance(scene_, dir);
        return kPi * transport::unsampledEnvironmentRadiance(scene_, dir) +
               transport::sampledEnvironmentEscape(scene_, n, dir, 1, 1);
    }

    const scene::Scene& scene_;
    const transport::Visibility& vis_;
    const EmitterTable& em_;
    int maxDepth_;
    bool mis_;
    bool hasEnv_;
    bool envMis_;  ///< mc.environment = mis and an importanceSampled() light
};

}  // namespace

MonteCarloSettings MonteCarloSettings::fromParams(const Params& params, const std::string& prefix) {
    Params::Scope scope(params, "montecarlo reference");
    MonteCarloSettings s;
    auto key = [&](const char* k) { return prefix.empty() ? std::string(k) : prefix + "." + k; };
    s.level =
        int(params.getInt({key("level"), "Monte Carlo: uniform subdivision level of the regions"},
                          s.level, 0, scene::kMaxLevel));
    s.maxArea = params.getDouble(
        {key("max_area"), "Monte Carlo: subdivide regions above this area (0: by level only)"},
        s.maxArea, 0.0, 1e300);
    s.maxLevel =
        int(params.getInt({key("max_level"), "Monte Carlo: region level at most with max_area"},
                          s.maxLevel, 0, scene::kMaxLevel));
    s.samples = int(params.getInt(
        {key("samples"), "Monte Carlo: paths per region (standard error falls as 1/sqrt)"},
        s.samples, 2, 1000000000));
    s.timeBudget = params.getDouble(
        {key("time_budget"), "Monte Carlo: seconds of sampling at most (0: no limit)"},
        s.timeBudget, 0.0, 1e12);
    s.maxDepth = int(params.getInt(
        {key("max_depth"), "Monte Carlo: path length at most (0: Russian roulette only)"},
        s.maxDepth, 0, 1000000));
    s.seed = uint64_t(params.getInt({key("seed"), "Monte Carlo: seed of the random walks"},
                                    int64_t(s.seed), 0, std::numeric_limits<int64_t>::max()));
    s.mis = params.getBool(
        {key("mis"), "Monte Carlo: multiple importance sampling of next-event estimation"}, s.mis);
    s.environmentMis =
        params.getEnum({key("environment"),
                        "Monte Carlo: importance-sampled environments (envmaps) by light draws "
                        "and cosine rays with MIS, or by escaping cosine rays alone"},
                       "mis", {"mis", "cosine"}) == "mis";
    return s;
}

std::string MonteCarloSettings::describe() const {
    return fmt::format(
        "level={} max_area={} max_level={} samples={} time_budget={} max_depth={} seed={} mis={}{}",
        level, maxArea, maxLevel, samples, timeBudget, maxDepth, seed, mis,
        environmentMis ? "" : " environment=cosine");
}

MonteCarloResult solveMonteCarlo(const scene::Scene& scene, const transport::Visibility& visibility,
                                 const MonteCarloSettings& settings, bool showProgress,
                                 const StopPoll& stop) {
    if (settings.samples < 2)
        throwInputError({},
                        "mc.samples = {}: need at least 2 paths per region for a standard "
                        "error",
                        settings.samples);
    if (settings.level < 0 || settings.level > scene::kMaxLevel)
        throwInputError({}, "mc.level = {} out of range [0, {}]", settings.level, scene::kMaxLevel);
    Timer timer;
    MonteCarloResult result;
    result.field = std::make_unique<scene::UniformField>(
        scene, scene::uniformLevels(scene, settings.level, settings.maxArea, settings.maxLevel));
    scene::UniformField& field = *result.field;
    const size_t n = field.numElements();
    std::vector<uint32_t> patchOf(n);
    for (uint32_t p = 0; p < scene.patches.size(); ++p)
        for (size_t i = 0; i < field.count(p); ++i) patchOf[field.offset(p) + i] = p;

    EmitterTable emitters(scene);
    if (emitters.empty() && scene.lights.empty()) spdlog::warn("monte carlo reference: the scene has no emitter");
    std::vector<Welford> acc(n);
    std::vector<uint64_t> rays(n, 0);

    const bool budgeted = settings.timeBudget > 0;
    // Fixed mode: progress over regions; budget mode: over the budget in ms.
    ProgressBar bar(fmt::format("monte carlo ({} regions)", n),
                    budgeted ? uint64_t(settings.timeBudget * 1000.0) : uint64_t(n), showProgress);
    int rounds = 0;
    std::atomic<bool> stopped{false};
    for (;;) {
        const uint64_t round = uint64_t(rounds);
        tbb::parallel_for(
            tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
                for (size_t k = r.begin(); k != r.end(); ++k) {
                    if (stopped.load(std::memory_order_relaxed) || stop()) {
                        stopped = true;
                        break;
                    }
                    uint32_t pi = patchOf[k];
                    const scene::Patch& p = scene.patches[pi];
                    Vec3 corners[4];
                    int nc = scene::elementCorners(
                        p, scene::keyDomain(p.kind, field.key(pi, k - field.offset(pi))), corners);
                    PolygonSampler region(corners, nc);
                    Pcg32 rng(hashIds(settings.seed, uint64_t(k), round));
                    Walker walker(scene, visibility, emitters, settings);
                    const bool reflects = maxComponent(p.rho) > 0;
                    for (int s = 0; s < settings.samples; ++s) {
                        RGB b = p.emission;
                        if (reflects) b += p.rho * walker.gather(region.sample(rng), pi, rng);
                        acc[k].add(b);
                    }
                    rays[k] += walker.rays;
                    if (!budgeted) bar.add(1);
                }
            });
        ++rounds;
        if (!budgeted || stopped) break;
        double t = timer.seconds();
        bar.add(uint64_t(1000.0 * t / rounds));  // approximate: one round's share
        if (t + t / rounds > settings.timeBudget) break;
    }
    bar.done();

    result.stdError.resize(n);
    uint64_t totalRays = 0;
    for (size_t k = 0; k < n; ++k) {
        const bool estimated = acc[k].n >= 2;
        field.value(k) = estimated ? acc[k].mean : RGB(std::nan(""));
        result.stdError[k] = estimated ? acc[k].stdError() : RGB(std::nan(""));
        result.stats.estimated += estimated ? 1 : 0;
        result.stats.paths += acc[k].n;
        totalRays += rays[k];
    }
    result.stats.interrupted = stopped;
    if (stopped)
        spdlog::warn("signal {} received: the Monte Carlo reference stops with {} of {} regions estimated "
                     "(the others are NaN), marked interrupted", interruptSignal(), result.stats.estimated, n);
    result.stats.regions = n;
    result.stats.rays = totalRays;
    result.stats.rounds = rounds;
    result.stats.seconds = timer.seconds();
    spdlog::debug("monte carlo: {} regions, {} rounds, {} paths, {} rays, {:.2f} s", n, rounds,
                  result.stats.paths, totalRays, result.stats.seconds);
    return result;
}

}  // namespace hrad::reference
