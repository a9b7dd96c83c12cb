// The hierarchical radiosity solver: initial linking, refinement driven by an
// oracle and amended by the refinement checks, gather and push-pull,
// repeated until converged.
//
// Hanrahan, Salzman & Aupperle 1991 ("A Rapid Hierarchical Radiosity
// Algorithm"), with the loop of DESIGN.md: refine all links -> gather ->
// push-pull, until no link was refined and both the relative change of the
// reflected power and the estimated error still to come from iterating (the
// geometric tail, hr/iteration_tail.h) are below hr.tolerance. A schedule
// of decreasing eps (multigridding, HSA91 section 5) runs the loop once per
// value, keeping the hierarchy. With clustering (Smits, Arvo & Greenberg
// 1994; Sillion 1995) the solve starts from the root cluster's self-link.
//
// The parts, each in its own file:
//   hr/settings.h         every setting (hrad settings hr.)
//   hr/refiner.h          one judging pass, breadth-first, phase by phase;
//                         results are bitwise identical for any thread count
//   hr/checks/            the amendments to the oracle's decisions (receiver
//                         check, leaf budget, sender total, cluster checks)
//   hr/budget.h           hr.max_links, memory.budget_mb, hr.max_seconds
//   hr/link_estimate.cpp  what the oracle judges a link by (LinkEstimate)
//   hr/eps_power.h        what eps is a fraction of (hr.eps_power)
//   hr/accelerate.h       relaxation and Aitken extrapolation of the tail
//   hr/receiver_error.h   receiver aggregates and the leaves' error estimates
//   hr/noise.h            the solve's own ray noise (hr.noise_target)
// Lazy refinement (hr.refine_growth = g): every oracle's test is linear in
// the senders' radiosity or does not read it, so links accepted in a
// judging pass stay within (1 + g) eps until some element's radiosity has
// grown by more than g since that pass; only then are the links judged
// again.
//
// Design notes and the measurements behind the defaults:
// papers/notes/2026-11-29-hr-solver-notes.md.
#pragma once

#include <tbb/enumerable_thread_specific.h>

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "cluster/link.h"
#include "cluster/openness.h"
#include "cluster/transfer.h"
#include "cluster/tree.h"
#include "core/memory.h"
#include "core/params.h"
#include "core/timer.h"
#include "hr/accelerate.h"
#include "hr/budget.h"
#include "hr/checks/check.h"
#include "hr/checks/registry.h"
#include "hr/eps_power.h"
#include "hr/settings.h"
#include "hr/stage_controller.h"
#include "hr/hierarchy.h"
#include "hr/link_builder.h"
#include "hr/noise.h"
#include "hr/receiver_error.h"
#include "oracles/oracle.h"
#include "scene/scene.h"
#include "transport/coupling.h"
#include "transport/formfactor.h"
#include "transport/visibility.h"

