// Making the links refinement asks for: hr/solver.cpp decides which links to
// make and keep; this file turns "a link from node s to node r" into an
// hr::Link by asking the folder that owns the link's physics (DESIGN.md,
// "Where the next capabilities go": cluster and surface link construction in
// cluster/ and transport/), and translating the answer into the 16-byte
// Link's coefficient, bound, visibility and flags.
//
//   - Surface to surface: transport::FormFactorEngine (Hanrahan, Salzman &
//     Aupperle 1991 form factors with ray-traced visibility). With
//     hr.judge_visibility = independent (the default) the oracle judges a
//     second visibility estimate drawn with other rays (salt
//     kJudgedVisibilitySalt), and the link's Fupper keeps the unoccluded form
//     factor: with one estimate the links whose estimate came out low were
//     accepted and kept it (hr/solver.h, "Judged visibility").
//   - Touching a cluster: cluster::ClusterLinker (Smits, Arvo & Greenberg
//     1994; Sillion 1995), and its stand-ins (cluster/link.h "Stand-ins",
//     "Judged stand-ins").
//
// It also counts what the links cost, per kind (HrResult::linkCost), and
// gives the oracle the bounds it may ask for (fillBounds).
#pragma once

#include <tbb/enumerable_thread_specific.h>

#include <cstdint>
#include <vector>

#include "cluster/link.h"
#include "hr/hierarchy.h"
#include "oracles/oracle.h"
#include "transport/formfactor.h"

namespace hrad::hr {

/// Link evaluations, rays and CPU seconds (summed over threads) by kind, in
/// the order surface-surface, surface <- cluster, cluster <- surface,
/// cluster-cluster. The seconds are the evaluating threads' CPU time
/// (core/cpu_time.h, not wall time), estimated from every kTimingStride-th
/// evaluation of each kind (per thread) times the stride: reading the clock
/// twice per evaluation cost 1.4 % of the bathroom's CPU.
struct LinkKindCost {
    static constexpr uint64_t kTimingStride = 8;
    uint64_t evaluations[4] = {0, 0, 0, 0};
    uint64_t rays[4] = {0, 0, 0, 0};
    double seconds[4] = {0, 0, 0, 0};
};

class LinkBuilder {
  public:
    /// `judgeVisibility`: hr.judge_visibility = independent (the judged
    /// estimate casts as many rays as the engine's ff.vis_rays).
    LinkBuilder(const transport::FormFactorEngine& engine, bool judgeVisibility)
        : engine_(&engine), judgeVisibility_(judgeVisibility) {}

    /// The cluster link physics (null: no clusters). Not owned.
    void setLinker(const cluster::ClusterLinker* linker) { linker_ = linker; }

    /// The link from s to r, its cost added to the counts (cost()).
    Link make(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays) const;

    /// A surface-to-surface link whose carried estimate found nothing but
    /// whose judged one did (hr.judge_visibility): kept, carrying 0, so that
    /// what the oracle decides does not depend on the carried estimate.
    bool keepSurfaceLink(const Link& l) const {
        return judgeVisibility_ && l.vis() > 0 && l.upperF() > 0;
    }

    /// The stand-in for a link from s to r that had to be opened (cluster/
    /// link.h "Stand-ins"; Link::kStandIn). `samples` (sending clusters)
    /// receives its samples; `judge`: it also gets an independent estimate to
    /// be judged by.
    Link standIn(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays,
                 std::vector<cluster::StandInSample>* samples, bool judge) const;
    /// Replaces links[i] for each i in `open` by its stand-in, storing the
    /// samples of those from sending clusters in h; returns the rays cast.
    /// Estimated in parallel, stored in link order: results do not depend on
    /// the threads.
    uint64_t standIns(Hierarchy& h, const std::vector<uint32_t>& recv, std::vector<Link>& links,
                      const std::vector<size_t>& open, bool judge) const;

    /// Node e as the cluster link physics sees it.
    static cluster::LinkEnd endOf(const Hierarchy& h, uint32_t e);
    /// Refinement forced by validity (self-links, single-surface clusters,
    /// clusters too close for the point approximation), independent of the
    /// oracle; Accept means "valid". make() evaluates it once and marks
    /// invalid links Link::kOpen; refinement asks it only for those.
    oracles::Decision forcedDecision(const Hierarchy& h, uint32_t r, uint32_t s) const;
    /// Fills e.Fmin / e.Fmax for link l of receiver r (only for oracles whose
    /// needsBounds() is true; the other fields of e must be set).
    void fillBounds(const Hierarchy& h, uint32_t r, const Link& l, oracles::LinkEstimate& e) const;

    /// The counts of make() since the last resetCost(), over all threads.
    LinkKindCost cost() const;
    void resetCost() { cost_.clear(); }

    /// Seeds the judged visibility rays of surface links apart from the
    /// carried ones (transport visibilityEstimate's salt).
    static constexpr uint64_t kJudgedVisibilitySalt = 0x6a7564676564ULL;

  private:
    Link evaluate(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays) const;
    Link clusterLink(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays) const;

    const transport::FormFactorEngine* engine_;
    const cluster::ClusterLinker* linker_ = nullptr;
    bool judgeVisibility_;
    mutable tbb::enumerable_thread_specific<LinkKindCost> cost_;
};

}  // namespace hrad::hr
