// The estimates refinement judges by: the LinkEstimate of one link for the
// oracle (HrSolver::linkEstimate), the kernel samples of the receiver
// aggregates (hr/receiver_error.h), and the a posteriori error estimate of
// a solution (HrSolver::estimateError).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

#include "hr/solver.h"

namespace hrad::hr {

namespace {
/// Largest rho_r |B_c - B_s| (max channel) over the children of a subdivided
/// surface sender s; 0 for a leaf or a cluster (LinkEstimate::senderSpread).
double senderSpread(const Hierarchy& h, uint32_t r, uint32_t s) {
    if (h.isCluster(s) || h.firstChild(s) == kNone) return 0.0;
    double spread = 0.0;
    for (uint32_t c = 0; c < h.numChildren(s); ++c)
        spread = std::max(spread, maxComponent(h.rho(r) * glm::abs(h.B(h.child(s, c)) - h.B(s))));
    return spread;
}
}  // namespace

/// The transfer the oracle judges link l by: F, the visibility, the
/// unoccluded F and its bound, for surface links (judged visibility),
/// sampled near pairs and links touching a cluster. Fills `ends` for a
/// cluster link that is not sampled.
void HrSolver::judgedTransfer(const Hierarchy& h, uint32_t r, const Link& l, bool upper,
                              oracles::LinkEstimate& e, LinkEnds& ends) const {
    const uint32_t s = l.sender;
    e.F = l.K;
    double v = l.vis();
    e.visibility = v;
    e.unoccludedF = v > 0 ? l.K / v : l.K;
    e.Fupper = l.upperF();
    if (s_.judgeVisibility && !h.isCluster(r) && !h.isCluster(s)) {
        // Judged visibility (header): F from the independent estimate; the
        // link keeps the unoccluded F in Fupper, the bound is made here when
        // the oracle reads it.
        e.unoccludedF = l.upperF();
        if (l.flags & Link::kUncertain)
            e.visibility = cluster::ClusterLinker::blockedVisibilityBound(s_.ff.visRays);
        e.F = e.unoccludedF * e.visibility;
        e.Fupper = e.unoccludedF;
        if (upper) {
            transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
            transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
            e.Fupper = std::max(engine_.upperBound(er, es), e.unoccludedF);
        }
    }
    e.partialVisibility = (l.flags & (Link::kPartial | Link::kUncertain)) != 0;
    if (l.flags & Link::kSampled) {
        // A near cluster pair estimated by sampling (cluster/link.h): the
        // judged estimate, receiver factor included, and its error bound (a
        // stand-in's is Hierarchy::standInJudged: it may hold a
        // sample block).
        e.F = (l.flags & Link::kStandIn) ? h.standInJudged(l) : double(l.judgedF());
        e.unoccludedF = v > 0 ? e.F / v : e.F;
        e.Fupper = e.F * (1.0 + l.uncertainty / 100.0);
        e.partialVisibility = (l.flags & (Link::kPartial | Link::kUncertain)) != 0;
    } else if (h.isCluster(r) || h.isCluster(s)) {
        // A link touching a cluster is judged with its own visibility
        // estimate (Link::visibility), independent of the one in K
        // (LinkBuilder::make), times the unoccluded point approximation.
        ends = {links_.endOf(h, r), links_.endOf(h, s)};
        e.unoccludedF = linker_->kernel(ends.first, ends.second);
        if (l.flags & Link::kUncertain) {
            // All judged rays blocked: the oracle sees the unoccluded
            // transfer times the 95 % upper bound of the visibility, so the
            // link is refined (clusters opened) where that much light could
            // matter, and accepted (carrying what K carries) where not.
            e.visibility = linker_->blockedVisibilityBound();
            e.partialVisibility = true;
        }
        e.F = e.visibility * e.unoccludedF;
    }
}

/// A link into an oriented cluster stores K without the receiver's
/// projected-area fraction (applied per surface when pushing): the oracle
/// judges it with the fraction towards the sender.
void HrSolver::receiverFraction(const Hierarchy& h, const LinkEnds& ends,
                                oracles::LinkEstimate& e) const {
    if (h.transferModel().receivesByCosine()) {
        const cluster::LinkEnd& re = ends.first;
        Vec3 u = ends.second.center - re.center;
        double len = glm::length(u);
        double g = len > 0 ? linker_->projectedFraction(re, u / len) : 1.0;
        e.F *= g;
        e.unoccludedF *= g;
    }
}

oracles::LinkEstimate HrSolver::linkEstimate(const Hierarchy& h, uint32_t r, const Link& l,
                                             bool bounds, bool upper) const {
    const uint32_t s = l.sender;
    oracles::LinkEstimate e;
    // The two ends of a cluster link, made once (endOf is not cheap).
    LinkEnds ends;
    judgedTransfer(h, r, l, upper, e, ends);
    e.receiverArea = h.area(r);
    e.senderArea = h.area(s);
    // A cluster's mean radiosity hides its brightest surfaces: a cluster
    // holding a luminaire and the ceiling around it has a mean B several
    // times below the luminaire's, and its point-approximation transfer
    // (centroid distance, visibility of area-sampled points) misjudges the
    // luminaire's light most: judged with the mean B such links were
    // accepted and lost light (papers/notes/2026-11-29-receiver-error.md).
    // The oracle sees the largest radiosity of the root
    // patches below a sender cluster (a bound on what any of its surfaces
    // sends, in the spirit of the B_max of error-bounded refinement,
    // Lischinski et al. 1994), so bright clusters are opened until their
    // emitters are linked as surfaces. Gather still uses directionalB().
    e.senderB = h.isCluster(s) ? h.maxB(s) : h.B(s);
    e.receiverRho = h.rho(r);
    e.senderSpread = senderSpread(h, r, s);
    e.receiverIsCluster = h.isCluster(r);
    e.senderIsCluster = h.isCluster(s);
    if (e.receiverIsCluster && !(l.flags & Link::kSampled)) receiverFraction(h, ends, e);
    e.emittedPower = epsPower_;
    e.emittedRadiosity = emittedRadiosity_;
    e.receiverLevel = h.level(r);
    e.senderLevel = h.level(s);
    // The limits of Hierarchy::setSubdivisionLimits (solve).
    e.receiverCanSubdivide = h.canSubdivide(r);
    e.senderCanSubdivide = h.canSubdivide(s);
    if (bounds) links_.fillBounds(h, r, l, e);
    return e;
}


KernelSamples HrSolver::linkSamples(const Hierarchy& h, uint32_t r, uint32_t s) const {
    // A polynomial receiver misses only what its projection misses.
    return coupling_ ? linkResidualSamples(h, *coupling_, r, s)
                     : linkKernelSamples(h, engine_, r, s);
}

std::vector<KernelSamples> HrSolver::computeKernelSamples(const Hierarchy& h,
                                                          const std::vector<uint32_t>& recv,
                                                          const std::vector<Link>& links) const {
    // Compact: one entry per link that carries samples, in link order.
    std::vector<uint64_t> at(links.size() + 1, 0);
    for (size_t i = 0; i < links.size(); ++i)
        at[i + 1] = at[i] + (h.storesKernelSamples(recv[i], links[i]) ? 1 : 0);
    std::vector<KernelSamples> out(at.back(), KernelSamples{});
    tbb::parallel_for(tbb::blocked_range<size_t>(0, links.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i)
            if (at[i + 1] > at[i]) out[at[i]] = linkSamples(h, recv[i], links[i].sender);
    });
    return out;
}