namespace hrad::hr {

class LightLinks;

/// What one iteration did (one row of the per-iteration history).
struct IterationRecord {
    int iteration = 0;  ///< 1-based, counted across stages
    int stage = 0;
    double eps = 0.0;  ///< oracle eps of the stage (NaN when the oracle has none)
    uint64_t links = 0, elements = 0, leaves = 0;
    uint64_t refinedLinks = 0;  ///< links replaced by refinement this iteration
    /// The links were judged this iteration (false: lazy refinement skipped
    /// the pass, no radiosity having grown by hr.refine_growth since the last).
    bool judged = true;
    uint64_t rays = 0;         ///< occlusion rays cast this iteration
    uint64_t formFactors = 0;  ///< form factors computed this iteration
    double residual = 0.0;     ///< relative change of reflected power
    /// Estimated relative error of the reflected power still to come from
    /// further iterations on the same links (the geometric tail, below);
    /// infinite when it cannot be estimated yet.
    double iterationError = std::numeric_limits<double>::infinity();
    RGB reflectedPower{0.0};
    double refineSeconds = 0.0, gatherSeconds = 0.0, pushPullSeconds = 0.0;
    uint64_t elementBytes = 0, linkBytes = 0;
    /// The process's peak resident set size at the end of this iteration
    /// (VmHWM): with the history, which phase of which iteration set it.
    uint64_t peakRss = 0;
    /// Aitken factor applied after this iteration (0: none), max channel.
    double extrapolation = 0.0;
    /// Root patches relaxed alone after this iteration (hr.relax_share; 0:
    /// none), and the sweeps over them.
    uint32_t relaxedPatches = 0;
    int relaxSweeps = 0;
    bool relaxIncomplete = false;  ///< stopped by its sweep or link budget, not its target
    /// Error after this iteration when an iteration hook computes it (NaN otherwise).
    double l2Lum = std::numeric_limits<double>::quiet_NaN();
};

/// What one refinement check (hr/checks/) did in a solve.
struct CheckUse {
    std::string name;
    uint64_t passes = 0;   ///< judging passes it took part in
    uint64_t amended = 0;  ///< decisions it changed
};

struct HrResult {
    std::unique_ptr<Hierarchy> hierarchy;
    /// Every refinement check of the solve, in amendment order.
    std::vector<CheckUse> checks;
    std::unique_ptr<HierarchyField> field;
    std::vector<IterationRecord> history;
    std::string oracleDescription;
    bool converged = false;
    bool linkCapHit = false;
    bool memoryBudgetHit = false;  ///< refinement stopped at memory.budget_mb
    bool timeLimitHit = false;     ///< stopped at hr.max_seconds
    bool interrupted = false;      ///< stopped by SIGINT/SIGTERM (core/interrupt.h)
    /// Stopped by the clock or a signal before converging.
    bool stoppedEarly() const { return timeLimitHit || interrupted; }
    /// The power eps was a fraction of in the last judging pass
    /// (hr.eps_power: the emitted power, the reflected power so far, or the
    /// smaller of the emitted and the predicted reflected power).
    double epsPower = 0.0;
    HrSettings::EpsPower epsPowerOf = HrSettings::EpsPower::Emitted;  ///< hr.eps_power
    uint64_t initialLinks = 0;
    uint64_t initialPairs =
        0;  ///< node pairs evaluated by initial linking (k(k-1) without clusters)
    /// Patches light cannot reach (hr.reach_rays; transport/reachability.h),
    /// left out of the transport, the rays and seconds of that pass.
    uint32_t unreachablePatches = 0;
    uint64_t reachRays = 0;
    double reachSeconds = 0.0;
    std::unique_ptr<cluster::ClusterTree> clusterTree;
    /// The oriented hand-over's openness table (cluster.handover = visible;
    /// cluster/openness.h; owned by the hierarchy's hand-over), its rays and seconds.
    const cluster::SurfaceOpenness* openness = nullptr;
    uint64_t opennessRays = 0;
    double opennessSeconds = 0.0;
    /// Links into oriented clusters whose hand-over was decided (when first
    /// kept; some are refined away later): by cosine and openness, and by
    /// cosine alone (no surface of the receiving cluster found open).
    uint64_t handOverByOpenness = 0, handOverByCosine = 0;
    /// Of those by openness, the ones held to their unoccluded bound
    /// (hr/openness_handover.h).
    uint64_t handOverCapped = 0;
    std::string clusterModel;  ///< the model used (auto resolved)
    double clusterBuildSeconds = 0.0;
    /// Links by kind after the solve: surface-surface, surface receiving from a
    /// cluster, cluster receiving from a surface, cluster-cluster.
    uint64_t linksSS = 0, linksSC = 0, linksCS = 0, linksCC = 0;
    uint64_t lightLinks = 0;  ///< links from non-area lights (hr/light_links.h)
    /// Link evaluations (form factors or cluster transfers, kept or refined
    /// away), their visibility rays and their CPU seconds (summed over
    /// threads), by kind in the order above: where refinement spends
    /// (hr/link_builder.h LinkKindCost).
    LinkKindCost linkCost;
    uint64_t totalRays = 0, totalFormFactors = 0;
    /// Links made without rays while their sending cluster was dark and
    /// computed once it carried light (cluster.defer_dark).
    uint64_t deferredLinksComputed = 0;
    /// Links left at the end of the solve that carry nothing: cluster links
    /// that had to be opened when refinement stopped early (Link::kOpen), and
    /// links from clusters that never carried light (Link::kDeferred).
    uint64_t unopenedLinks = 0, deferredLinksLeft = 0;
    /// Links that had to be opened when refinement stopped early and got a
    /// stand-in transfer instead (cluster.stand_in, Link::kStandIn), the
    /// rays and wall seconds (of the phase that made them) those cost, and the power
    /// the stand-ins carry in the final solution (max channel) over the
    /// reflected power.
    uint64_t standInLinks = 0, standInRays = 0;
    double standInSeconds = 0.0, standInPowerShare = 0.0;
    /// cluster.near = stand_in: stand-ins made for pairs too close for the
    /// point approximation (judged, then kept or opened), their rays and
    /// seconds; and the stand-ins of either kind in the final hierarchy
    /// (standInPowerShare is over these: the power their receivers reflect of
    /// what they deliver, Hierarchy::standInReflected).
    uint64_t nearStandInsMade = 0, nearStandInRays = 0, standInLinksFinal = 0;
    double nearStandInSeconds = 0.0;
    double linkingSeconds = 0.0, refineSeconds = 0.0, gatherSeconds = 0.0, pushPullSeconds = 0.0;
    double minArea = 0.0;
    /// A posteriori estimate of the solve's relative L1 error of the
    /// reflected radiosity (HrSolver::estimateError); NaN when not computed.
    double errorEstimate = std::numeric_limits<double>::quiet_NaN();
    /// The error of the leaves' averages from the push of coarse surface
    /// links, all links together (hr/receiver_error.h leafAverageError);
    /// NaN for a polynomial basis.
    double errorEstimateLeaves = std::numeric_limits<double>::quiet_NaN();
    double errorEstimatePoints = std::numeric_limits<double>::quiet_NaN();
    /// The share of the reflected power (luminance) that links the two leaf
    /// estimates leave out deliver: links with a cluster at either end
    /// (hr/receiver_error.h uncoveredLightShare). Where it is large the
    /// estimates see only part of the transport. NaN when they are not computed.
    double errorEstimateUncovered = std::numeric_limits<double>::quiet_NaN();
    double errorEstimateSeconds = 0.0;
    /// The solve's own Monte Carlo noise, estimated from its links
    /// (hr/noise.h), and the time it took.
    SolverNoise noise;
    double noiseSeconds = 0.0;
    /// hr.noise_target: the re-solves made (0: the first solve met it, or
    /// off), the factor every ray count was multiplied by in the one
    /// returned, and the first solve's noise. The phase timings and counts
    /// above are the returned solve's; noiseRoundsSeconds is all the solves'
    /// wall time.
    int noiseRounds = 0;
    double noiseRayFactor = 1.0, noiseFirst = 0.0, noiseRoundsSeconds = 0.0;
    MemoryCounters memory;
};

class HrSolver {
    friend class RefinementPass;  // hr/refiner.h: one judging pass, phase by phase

