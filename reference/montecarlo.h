// Monte Carlo region reference (DESIGN.md "Reference solves and error").
//
// Unbiased estimates, with standard errors, of the average radiosity over
// fixed regions: the elements of a uniform subdivision of every root patch
// (scene::uniformLevels), so the result is a scene::UniformField that the
// error metric (reference/metrics.h) compares with any solution exactly.
//
// The math. For diffuse, one-sided patches the radiosity equation is
// (Cohen & Wallace 1993, eq. 2.54)
//
//   B(x) = E(x) + rho(x) H(x),
//   H(x) = \int_A B(y) G(x,y) V(x,y) dA_y,   G = cos t_x cos t_y / (pi r^2)
//        = (1/pi) \int_{hemisphere(x)} B(y(w)) cos t_x dw,
//
// where H is the irradiance in radiosity units (the gathered radiosity) and
// y(w) is the first surface seen from x in direction w; B(y) = 0 when that is
// the back of a patch or nothing. Splitting B(y) = E(y) + rho(y) H(y):
//
//   H(x) = D(x) + (1/pi) \int rho(y) H(y) cos t_x dw,  D(x) = \int E(y) G V dA_y.
//
// D (direct light) is estimated by next-event estimation: pick emitter e with
// probability p_e proportional to its power luminance(E_e) A_e, a point y
// uniformly on it, and score E_e G(x,y) V(x,y) A_e / p_e (one shadow ray,
// Visibility::occluded with the two patch ids). The indirect integral is
// estimated by one cosine-weighted direction (pdf cos t_x / pi, so the weight
// is exactly rho(y) H(y)) traced with Visibility::intersect ignoring x's patch;
// H(y) is estimated recursively the same way. Emission of a patch hit by an
// indirect ray is *not* added: it is D's job (no double counting). The walk
// is the standard NEE path tracer; its throughput is the product of the
// reflectances of the vertices after x:
//
//   H_est(x_0) = sum_{i>=0} (prod_{j=1..i} rho(x_j)) D_est(x_i).
//
// Multiple importance sampling (setting `mis`, on by default). Pure NEE has
// *infinite variance* where an emitter touches a receiver at an angle: for
// two perpendicular patches sharing an edge, G = a b / (pi s^4) with a, b the
// distances to the edge and s^2 = a^2 + b^2 + l^2, and the second moment of
// the NEE estimate \int\int G^2 grows like \int s^{-2} ds, which diverges (the
// furnace has such edges everywhere). The mean is still right, but the sample
// variance, hence the standard error, is then meaningless. With `mis` the
// direct term is estimated by both strategies, combined with the balance
// heuristic (Veach 1997, sec. 9.2): an NEE sample scores E_e a / (a + b) and a
// cosine-sampled ray that hits the front of an emitter scores E_e a / (a + b)
// too, with a = A_e cos t_x cos t_y and b = pi p_e r^2 (so a / b is the NEE
// weight without MIS and the solid-angle pdfs are cos t_x / pi and
// p_e r^2 / (A_e cos t_y)). Both scores are <= E_e: bounded, finite variance,
// and the estimator stays unbiased (the weights sum to 1 wherever the
// integrand is non-zero). With mis = false the walk is the plain NEE tracer
// above (indirect hits on emitters score nothing).
//
// After `kRouletteDepth` vertices, Russian roulette continues a walk with
// probability q = max channel of rho(x_i) and divides the throughput by q
// (unbiased). The region average of B is then
//
//   Bbar_k = E_k + rho_k Hbar_k,  Hbar_k = (1/A_k) \int_{region k} H(x) dA_x,
//
// estimated by averaging E_k + rho_k H_est(x) over paths whose start x is
// uniform by area on region k (the region is a planar polygon with the
// element's corners, split into triangles chosen by area). The standard error
// of each region is sqrt(s^2 / N) with s^2 the per-path sample variance
// (Welford's algorithm, per RGB channel).
//
// Check: in a closed box with E = 1 and rho = 0.5 everywhere, H = 2 and B = 2.
//
// Determinism: region k in round r draws from Pcg32(hashIds(seed, k, r)) and
// is processed by one task, so results are bitwise identical for any number
// of threads. Rounds run one after another.
//
// Settings (Params keys below a prefix, "mc" by default):
//   level        int     0     regions are the uniform subdivision of each root
//                              patch at this level (0 = the root patches)
//   max_area     double  0     alternatively regions of at most this area
//                              (scene::uniformLevels; 0: use level)
//   max_level    int     12    cap on the level chosen by max_area
//   samples      int     256   paths started per region per round (per
//                              region, so every region gets a standard error)
//   time_budget  double  0     seconds (0 = off): keep adding rounds of
//                              `samples` paths per region while the time spent
//                              plus the mean round time fits in the budget
//                              (always at least one round)
//   max_depth    int     0     0 = unlimited (Russian roulette); N > 0 keeps
//                              only light paths of at most N segments
//                              (N = 1: direct light only; biased, for tests)
//   seed         int     1     seed of every region's random stream
//   mis          bool    true  combine NEE with cosine sampling (see above)
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
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

    /// Reads the keys listed above below `prefix` ("mc.level", "mc.samples", ...).
    static MonteCarloSettings fromParams(const Params& params, const std::string& prefix = "mc");
    /// One line, "level=0 max_area=0 ... seed=1"; every setting that changes
    /// the result appears (it is part of the reference cache key).
    std::string describe() const;
};

struct MonteCarloStats {
    size_t regions = 0;
    uint64_t paths = 0;  ///< paths started, all rounds
    uint64_t rays = 0;   ///< intersection + shadow rays
    double seconds = 0.0;
    int rounds = 0;
};

struct MonteCarloResult {
    std::unique_ptr<scene::UniformField> field;  ///< region averages Bbar_k
    std::vector<RGB> stdError;  ///< standard error of Bbar_k per channel, same indexing
    MonteCarloStats stats;
};

/// Runs the estimator described above. Throws InputError for invalid settings
/// (samples < 2: a standard error needs two paths).
MonteCarloResult solveMonteCarlo(const scene::Scene& scene, const transport::Visibility& visibility,
                                 const MonteCarloSettings& settings, bool showProgress = true);

}  // namespace hrad::reference
