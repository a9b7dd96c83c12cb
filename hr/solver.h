// The hierarchical radiosity solver: initial linking, refinement driven by an
// oracle, gather and push-pull, repeated until converged.
//
// Hanrahan, Salzman & Aupperle 1991 ("A Rapid Hierarchical Radiosity
// Algorithm"), with the solver loop of DESIGN.md: refine all links -> gather ->
// push-pull, until no link was refined and the relative change of total
// reflected power is below `tolerance` (or `max_iterations`). An optional
// schedule of decreasing epsilon (multigridding, HSA91 section 5) runs the loop
// once per value, keeping the hierarchy between stages.
//
// Refinement is breadth-first over the whole link set: every link is given to
// the oracle; elements to subdivide are collected and subdivided serially in
// index order; links are replaced by links between the children, whose form
// factors are computed in parallel; the new links are judged in the next
// round, until no link is refined. This is HSA91's recursive Refine() unrolled
// by level, and it makes the result independent of thread scheduling: results
// are bitwise identical for any thread count.
//
// Settings (Params keys):
//   hr.oracle          string  "bfa"   refinement oracle (oracles/registry.h); its own
//                                       settings are the keys "oracle.*" (e.g. oracle.eps).
//                                       Oracles that read form-factor bounds (`error`,
//                                       `kv`: Oracle::needsBounds) cost point-to-element
//                                       form factors per link judged (linkEstimate below)
//   hr.eps_schedule    string  ""      comma-separated decreasing eps values; each stage
//                                       sets oracle.eps and runs the loop to convergence
//   hr.min_area        double  0       minimum element area (absolute); 0: min_area_rel
//   hr.min_area_rel    double  1e-5    minimum element area relative to the total scene area
//   hr.max_level       int     14      maximum quadtree depth below a root patch
//   hr.max_iterations  int     100     iteration cap per stage
//   hr.min_iterations  int     2       iterations before convergence may be declared
//   hr.tolerance       double  1e-4    stop when both the relative change of reflected
//                                       power and the estimated iteration error (below)
//                                       are below this
//   hr.iteration       string  "jacobi"  jacobi | gauss-seidel (Hierarchy::sweep): the
//                                       order in which receivers gather within an iteration
//   hr.gs_blocks       int     0       gauss-seidel: root patches per sweep are split into
//                                       this many blocks gathered one after the other
//                                       (0: one block per root patch, full Gauss-Seidel)
//   hr.max_links       int     2e8     refinement stops (with a warning) past this many links;
//                                       never past 2^32 - 1, the hierarchy's own limit
//                                       (Hierarchy::kMaxLinks: 32-bit row offsets)
//   hr.max_seconds     double  0       wall-clock limit of the solve (0: none): refinement
//                                       stops at the next round and iterating after the
//                                       current iteration; the solution so far is the
//                                       result (summary time_limit_hit, converged false)
//   memory.budget_mb   int     0       refinement stops (with a warning, and
//                                       summary memory_budget_hit) before a round after
//                                       which the process would pass this many MiB: what it
//                                       held apart from links and elements when the pass
//                                       began (resident set), plus the elements, plus the
//                                       peak of the next judging pass over the links
//                                       (HrSolver::passPeakBytes: 109 bytes per link, 48 per
//                                       kernel-sample block, 80 per element), estimated
//                                       before allocating, within 31/32 of the budget; the
//                                       solve then finishes on the coarser hierarchy.
//                                       0: 80 % of the machine's physical memory
//   ff.*                               form-factor settings (transport/formfactor.h)
//   hr.receiver_eps    auto    auto    receiver check for oracles that do not read the
//                                       receiver aggregate themselves (bfa, ff): a link the
//                                       oracle accepts is still refined on the receiver side
//                                       while its receiver's aggregate kernel error
//                                       (hr/receiver_error.h) carries more than this fraction
//                                       of the power hr.eps_power names, Phi (A_r * range >
//                                       eps * Phi), and the link carries at least an even
//                                       share of it; with
//                                       hr.sender_total, the sender side likewise (a subdivided
//                                       sender's mean, summed over its receivers: without it
//                                       the check's receiver-side refinement lost 0.9 % of the
//                                       power of a closed room at bfa 1e-4). auto: the
//                                       oracle's own eps where it is a power fraction (bfa, and
//                                       each stage of hr.eps_schedule), for ff (whose eps
//                                       is a form factor) F_eps / 100; off (or 0): the published
//                                       oracles, link by link; a number: that fraction.
//                                       Without it bfa and ff judge each link alone, and the
//                                       links a coarse receiver next to a finely linked wall
//                                       accepts add up: in the furnace (closed cube) bfa left
//                                       11 % of the reflected radiosity wrong at eps 1e-3 and
//                                       ff diverged at rho 0.9 (papers/README.md, "The receiver
//                                       check by default")
//   hr.sender_total    bool    true    error and kv also bound the sender-side error (gathering
//                                       a subdivided sender's mean) summed per sender over all
//                                       its receivers, refining the links with at least an
//                                       even share (hr/receiver_error.h SenderTotal). Without
//                                       it the constant basis stalls on the perpendicular
//                                       plates at L2 0.016 from eps 1e-5 to 1e-6 (receivers
//                                       along the emitter's bright edge each accept its mean)
//   hr.leaf_estimates  bool    true    after the solve, estimate the error of the leaves'
//                                       averages and at their points with every ancestor's
//                                       links pushed to every leaf (summary
//                                       error_estimate_leaves, error_estimate_points;
//                                       hr/receiver_error.h leafAverageError). It costs point
//                                       form factors for every (leaf, ancestor link) pair:
//                                       3.5 s of the bathroom's 60 s wall (1.1 M links), 0.2 s
//                                       of Lost Empire's 10 s; false leaves both null
//   hr.leaf_budget     string  "balanced"  balanced | true (full) | false (off): hold the
//                                       error of the leaves' averages, summed over the leaves
//                                       (every ancestor link's push to every leaf, signed, so
//                                       that a leaf's own links and its ancestors' cancel:
//                                       hr/receiver_error.h leafErrorTotals), to the receiver
//                                       check's eps of the power eps refers to (bfa, error,
//                                       kv: eps; ff: F_eps / 100), pushing the links of the
//                                       receivers with the largest parts one level down
//                                       (leafBudgetMarks). The check bounds each receiver, not
//                                       their sum: the furnace at bfa 1e-2 is 1.3 % off with it
//                                       alone. full: the sum within eps, judged in every pass
//                                       (no lazy refinement). balanced: the sum within eps
//                                       beyond the error inside the leaves (the pointwise
//                                       estimate less the averages'), judged where a stage
//                                       would converge and, after a pass that pushed links,
//                                       after the next gather; pushes aim at half the eps
//                                       beyond it. Where the exact irradiance is flat over the
//                                       leaves (the furnace) it is the full budget; where the
//                                       variation inside the leaves dominates (bfa, error, kv
//                                       in the rooms measured) it does not fire and its one
//                                       pass is the final error_estimate_leaves/_points. Off
//                                       with hr.receiver_eps = off for bfa and ff (the
//                                       published oracles). papers/README.md, "The leaf budget"
//   hr.extrapolate     bool    true    Aitken extrapolation of the gather iteration's tail
//                                       (below)
//   hr.relax_share     double  0.8     relaxation (below): after an iteration that refined
//                                       nothing, the fewest root patches that carry this share
//                                       of the change of the last two iterations are relaxed
//                                       alone when they are at most hr.relax_fraction of all
//                                       root patches; 0: off
//   hr.relax_fraction  double  0.01    the most root patches relaxed, as a fraction of all
//                                       (none in scenes of fewer than 1 / fraction patches)
//   hr.relax_sweeps    int     1000    the most Gauss-Seidel sweeps of one relaxation (and at
//                                       most as many links read as one iteration reads)
//   hr.reach_rays      int     64      rays per patch of the pass that finds the patches light
//                                       cannot reach (transport/reachability.h): inside closed
//                                       boxes, cavities between slabs, faces pressed against the
//                                       back of a wall. Non-emitting ones are left out of the
//                                       transport (no cluster holds them, no link reaches them),
//                                       so they stay dark as they physically are, instead of
//                                       receiving light that links into clusters spread over
//                                       every surface facing the sender; a patch that sees lit
//                                       surfaces through a fraction x of its hemisphere is
//                                       missed with probability (1 - x)^rays. 0: off
//   hr.reach_retry_rays int    0       rays more for every patch the first rays left
//                                       unconnected, then the search again (graz.mgf
//                                       one-sided: 64 rays alone left out 3,762 patches,
//                                       64 + 1,024 left out 1,846, 4,096 rays 1,466). Off
//                                       by default: on graz it lowers the non-emitter L2
//                                       but raises the light on patches the Monte Carlo
//                                       reference has dark (papers/README.md)
//   hr.seed            int     0       the seed of every ray the solve casts (surface
//                                       visibility, cluster links, stand-ins, the hand-over's
//                                       openness table, reachability). 0: the fixed seeding
//                                       (results repeat bit for bit); other values draw from
//                                       independent streams, so solves repeated with seeds
//                                       1..n measure the solver's own Monte Carlo noise
//                                       (tests/hr/stand_in_audit_test.cpp)
//   hr.noise_target    double  0       the solve's own noise (noise_estimate: one standard
//                                       deviation of the reflected power from its rays,
//                                       relative; hr/noise.h) to reach: a solve above it is
//                                       solved again with every ray count multiplied by up
//                                       to (noise / target)^2, at most 8x per round
//                                       (HrSolver::solve). 0: off
//   hr.noise_rounds    int     3       the re-solves hr.noise_target may make
//   hr.noise_max_factor double 64      how far it may multiply the ray counts, in all
//   hr.eps_power       string  "smaller"  smaller | emitted | reflected: the power eps is
//                                       a fraction of, for every oracle and every check the
//                                       solver adds (LinkEstimate::emittedPower), max channel.
//                                       smaller: the smaller of the emitted power and the
//                                       reflected power B - E the iteration is heading to, so
//                                       eps is at most a fraction of what the error metrics
//                                       measure; emitted: the scene's emitted power;
//                                       reflected: the reflected power so far (below, "What
//                                       eps is a fraction of")
//   hr.judge_visibility string "independent"  independent | carried: the visibility the
//                                       oracle judges a surface-to-surface link by (below,
//                                       "Judged visibility")
//   hr.refine_growth   double  0.05    lazy refinement (below): an iteration re-judges the
//                                       links only when some element's radiosity (any
//                                       channel) has grown by more than this fraction since
//                                       the last judging pass; 0: every iteration judges
//                                       every link (as Hanrahan et al. 1991)
//   hr.basis           string  "constant"  constant | linear | quadratic | cubic: the
//                                       polynomial basis on every element (scene/basis.h;
//                                       Zatz 1993, Bekaert & Willems 1996). Degree > 0: every
//                                       surface-surface link also carries its Galerkin coupling
//                                       matrix (transport/coupling.h), computed once when the
//                                       link is made; links touching a cluster exchange the
//                                       constant term only (hr/hierarchy.h). "constant" is
//                                       today's solver, bit for bit
//   hr.basis_points    int     0       quadrature points per axis on each element for the
//                                       coupling coefficients (0: degree + 2)
//   hr.basis_check     double  0.5     a link whose point-to-point rule misses the exact point
//                                       form factors by more than this (relative, weighted)
//                                       keeps only the sender's mean (transport/coupling.h)
//   hr.basis_near_levels int   1       near pairs use that rule on each of 4^k sub-elements
//                                       of both elements (transport/coupling.h); 2 for the
//                                       cubic basis, whose coupling with one level had a
//                                       higher-order mode growing 1.12x per iteration in the
//                                       furnace at rho 0.9 (the solve diverged once the
//                                       stopping rule no longer stopped it early)
//   cluster.model      string  "auto"  none | isotropic | oriented (cluster/transfer.h), or
//                                       auto: none up to 2,000 patches, oriented above (the
//                                       choice is logged and recorded in the result); with
//                                       clustering the solve starts from the root cluster's
//                                       self-link instead of linking all pairs of patches
//   cluster.partial_receivers  string  "open"  open | keep: a link into a cluster whose
//                                       visibility rays were partly (or all) blocked hands
//                                       its light to every surface of the cluster facing the
//                                       sender, seen or not; with `open` the power it may so
//                                       misplace, rho B F_unoccluded (1 - v) A, must be within
//                                       the oracle's eps share of the eps power, and so
//                                       must the sum over the links into one cluster (links
//                                       with at least an even share refined), else the
//                                       receiving cluster is opened (Oracle::receiverCheckEps:
//                                       ff's F_eps / 100; uniform has none). graz.mgf one-sided, bfa 1e-3: the
//                                       reflected power on patches Monte Carlo has dark falls
//                                       from 63 % to 42 % of the total for 0.06 % more links
//   cluster.builder, cluster.leaf_size, cluster.max_depth, cluster.faces,
//   cluster.face_cone, cluster.face_planarity, cluster.face_shape   (cluster/tree.h)
//   cluster.vis_rays, cluster.separation, cluster.surface_separation, cluster.near,
//   cluster.near_rays, cluster.face_separation, cluster.face_kernel, cluster.defer_dark,
//   cluster.ambient, cluster.handover
//                                      links that touch a cluster (cluster/link.h)
//
// Links touching a cluster are built by cluster::ClusterLinker (cluster/link.h:
// point approximation, visibility rays, validity); surface links by
// transport::FormFactorEngine. This file asks for links and judges them: the
// oracle judges a link from a cluster with the largest radiosity of the root
// patches below it (Hierarchy::maxB) and, when all its judged rays were
// blocked, with the 95 % visibility bound (linkEstimate).
//
// Stopping. A small change from one iteration to the next is not a small
// error: the error of a stationary iteration shrinks by a ratio q per
// iteration (the dominant eigenvalue of the transport operator, about the
// scene's reflectance in a closed room), so after a change d the remaining
// change is d q / (1 - q) (the geometric tail). Measured: the furnace at
// rho 0.99 without extrapolation stopped on a change below 1e-4 with its
// reflected power 1.0 % below the exact value. The solve now also requires
// the tail estimate, per channel, to be below `tolerance`, with q the ratio
// of the last two changes of a run of iterations in which nothing was
// refined or extrapolated. Where that step does not contract (q >= 1), q is
// taken over the last up to 4 steps of the run, (|d_i| / |d_{i-w}|)^(1/w),
// so that a channel whose changes shrink irregularly still has a rate
// (two-sided graz.mgf: single-step ratios crossed 1 again and again while
// the changes fell 300x in 50 iterations, and the solve ran to the
// iteration cap). It is recorded per iteration (iteration_error) and in the
// summary. Oscillating channels (last two changes of opposite sign) use the
// change itself; q >= 1 over the window (not contracting) never stops the
// solve.
//
// Judged visibility (hr.judge_visibility). A link is accepted when the
// oracle finds its estimated power below eps, and kept as it is; otherwise
// it is refined and its estimate replaced. Judged by the visibility
// estimate it also carries, the links kept are those whose estimate came
// out low: a selection bias towards darkness wherever the estimate is noisy
// (16 rays through a window's blinds, ff.vis_rays). On the bathroom,
// surface links from the window to a cabinet carried a visibility of 0.07
// where 1,024 rays give 0.78, and the solve was 6 % dark against Monte
// Carlo, its cabinets and walls most (papers/README.md, "Judged
// visibility"). As for links touching a cluster (cluster/link.h), a
// surface-to-surface link now carries K from one estimate and is judged,
// kept or dropped by a second, independent one (the same number of rays,
// another seed): the links kept then carry an unbiased estimate. Link::
// visibility holds the judged fraction and Fupper the unoccluded form factor
// (Hierarchy::unoccludedF, carriedVisibility). It costs the second set of
// rays. `carried` is the previous behaviour.
// A judged estimate whose rays were all blocked says little: the link is
// kept when its carried estimate found the sender (K > 0), and judged by 0
// it would never be refined, whatever light it carries. On Cornell a floor
// element a quarter of the floor in size kept a link from the lamp that way
// (judged 0, carried 0.12 of its unoccluded transfer, 0.55 % of the
// reflected power on one 16-ray draw). Such a link (Link::kUncertain) is
// judged like a cluster link whose rays were all blocked: with its
// unoccluded transfer times 1 - 0.05^(1/n), the 95 % upper bound of a
// fraction that none of n rays found (measured over seeds:
// bench/results/solver_noise.md, "Surface links whose judged rays were all
// blocked").
//
// What eps is a fraction of (hr.eps_power). The oracles compare a power (bfa:
// rho_r B_s F A_r; error, kv: A_r dB) with eps times a power of the scene
// (max channel). Hanrahan et al. 1991 take the emitted power. The error
// metrics measure the reflected power B - E, and where the lamps' light
// mostly leaves the scene or is absorbed that is a small part of the
// emitted (one-sided graz.mgf: about 1 %): at eps 1e-3 of the emitted power
// one link may carry a tenth of all the reflected light, and the error of
// its 8-ray visibility estimate (cluster.vis_rays) moves that much light
// (papers/README.md, "What eps is a fraction of").
//   smaller (the default): the smaller of the emitted power and the
//     reflected power the iteration is heading to, predicted from the last
//     three iterations (hr/eps_power.h). A pass judged with a power later
//     found too large is corrected by the pass the fall triggers (below);
//     one judged with a power too small would keep its extra links, which
//     is why the prediction, not the power so far, is used: after the first
//     bounces the power so far is a fraction of the final one, and judging
//     with it refines scenes that reflect as much as they emit (the furnace
//     at rho 0.5: 33 k links against 18.6 k under bfa 1e-3). Scenes that
//     reflect clearly more than they emit keep the emitted power exactly
//     (office:2, the classroom and Lost Empire, 1.5-1.6x; the furnace: the
//     same links); one that reflects about as much (the bathroom, 1.02x) is
//     judged finer in the passes whose prediction still fell short of it.
//   emitted: the emitted power.
//   reflected: the reflected power of the solution so far (the emitted
//     power before the first gather).
// Under smaller and reflected a judging pass is also triggered when the
// power has fallen by more than hr.refine_growth since the last one (a rise
// makes the accepted links safer).
//
// Lazy refinement (hr.refine_growth = g). Every oracle's test is linear in
// the sender's radiosity or does not read it: bfa's rho_r B_s F A_r, the
// error oracles' receiver and sender aggregates (sums of B_s times kernel
// ranges), the checks on sampled and partially visible cluster links, and
// the largest B below a sending cluster; ff and uniform read none. A link
// accepted in a judging pass therefore stays within (1 + g) eps as long as
// no element's radiosity has grown by more than the fraction g since that
// pass (a fall only makes it safer: links are never coarsened). So after a
// pass the solver keeps the radiosities it judged with, and an iteration
// re-judges the links only when some element, channel by channel, has grown
// by more than g since then (an element that was dark and is now lit always
// triggers a pass); otherwise it only gathers. Without it the tail of the
// iteration re-judged every link in every iteration to refine a handful
// (classroom, error oracle, 0.8 M links: 1 s per pass over the last 20 of
// 30 iterations). A new eps stage always judges. Polynomial bases judge
// every iteration: their residual tests read the senders' higher
// coefficients, whose growth the means do not bound.
//
// Iteration order (hr.iteration). Jacobi gathers every receiver from the
// previous iteration's radiosities; Gauss-Seidel (Cohen & Wallace 1993,
// section 5.3) lets each root patch gather from those the patches before it
// have just computed. Measured (papers/README.md, "Error control"): half the
// iterations on office:2 without clusters and on a uniform furnace, about
// the same with clusters, whose links still gather Jacobi-style; but the
// furnace with the error oracle refines to 4,203 links instead of 30, since
// mid-sweep radiosities are not uniform and the oracle judges them. Jacobi
// stays the default.
//
// Relaxation (hr.relax_share). A nearly closed gap between surfaces of high
// reflectance keeps its light for many bounces: the bathroom's mirror is two
// panes a few millimetres apart, both 0.99 (a perfect mirror by the Mitsuba
// loader's rule), and the light that enters at the edges alternates between
// them, a mode of the iteration of ratio about -0.99 under the room's fast
// ones. The Jacobi iteration then crawls (the bathroom ran to the 100-
// iteration cap with 1.5 % of its reflected light still to come) and the
// extrapolation below, which needs a steady one-step ratio, never applies.
// Such a mode is local: measured on the bathroom after 60 iterations, 97 %
// of the change of B (area-weighted) was on the 4 triangles of the two
// panes. So after each quiet iteration (one that refined nothing, or at most
// a ten-thousandth of the links: kQuietRefinement), the solver finds the
// fewest root patches that carry hr.relax_share of the change of the last
// two iterations (two, so that both surfaces of an alternating pair are
// found) and, when they are few (hr.relax_fraction of all root patches),
// relaxes them alone (Hierarchy::relax): Gauss-Seidel sweeps over just these
// patches, each gathering through all its links, including the links into
// the clusters above it, with everything else held, until the change still
// to come (a geometric tail with the rate over two sweeps) is a tenth of the
// tolerance, for at most as many link reads as one iteration makes
// (Hierarchy::iterationLinkReads: with oriented clusters the push reads each
// link into a cluster once per surface below it, so on the bathroom an
// iteration reads about 140 times as many links as it gathers). This is
// block relaxation of the equations with the largest residuals (Southwell
// relaxation, which progressive radiosity is; Gortler, Cohen & Slusallek
// 1994, "Radiosity and relaxation methods"): the fixed point is the solve's
// own, only the path to it changes (measured on the bathroom:
// bench/results/large_scenes.md). An iteration whose relaxation did not
// reach its target (budget) makes the run of changes the tail estimate reads
// irregular: the estimate then takes the slowest step of its window
// (hr/iteration_tail.h), and no extrapolation follows it directly.
//
// Extrapolation (hr.extrapolate). The gather iteration is a Jacobi iteration
// whose error shrinks by about the scene's largest reflectance per iteration:
// graz.mgf (rho up to 0.999) stopped at the iteration cap. Once refinement
// has stopped, the change of the reflected power from one iteration to the
// next, per channel, falls by a nearly constant ratio q (the dominant
// eigenvalue of the transport operator); the remaining change is then the
// geometric tail q/(1-q) times the last change, and every leaf is moved by
// that multiple of its own last change (Aitken's delta-squared process
// applied to the vector of leaf radiosities; the dominant-mode extrapolation
// used in power iterations, e.g. Wilkinson 1965 ch. 9). It is applied only
// when the last two iterations were quiet (as for relaxation; the leaves
// must be the same), 0 < q < 0.99999 and q
// has changed by less than 5 % since the previous iteration, and at most
// every other iteration; the following iterations correct any error, since
// the fixed point is the same.
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