  public:
    /// `extraChecks` run after the registry's checks (hr/checks/registry.h):
    /// a check under study, without a row in the table yet.
    HrSolver(const scene::Scene& scene, const transport::Visibility& visibility,
             HrSettings settings, const std::vector<CheckEntry>& extraChecks = {});

    /// Runs the whole solve. `progress` enables progress lines on stderr.
    /// With hr.noise_target, a solve whose own noise estimate (hr/noise.h)
    /// is above the target is solved again with every ray count (ff.vis_rays,
    /// cluster.vis_rays, cluster.near_rays, cluster.stand_in_rays)
    /// multiplied by (noise / target)^(1/a) x 1.1, at most 8x per round:
    /// a = 1/2 at first (each link's variance falls as 1 / rays), then the
    /// exponent the last two solves measured (the noise falls faster where
    /// more rays also resolve which links are partially visible). At most
    /// hr.noise_rounds times, and with the rays' growth at most
    /// hr.noise_max_factor in all; a solve stopped early (hr.max_links,
    /// memory.budget_mb, hr.max_seconds) is not solved again. The last
    /// solve is returned.
    HrResult solve(bool progress = false);

    /// Called after every iteration's push-pull with the hierarchy and that
    /// iteration's record (e.g. to compute the error against a reference and
    /// store it in rec.l2Lum). Its time is not counted in any phase.
    using IterationHook = std::function<void(const Hierarchy&, IterationRecord&)>;
    void setIterationHook(IterationHook hook) { hook_ = std::move(hook); }
    /// A caller's stop request (core/cancel.h), polled by the budget
    /// (hr/budget.h) before every refinement round and after every
    /// iteration: solve() then throws hrad::Cancelled.
    void setCancelToken(const CancelToken* token) { budget_->setCancelToken(token); }
    /// After the last stage of hr.eps_schedule (or the one eps) has
    /// converged, `controller` may ask for further stages with smaller eps on
    /// the same hierarchy (hr/stage_controller.h). Not owned.
    void setStageController(StageController* controller) { stageController_ = controller; }

