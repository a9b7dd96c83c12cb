// Progressive refinement radiosity with adaptive substructuring
// (Cohen, Chen, Wallace & Greenberg 1988, "A progressive refinement approach
// to fast radiosity image generation", SIGGRAPH '88; Cohen & Wallace 1993
// §5.3.3). Selected as `solver = progressive`.
//
// What it does. Every root patch is split uniformly into *patches* (the
// shooters, scene::uniformLevels of `level` / `max_area`); each patch carries
// a quadtree of *elements* (the receivers), initially the patch itself. One
// step ("shot") takes the patch j with the largest unshot power A_j |U_j|_1
// and distributes it to every element e of every other patch i:
//
//     dB_e = rho_e U_j F_je A_j / A_e = rho_e U_j F_ej        (reciprocity)
//
// (Cohen et al. 1988, "shooting"), so only the element-to-patch form
// factors F_ej of the current shooter are computed (transport::
// FormFactorEngine, receiver e, sender j): nothing of size n^2 is stored and
// memory is O(patches + elements). Patch i's unshot radiosity grows by the
// area-weighted mean of its elements' dB, and U_j is set to 0.
//
// Adaptive substructuring (Cohen, Greenberg, Immel & Brock 1986; Cohen et al.
// 1988): during a shot, an element below `max_subdivision` extra levels is
// evaluated on its four children; where the radiosity difference between
// neighbouring children, max |dB_c - dB_c'|_1, exceeds subdivide_threshold x
// B_scale the children become elements (each recursively tested), otherwise
// the element keeps one value, the area-weighted mean of its children's (a
// finer rule than one evaluation). B_scale = Phi_emitted / (A_total (1 -
// rho_avg)) is the mean radiosity of a closed scene of the mean reflectance.
// A new element's radiosity from the earlier shots is, with `regather`,
// gathered from the radiosity every patch has shot so far, S_k:
//     B_e = E_e + rho_e sum_k F_ek S_k        (exact: B is linear in the shots)
// at the cost of one element-to-patch form factor per patch that has shot;
// without it the element inherits its parent's value, the approximation of
// the 1988 paper (only the current shot is resolved finely), which leaves
// errors of several per cent where earlier shots varied across the parent
// (5 % in the furnace box, tests/reference/progressive_test.cpp).
//
// Ambient term (Cohen et al. 1988, for display): with rho_avg the
// area-weighted mean reflectance and R = 1 / (1 - rho_avg),
//     ambient = R sum_i A_i U_i / sum_i A_i,     B_display,e = B_e + rho_e ambient.
// It vanishes as the unshot power does.
//
// Stopping rule: stop when the unshot power sum_i A_i |U_i|_1 is at most
// `tolerance` times the emitted power, or after `max_shots` shots.
//
// Settings (Params keys below a prefix, "pr" by default):
//   level            int     2       uniform level of the patches (shooters),
//                                    4^level per root patch; ignored when
//                                    max_area > 0
//   max_area         double  0       patches of area <= max_area (0: use level)
//   max_level        int     12      cap on the level chosen by max_area
//   max_subdivision  int     2       extra quadtree levels elements may reach
//                                    below their patch (0: no substructuring)
//   subdivide_threshold double 0.05  gradient threshold, relative to B_scale
//   regather         bool    true    new elements gather the light already shot
//                                    (see above) instead of inheriting it
//   tolerance        double  1e-3    unshot / emitted power at which to stop
//   max_shots        int     100000  cap on the number of shots
//   ambient          bool    true    add the ambient term to the returned field
//                                    (and to the history hook's snapshots)
//   history_every    int     10      a history record (and hook call) every N shots
//   ff.*                             transport::FormFactorSettings; the full
//                                    matrix's defaults (adaptive_depth 3)
//   ff.method        string  "quadrature"  "hemicube": each shot's form factors
//                                    from hemicubes on the shooter (the 1988
//                                    paper's own method; transport/hemicube.h,
//                                    ff.hemicube_res, ff.hemicube_points):
//                                    F_ej = F_je A_j / A_e with F_je the cells
//                                    landing on element e. Regathering of new
//                                    elements still uses the quadrature.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
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
                                   const ProgressiveHook& hook = {});

}  // namespace hrad::reference