struct HrResult {
    std::unique_ptr<Hierarchy> hierarchy;
    std::unique_ptr<HierarchyField> field;
    std::vector<IterationRecord> history;
    std::string oracleDescription;
    bool converged = false;
    bool linkCapHit = false;
    bool memoryBudgetHit = false;  ///< refinement stopped at memory.budget_mb
    bool timeLimitHit = false;     ///< stopped at hr.max_seconds
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
    /// cluster/openness.h), its rays and seconds.
    std::unique_ptr<cluster::SurfaceOpenness> openness;
    uint64_t opennessRays = 0;
    double opennessSeconds = 0.0;
    /// Links into oriented clusters whose hand-over was decided (when first
    /// kept; some are refined away later): by cosine and openness, and by
    /// cosine alone (no surface of the receiving cluster found open).
    uint64_t handOverByOpenness = 0, handOverByCosine = 0;
    /// Of those by openness, the ones held to their unoccluded bound
    /// (Hierarchy::handOverNewLinks).
    uint64_t handOverCapped = 0;
    std::string clusterModel;  ///< the model used (auto resolved)
    double clusterBuildSeconds = 0.0;
    /// Links by kind after the solve: surface-surface, surface receiving from a
    /// cluster, cluster receiving from a surface, cluster-cluster.
    uint64_t linksSS = 0, linksSC = 0, linksCS = 0, linksCC = 0;
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
    /// rays and CPU seconds (summed over threads) those cost, and the power
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
    std::unique_ptr<scene::BasisSet> basis_;               ///< degree > 0
    std::unique_ptr<transport::CouplingEngine> coupling_;  ///< degree > 0
};

}  // namespace hrad::hr