    /// The LinkEstimate that refinement gives the oracle for link l of
    /// receiver r in h (a link not marked Link::kOpen). For a link touching
    /// a cluster, F is the unoccluded point approximation times the judged
    /// visibility (Link::visibility; for Link::kUncertain the 95 % bound
    /// blockedVisibilityBound()), and senderB of a cluster is its maxB().
    /// With `bounds` (the
    /// oracle's needsBounds()) Fmin / Fmax are evaluated too: for surface
    /// links the point-to-element form factors at the form-factor rule's
    /// receiver points, recomputed without rays (transport pointRange), with
    /// Fmin = 0 for partially visible links; [0, max(F, Fupper)] for links
    /// touching a cluster. Not stored in the 16-byte Link. With `upper`
    /// (the oracle's needsUpperBound()) a surface link judged by an
    /// independent visibility gets its conservative Fupper; without, Fupper
    /// is its unoccluded F (no oracle then reads it).
    oracles::LinkEstimate linkEstimate(const Hierarchy& h, uint32_t r, const Link& l, bool bounds,
                                       bool upper = false) const;
    /// The two ends of a link touching a cluster (LinkBuilder::endOf).
    using LinkEnds = std::pair<cluster::LinkEnd, cluster::LinkEnd>;

    /// A posteriori estimate of the relative L1 error of the reflected
    /// radiosity of the solution in h: the sum over surface receivers of
    /// A_r (receiverRange / 4) (the mean |D| of an error that is linear over
    /// the receiver, hr/receiver_error.h) plus, per surface link with a
    /// subdivided sender, A_r F rho_r max_c |B_c - B_s| / 2 (the sender's
    /// own variation averaged away), over the reflected power sum A (B - E);
    /// max channel. What it omits: the error of leaf senders' unresolved
    /// variation, of visibility within partially visible links beyond the
    /// unsigned term, of cluster links, and of the form factors themselves.
    double estimateError(const Hierarchy& h) const { return estimateError(h, h.linkReceivers()); }
    /// The same with the links' receivers already at hand (h.linkReceivers()).
    double estimateError(const Hierarchy& h, const std::vector<uint32_t>& recv) const;

