// HrSettings: every setting of the hierarchical solver (hr.*, with the
// form-factor, cluster and cluster-link settings it hands on), read from
// Params by fromParams. Each key's meaning, default and range is documented
// where it is read (hr/settings.cpp) and listed by `hrad settings hr.`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cluster/link.h"
#include "cluster/transfer.h"
#include "cluster/tree.h"
#include "core/params.h"
#include "hr/eps_power.h"
#include "hr/importance.h"
#include "transport/formfactor.h"

namespace hrad::hr {

struct HrSettings {
    int lightStrata = 8;  ///< hr.light_strata (hr/light_links.h)
    bool lightClusters = false;  ///< hr.light_clusters (hr/light_links.h)
    std::string oracle = "bfa";
    Params oracleParams;  ///< the "oracle.*" keys, prefix stripped
    std::vector<double> epsSchedule;
    double minArea = 0.0;
    double minAreaRel = 1e-5;
    int maxLevel = 14;
    int maxIterations = 100;
    int minIterations = 2;
    double tolerance = 1e-4;
    uint64_t maxLinks = 200'000'000;
    double maxSeconds = 0.0;    ///< hr.max_seconds (0: none)
    uint64_t memoryBudget = 0;  ///< bytes (memory.budget_mb; 0 resolved to 80 % of RAM)
    transport::FormFactorSettings ff;
    cluster::ClusterModel clusterModel = cluster::ClusterModel::Auto;
    cluster::ClusterSettings cluster;
    /// hr.sender_total: error and kv also bound the sender-side error summed
    /// per sender over all its receivers (hr/receiver_error.h SenderTotal).
    bool senderTotal = true;
    /// hr.checks: the refinement checks that may take part (hr/checks/
    /// registry.h), by name in table order; all of them by default.
    std::vector<std::string> checks;
    bool allChecks = true;
    /// hr.importance and its keys (hr/importance.h); the camera is set by
    /// the caller (experiments/solvers.cpp).
    ImportanceSettings importance;
    /// hr.leaf_estimates: compute error_estimate_leaves / _points after the
    /// solve (hr/receiver_error.h leafAverageError).
    bool leafEstimates = true;
    /// hr.leaf_budget: push ancestors' links down while the leaves' error
    /// (hr/receiver_error.h leafBudgetMarks) exceeds the check's eps (Full)
    /// or that eps beyond the error inside the leaves (Balanced).
    enum class LeafBudget { Off, Full, Balanced };
    LeafBudget leafBudget = LeafBudget::Balanced;
    /// hr.receiver_eps: the receiver-aggregate check for oracles that do not
    /// judge it themselves (see the header): negative = auto, 0 = off.
    double receiverEps = -1.0;
    bool extrapolate = true;
    /// hr.relax_share, hr.relax_fraction, hr.relax_sweeps: relaxation of the
    /// few root patches that carry most of an iteration's change (above).
    double relaxShare = 0.8;
    double relaxFraction = 0.01;
    int relaxSweeps = 1000;
    /// hr.eps_power: what eps is a fraction of (above, "What eps is a
    /// fraction of"): the emitted power, the reflected power so far, or the
    /// smaller of the emitted power and the reflected power the iteration is
    /// heading to.
    using EpsPower = hr::EpsPower;
    EpsPower epsPower = EpsPower::Smaller;
    /// hr.judge_visibility = independent: surface-to-surface links are
    /// judged by a visibility estimate independent of the one they carry
    /// (above, "Judged visibility").
    bool judgeVisibility = true;
    /// hr.refine_growth: lazy refinement (above); 0: judge every iteration.
    double refineGrowth = 0.05;
    /// hr.reach_rays: rays per patch of the reachability pass (0: off).
    int reachRays = 64;
    /// hr.reach_retry_rays: more rays for each patch the first ones left unconnected.
    int reachRetryRays = 0;
    /// hr.seed: 0 keeps the fixed seeding of every ray the solve casts.
    uint64_t seed = 0;
    /// hr.noise_target: the solve's own noise (SolverNoise::relative) it
    /// must reach, re-solving with more rays (HrSolver::solve); 0: off.
    double noiseTarget = 0.0;
    int noiseRounds = 3;          ///< hr.noise_rounds: re-solves at most
    double noiseMaxFactor = 64.0; ///< hr.noise_max_factor: rays' growth at most, in all
    bool openPartialReceivers = true;  ///< cluster.partial_receivers
    bool gaussSeidel = false;          ///< hr.iteration
    int gsBlocks = 0;                  ///< hr.gs_blocks (0: one block per root patch)
    cluster::ClusterLinkSettings clusterLink;
    /// hr.texture_rho = element: elements of textured root patches carry
    /// their own reflectance (hr/element_rho.h); patch: the root patch's mean.
    bool elementRho = false;
    /// hr.basis as a degree: 0 constant, 1 linear, 2 quadratic, 3 cubic.
    int basisDegree = 0;
    /// hr.basis_points: quadrature points per axis of the coupling
    /// coefficients (0: degree + 2).
    int basisPoints = 0;
    /// hr.basis_near_levels (transport/coupling.h).
    int basisNearLevels = 1;
    /// hr.basis_check (transport/coupling.h): relative error of the
    /// point-to-point rule's form factors past which a link keeps only the
    /// sender's mean.
    double basisCheck = 0.5;

    /// Reads the keys above (marks "oracle.*" used only after the oracle has
    /// read them: see HrSolver). Throws InputError on bad values or an unknown
    /// oracle name.
    static HrSettings fromParams(const Params& params);
};

}  // namespace hrad::hr