double HrSolver::estimateError(const Hierarchy& h, const std::vector<uint32_t>& recv) const {
    const std::vector<Link>& links = h.links();
    // The cached samples where h holds them (made with the links), the
    // others computed receiver by receiver (those of receivers that cannot
    // subdivide, or all of them for an oracle that did not ask for them).
    const std::vector<KernelSamples> none;
    const std::vector<KernelSamples>& samples = h.hasKernelSamples() ? h.kernelSamples() : none;
    std::vector<ReceiverError> err;
    receiverErrors(h, recv, links, samples, {}, {}, {}, err, coupling_ != nullptr,
                   [&](uint32_t r, uint32_t s) { return linkSamples(h, r, s); });
    double sum = 0.0;
    uint32_t last = kNone;
    // err holds the links that carry samples, in link order.
    size_t k = 0;
    for (size_t i = 0; i < links.size(); ++i) {
        uint32_t r = recv[i];
        const bool carries = h.carriesKernelSamples(r, links[i]);
        const size_t si = carries ? k++ : 0;
        if (h.isCluster(r)) continue;
        if (carries && err[si].range >= 0.0f && r != last) {
            sum += h.area(r) * double(err[si].range) / 4.0;
            last = r;
        }
        sum += h.area(r) * double(links[i].K) * senderSpread(h, r, links[i].sender) / 2.0;
    }
    double reflected = maxComponent(h.reflectedPower());
    return reflected > 0 ? sum / reflected : 0.0;
}

}  // namespace hrad::hr
