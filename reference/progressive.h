// Progressive refinement radiosity with adaptive substructuring
// (Cohen, Chen, Wallace & Greenberg 1988, "A progressive refinement approach
// to fast radiosity image generation"; Cohen & Wallace 1993 §5.3.3).
// Selected as `solver = progressive`.
//
// Every root patch is split uniformly into patches (the shooters); each
// carries a quadtree of elements (the receivers). A shot takes the patch j
// with the largest unshot power A_j |U_j|_1 and gives every element e of
// every other patch
//     dB_e = rho_e U_j F_je A_j / A_e = rho_e U_j F_ej        (reciprocity)
// so only the current shooter's element-to-patch form factors are computed:
// memory is O(patches + elements). A patch's unshot radiosity grows by the
// area-weighted mean of its elements' dB; U_j is then 0.
//
// Adaptive substructuring (Cohen, Greenberg, Immel & Brock 1986; Cohen et al.
// 1988): an element below max_subdivision extra levels is evaluated on its
// four children; where neighbouring children differ by more than
// subdivide_threshold x B_scale (B_scale = Phi_e / (A_total (1 - rho_avg)))
// they become elements, otherwise the element keeps their area mean. With
// `regather` a new element gathers what every patch has shot so far, S_k:
//     B_e = E_e + rho_e sum_k F_ek S_k        (exact: B is linear in the shots)
// instead of inheriting its parent's value (the 1988 approximation, several
// per cent off where earlier shots varied across the parent).
//
// Ambient term (Cohen et al. 1988, for display): R = 1 / (1 - rho_avg),
//     ambient = R sum_i A_i U_i / sum_i A_i,   B_display = B + rho ambient.
// Stops when the unshot power is at most `tolerance` times the emitted power,
// or after max_shots. ff.method = hemicube shoots with hemicubes (the 1988
// paper's own method; transport/hemicube.h).
//
// Settings: the keys below a prefix, "pr" by default (`hrad settings pr.`).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/stop.h"
#include "scene/field.h"
#include "scene/scene.h"
#include "transport/formfactor.h"
#include "transport/hemicube.h"
#include "transport/visibility.h"

namespace hrad::reference {

struct ProgressiveSettings {
    int level = 2;
    double maxArea = 0.0;
    int maxLevel = 12;
    int maxSubdivision = 2;
    double subdivideThreshold = 0.05;
    bool regather = true;
    double tolerance = 1e-3;
    int64_t maxShots = 100000;
    bool ambient = true;
    int historyEvery = 10;
    transport::FormFactorSettings ff;
    transport::HemicubeSettings hemicube;  ///< ff.method = hemicube

    ProgressiveSettings();
    static ProgressiveSettings fromParams(const Params& params, const std::string& prefix = "pr");
    std::string describe() const;
};

/// One history record: the state after `shots` shots.
struct ProgressiveRecord {
    int64_t shots = 0;
    uint32_t shooter = 0;        ///< patch shot last
    double unshotFraction = 0;   ///< unshot / emitted power (|.|_1 of RGB)
    size_t elements = 0;         ///< receiver elements (leaves)
    uint64_t formFactors = 0;    ///< element-to-patch form factors so far
    uint64_t rays = 0;
    double seconds = 0;          ///< wall time since the start
    uint64_t bytes = 0;          ///< patch + element storage
    double l2Lum = std::nan(""); ///< set by the history hook, if any
};

struct ProgressiveResult {
    std::unique_ptr<scene::LeafField> field;
    size_t patches = 0;
    size_t elements = 0;
    int64_t shots = 0;
    double unshotFraction = 0;
    bool converged = false;
    bool interrupted = false;  ///< stopped by a signal before a shot (core/stop.h)
    uint64_t formFactors = 0;
    uint64_t rays = 0;
    uint64_t bytes = 0;
    double seconds = 0;
    std::vector<ProgressiveRecord> history;
};

/// Called at every history record with the current display field.
using ProgressiveHook = std::function<void(const scene::RadiosityField&, ProgressiveRecord&)>;

ProgressiveResult solveProgressive(const scene::Scene& scene, const transport::Visibility& visibility,
                                   const ProgressiveSettings& settings, bool showProgress = true,
                                   const ProgressiveHook& hook = {}, const StopPoll& stop = {});

}  // namespace hrad::reference
