// Monte Carlo region reference (DESIGN.md "Reference solves and error").
//
// Unbiased estimates, with standard errors, of the average radiosity over the
// elements of a uniform subdivision of every root patch (scene::UniformField,
// compared with any solution by reference/metrics.h). For diffuse one-sided
// patches (Cohen & Wallace 1993, eq. 2.54)
//   B(x) = E(x) + rho(x) H(x),  H(x) = (1/pi) \int_hemisphere B(y(w)) cos t_x dw,
// and with B = E + rho H at the first hit y,
//   H(x) = D(x) + (1/pi) \int rho(y) H(y) cos t_x dw,  D(x) = \int E G V dA_y.
// The walk is the standard next-event-estimation path tracer: D by an emitter
// chosen by power and a point on it (one shadow ray), the indirect integral by
// one cosine-weighted direction (weight rho(y)), so
//   H_est(x_0) = sum_{i>=0} (prod_{j=1..i} rho(x_j)) D_est(x_i).
// Emission hit by an indirect ray is not added (D's job). Non-area lights
// (scene/lights/light.h): D includes every delta light by one shadow ray
// (reference/light_sampling.h), and a ray that escapes the scene adds
// pi L(w) of the environment (light otherwise escaping is lost). An
// environment that is importanceSampled() (an envmap that varies) is, with
// `environment` = mis (default), also drawn at every vertex: one draw of
// its sample() and the walk's own cosine ray, weighted by the power
// heuristic (Veach & Guibas 1995; transport/light_irradiance.h), so a small
// bright sun is found by the light draw instead of by rare cosine hits. `environment` = cosine
// keeps the escaping rays alone (pi L: unbiased, heavy-tailed for a sun).
//
// Multiple importance sampling (`mis`, default on): pure NEE has infinite
// variance where an emitter meets a receiver at an edge (the second moment
// grows like \int s^-2 ds), so the standard error would be meaningless. With
// mis the direct term combines NEE and cosine hits by the balance heuristic
// (Veach 1997, sec. 9.2): both score E_e a / (a + b), a = A_e cos t_x cos t_y,
// b = pi p_e r^2; bounded by E_e, unbiased.
//
// After kRouletteDepth vertices Russian roulette continues with probability
// max_c rho and divides by it. A region's average Bbar_k = E_k + rho_k Hbar_k
// is the mean over paths started uniformly by area on it; its standard error
// is sqrt(s^2 / N) (Welford, per channel). Check: a closed box with E = 1,
// rho = 0.5 has H = B = 2. Region k in round r draws from
// Pcg32(hashIds(seed, k, r)) in one task: bitwise identical for any number of
// threads.
//
// Settings: the keys below a prefix, "mc" by default (`hrad settings
// reference.mc.` lists them as a study's reference reads them).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/stop.h"
#include "core/types.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::reference {

/// Vertices of a walk (x_0 included) before Russian roulette starts.
inline constexpr int kRouletteDepth = 3;

struct MonteCarloSettings {
    int level = 0;
    double maxArea = 0.0;
    int maxLevel = 12;
    int samples = 256;
    double timeBudget = 0.0;
    int maxDepth = 0;
    uint64_t seed = 1;
    bool mis = true;
    /// mc.environment: importance-sampled environments by light draws and
    /// cosine rays (mis) or by escaping cosine rays alone (cosine).
    bool environmentMis = true;

    /// Reads the keys listed above below `prefix` ("mc.level", "mc.samples", ...).
    static MonteCarloSettings fromParams(const Params& params, const std::string& prefix = "mc");
    /// One line, "level=0 max_area=0 ... seed=1"; every setting that changes
    /// the result appears (it is part of the reference cache key);
    /// environment only when it is cosine, so the keys of references made
    /// before the setting existed stay valid (without an importance-sampled
    /// environment both values give the same paths bit for bit; with one,
    /// such an entry is a cosine-only estimate: unbiased, its own standard
    /// error stored beside it).
    std::string describe() const;
};

struct MonteCarloStats {
    size_t regions = 0;
    uint64_t paths = 0;  ///< paths started, all rounds
    uint64_t rays = 0;   ///< intersection + shadow rays
    double seconds = 0.0;
    int rounds = 0;
    /// Stopped by a signal (core/stop.h, polled per region): regions with
    /// fewer than two paths then hold NaN (value and standard error), never
    /// a silent zero; `estimated` counts the others.
    bool interrupted = false;
    size_t estimated = 0;
};

struct MonteCarloResult {
    std::unique_ptr<scene::UniformField> field;  ///< region averages Bbar_k
    std::vector<RGB> stdError;  ///< standard error of Bbar_k per channel, same indexing
    MonteCarloStats stats;
};

/// Runs the estimator described above. Throws InputError for invalid settings
/// (samples < 2: a standard error needs two paths).
MonteCarloResult solveMonteCarlo(const scene::Scene& scene, const transport::Visibility& visibility,
                                 const MonteCarloSettings& settings, bool showProgress = true,
                                 const StopPoll& stop = {});

}  // namespace hrad::reference