  private:
    void judgedTransfer(const Hierarchy& h, uint32_t r, const Link& l, bool upper,
                        oracles::LinkEstimate& e, LinkEnds& ends) const;
    void receiverFraction(const Hierarchy& h, const LinkEnds& ends,
                          oracles::LinkEstimate& e) const;
    /// One solve with the settings as they are (solve() without the noise
    /// target), phase by phase below.
    HrResult solveOnce(bool progress);
    /// The cluster model (auto resolved), reachability, the cluster tree,
    /// the hierarchy, the cluster linker and the hand-over's openness.
    void buildHierarchy(HrResult& res);
    /// hr.reach_rays: the patches light cannot reach, left out (included_).
    void findReachable(HrResult& res);
    void linkInitially(Hierarchy& h, HrResult& res, bool progress);
    struct LoopState;
    /// Every eps stage to convergence (or a cap, or the clock).
    void iterate(Hierarchy& h, HrResult& res, bool progress);
    /// One stage's iterations; true when it converged.
    bool runStage(Hierarchy& h, HrResult& res, int stage, double eps, LoopState& st,
                  bool progress);
    /// Judge (when due), gather and push-pull, accelerate, record.
    IterationRecord runIteration(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res,
                                 LoopState& st, bool lazy, bool checkPass,
                                 std::vector<RGB>& judgedB);
    /// One gather and push-pull (hr.iteration: Jacobi or Gauss-Seidel).
    void gatherOnce(Hierarchy& h, IterationRecord& rec) const;
    void logIteration(const IterationRecord& rec, bool progress) const;
    /// The a posteriori estimates and the solve's own ray noise.
    void estimateErrors(const Hierarchy& h, HrResult& res) const;
    /// Memory, link counts by kind, stand-ins, costs.
    void summarize(const Hierarchy& h, HrResult& res) const;
    struct Pending;
    /// Kernel samples of `links` (receivers `recv`): one entry per link that
    /// stores them (Hierarchy::storesKernelSamples), in link order.
    std::vector<KernelSamples> computeKernelSamples(const Hierarchy& h,
                                                    const std::vector<uint32_t>& recv,
                                                    const std::vector<Link>& links) const;
    /// The samples the receiver aggregate sums for the surface link s -> r:
    /// the kernel's (constant basis) or its projection residual's
    /// (polynomial basis), hr/receiver_error.h.
    KernelSamples linkSamples(const Hierarchy& h, uint32_t r, uint32_t s) const;
    void initialLinks(Hierarchy& h, std::vector<uint32_t>& recv, std::vector<Link>& links,
                      HrResult& res, bool progress);
    /// One refinement pass with the stage's oracle; the checks added to its
    /// decisions (sampled near cluster links' errors, light a cluster link
    /// may misplace, the receiver check) take its eps as a power fraction
    /// (Oracle::receiverCheckEps).
    uint64_t refine(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res,
                    IterationRecord& rec);
    /// The checks' atConvergence() (hr/checks/check.h): true when one asks
    /// for another judging pass. Its seconds count as refinement's.
    bool checksAtConvergence(Hierarchy& h, const oracles::Oracle& oracle, HrResult& res);
    /// Adds stand-ins made to the result's counts (near: judged ones).
    void countStandIns(HrResult& res, IterationRecord& rec, uint64_t links, uint64_t rays,
                       double seconds, bool near) const;
    /// cluster.near = stand_in: replaces each link to be opened (Link::kOpen)
    /// whose pair ClusterLinker::standInNear admits by its stand-in, which
    /// refinement then judges (cluster/link.h "Judged stand-ins").
    void standInNear(Hierarchy& h, const std::vector<uint32_t>& recv, std::vector<Link>& links,
                     HrResult& res, IterationRecord& rec) const;
    /// Replaces every link still to be opened (Link::kOpen) by its stand-in,
    /// storing the samples of those from sending clusters in h.
    void standInUnopened(Hierarchy& h, const std::vector<uint32_t>& recv, std::vector<Link>& links,
                         HrResult& res, IterationRecord& rec) const;
    /// Polynomial bases: sets the coupling matrices of h's current links,
    /// reusing those of `previous` (coupling index per link of the previous
    /// link set, keyed by receiver and sender) and computing the others.
    /// Returns the rays cast.
    struct PreviousCoupling;
    uint64_t updateCoupling(Hierarchy& h, const PreviousCoupling* previous) const;
    PreviousCoupling snapshotCoupling(const Hierarchy& h) const;

    const scene::Scene* scene_;
    const transport::Visibility* vis_;
    HrSettings s_;
    transport::FormFactorEngine engine_;
    /// Makes the links refinement asks for (hr/link_builder.h).
    LinkBuilder links_;
    double minArea_ = 0.0;
    double emittedPower_ = 1.0;
    /// The power eps is a fraction of in the current judging pass
    /// (hr.eps_power; LinkEstimate::emittedPower).
    double epsPower_ = 1.0;
    /// The refinement checks (hr/checks/registry.h), in amendment order.
    std::vector<std::unique_ptr<RefinementCheck>> checks_;
    std::vector<CheckEntry> extraChecks_;  ///< for the re-solves of hr.noise_target
    StageController* stageController_ = nullptr;
    /// The leaves' error totals of the last convergence check, which the
    /// final estimate reuses while the hierarchy is the one checked.
    LeafTotalsCache leafCache_;
    /// The limits that stop refinement early (hr/budget.h).
    std::unique_ptr<RefinementBudget> budget_;
    /// cluster.model with auto resolved (buildHierarchy).
    cluster::ClusterModel clusterModel_ = cluster::ClusterModel::None;
    double emittedRadiosity_ = 1.0;  ///< largest max-channel emission of any patch
    IterationHook hook_;
    bool progress_ = false;  ///< progress bars on stderr (solve's argument)
    Timer solveTimer_;       ///< started by solve() (hr.max_seconds)
    /// Patches the transport includes (hr.reach_rays; empty: all).
    std::vector<uint8_t> included_;
    bool outOfTime() const { return budget_->outOfTime(); }
    std::unique_ptr<cluster::ClusterLinker> linker_;       ///< made by solve() with the tree
    std::shared_ptr<LightLinks> lightLinks_;  ///< non-area lights (hr/light_links.h), per solve
    std::unique_ptr<scene::BasisSet> basis_;               ///< degree > 0
    std::unique_ptr<transport::CouplingEngine> coupling_;  ///< degree > 0
};

}  // namespace hrad::hr
