#include "hr/link_builder.h"

#include "core/cpu_time.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>

namespace hrad::hr {

using oracles::Decision;

cluster::LinkEnd LinkBuilder::endOf(const Hierarchy& h, uint32_t e) {
    cluster::LinkEnd x;
    x.isCluster = h.isCluster(e);
    if (x.isCluster) {
        x.cluster = h.clusterIndex(e);
        x.singleSurface = h.numChildren(e) == 1 && !h.isCluster(h.child(e, 0));
        x.maxB = maxComponent(h.maxB(e));
    } else {
        x.patch = h.patch(e);
        x.domain = h.domain(e);
    }
    x.center = h.center(e);
    x.radius = h.radius(e);
    x.area = h.area(e);
    x.stableId = h.stableId(e);
    return x;
}

Decision LinkBuilder::forcedDecision(const Hierarchy& h, uint32_t r, uint32_t s) const {
    if (r == s) return Decision::RefineBoth;  // a cluster's self-link must be opened
    switch (linker_->opening(endOf(h, r), endOf(h, s))) {
        case cluster::Opening::None:
            return Decision::Accept;
        case cluster::Opening::Receiver:
            return Decision::RefineReceiver;
        case cluster::Opening::Sender:
            return Decision::RefineSender;
        case cluster::Opening::Both:
            return Decision::RefineBoth;
    }
    return Decision::RefineBoth;
}

Link LinkBuilder::clusterLink(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays) const {
    cluster::LinkEnd se = endOf(h, s);
    if (se.isCluster && linker_->settings().sampleNear) {
        // What the gather will multiply K by (gatherRow): the sender's
        // radiosity towards the receiver's centre (a sampled near link is
        // calibrated to it, cluster/link.h).
        Vec3 d = h.center(r) - h.center(s);
        double len = glm::length(d);
        RGB b = (len > 0 ? h.directionalB(s, d / len) : h.B(s)) + h.rho(s) * linker_->ambient();
        se.sent = (b.r + b.g + b.b) / 3.0;
    }
    cluster::ClusterLink c = linker_->link(endOf(h, r), se, h.allB());
    Link l;
    l.sender = s;
    rays = c.rays;
    if (c.open != cluster::Opening::None) {
        // Not valid in the point approximation: nothing computed, opened
        // next round (refinement asks forcedDecision which side).
        l.flags = Link::kOpen;
        return l;
    }
    if (c.deferred) {
        l.flags = Link::kDeferred;
        l.setVis(1.0);
        return l;
    }
    if (!(c.K > 0) && !c.partial && !c.uncertain && c.rays == 0) return l;
    if (c.partial) l.flags |= Link::kPartial;
    if (c.uncertain) l.flags |= Link::kUncertain;
    l.K = float(c.K);
    l.setUpperF(std::min(c.Fupper, 3.0e38));
    l.setVis(c.judged);
    if (c.sampled) {
        l.flags |= Link::kSampled;
        l.setJudgedF(c.judgedF);
        l.uncertainty = uint8_t(std::min(255.0, std::ceil(100.0 * c.relativeError)));
    }
    return l;
}

Link LinkBuilder::standIn(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays,
                          std::vector<cluster::StandInSample>* samples, bool judge) const {
    cluster::ClusterLink c = linker_->standIn(endOf(h, r), endOf(h, s), samples, judge);
    rays = c.rays;
    Link l;
    l.sender = s;
    // A stand-in whose carried estimate found nothing carries nothing (K =
    // 0, no samples) but is judged, and handed over, like the others: what
    // decides whether a stand-in stays must not depend on its carried
    // estimate (cluster/link.h "Judged stand-ins").
    if (!(c.K > 0) && samples) samples->clear();
    l.flags = Link::kSampled | Link::kStandIn;
    if (c.byCosine) l.flags |= Link::kHandedOver;  // by cosine, not by area (Link::kStandIn)
    if (c.partial) l.flags |= Link::kPartial;
    if (c.uncertain) l.flags |= Link::kUncertain;
    l.K = float(c.K > 0 ? c.K : 0.0);
    // The judged F; from a sending cluster it moves into the stand-in's
    // sample block and its index takes its place (standIns).
    l.setJudgedF(c.judgedF);
    l.setVis(c.judged);
    l.uncertainty = uint8_t(std::min(255.0, std::ceil(100.0 * c.relativeError)));
    return l;
}

uint64_t LinkBuilder::standIns(Hierarchy& h, const std::vector<uint32_t>& recv,
                               std::vector<Link>& links, const std::vector<size_t>& open,
                               bool judge) const {
    std::vector<std::vector<cluster::StandInSample>> samples(open.size());
    std::atomic<uint64_t> rays{0};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, open.size(), 256), [&](const auto& range) {
        uint64_t localRays = 0;
        for (size_t j = range.begin(); j != range.end(); ++j) {
            const size_t i = open[j];
            const uint32_t s = links[i].sender;
            uint32_t nr = 0;
            links[i] = standIn(h, recv[i], s, nr, h.isCluster(s) ? &samples[j] : nullptr, judge);
            localRays += nr;
        }
        rays += localRays;
    });
    for (size_t j = 0; j < open.size(); ++j) {
        Link& l = links[open[j]];
        if (!(l.flags & Link::kStandIn) || !h.isCluster(l.sender)) continue;
        l.setSampleBlock(h.addStandIn(samples[j], l.judgedF()));
        std::vector<cluster::StandInSample>().swap(samples[j]);
    }
    return rays.load();
}

void LinkBuilder::fillBounds(const Hierarchy& h, uint32_t r, const Link& l,
                             oracles::LinkEstimate& e) const {
    if (l.flags & Link::kSampled) {
        // The sampled transfer's error bound (twice its standard error).
        double rel = l.uncertainty / 100.0;
        e.Fmin = std::max(0.0, e.F * (1.0 - rel));
        e.Fmax = e.F * (1.0 + rel);
        return;
    }
    if (e.receiverIsCluster || e.senderIsCluster) {
        // The point approximation of a cluster transfer has no receiver
        // points: use the widest interval the link knows, [0, upper bound].
        e.Fmin = 0.0;
        e.Fmax = std::max(e.F, double(l.upperF()));
        return;
    }
    uint32_t s = l.sender;
    transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
    transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
    // The same receiver points as the link's form factor (no rays: visibility
    // is the link's). F is their weighted mean, so [min, max] contains it up
    // to the float rounding of Link::K; the max/min with F keep it contained.
    transport::PointRange pr = engine_->pointRange(er, es);
    e.Fmax = std::max(pr.max, e.F);
    // Partial visibility: some receiver points may see none of the sender;
    // with only a visibility fraction known, 0 is the conservative lower bound.
    e.Fmin = e.partialVisibility ? 0.0 : std::min(pr.min, e.F);
}

Link LinkBuilder::make(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays) const {
    const int kind = (h.isCluster(r) ? 2 : 0) + (h.isCluster(s) ? 1 : 0);  // SS, SC, CS, CC
    LinkKindCost& c = cost_.local();
    // Timed once per stride (LinkKindCost).
    const bool timed = c.evaluations[kind]++ % LinkKindCost::kTimingStride == 0;
    // The thread's CPU clock (core/cpu_time.h): the wall clock counted the
    // time the thread waited for a core (issue 63).
    const double t0 = timed ? threadCpuSeconds() : 0.0;
    Link l = evaluate(h, r, s, rays);
    c.rays[kind] += rays;
    if (timed) c.seconds[kind] += double(LinkKindCost::kTimingStride) * (threadCpuSeconds() - t0);
    return l;
}

LinkKindCost LinkBuilder::cost() const {
    LinkKindCost sum;
    for (const LinkKindCost& c : cost_)
        for (int k = 0; k < 4; ++k) {
            sum.evaluations[k] += c.evaluations[k];
            sum.rays[k] += c.rays[k];
            sum.seconds[k] += c.seconds[k];
        }
    return sum;
}

Link LinkBuilder::evaluate(const Hierarchy& h, uint32_t r, uint32_t s, uint32_t& rays) const {
    if (h.isCluster(r) || h.isCluster(s)) return clusterLink(h, r, s, rays);
    transport::ElementRef er{h.patch(r), h.domain(r), h.stableId(r)};
    transport::ElementRef es{h.patch(s), h.domain(s), h.stableId(s)};
    Link l;
    l.sender = s;
    rays = 0;
    if (!engine_->facing(er, es)) return l;
    transport::FormFactorResult f = engine_->compute(er, es);
    rays = f.rays;
    l.K = float(f.F);
    if (judgeVisibility_) {
        // The oracle judges an independent visibility estimate (hr/solver.h,
        // "Judged visibility"); Fupper keeps the unoccluded form factor.
        l.setUpperF(f.unoccludedF);
        bool partial = false;
        uint32_t cast = 0;
        const double judged =
            f.rays > 0 ? engine_->visibilityFraction(er, es, engine_->settings().visRays, &cast,
                                                     kJudgedVisibilitySalt, &partial)
                       : f.visibility;
        rays += cast;
        l.setVis(judged);
        if (partial) l.flags |= Link::kPartial;
        // Every judged ray blocked while the carried ones found the sender:
        // judged with a bound, not with 0 (hr/solver.h, "Judged visibility").
        if (f.rays > 0 && judged == 0.0 && f.F > 0.0) l.flags |= Link::kUncertain;
        return l;
    }
    l.setUpperF(std::max(engine_->upperBound(er, es), f.unoccludedF));
    l.setVis(f.visibility);
    if (f.partial) l.flags |= Link::kPartial;
    return l;
}

}  // namespace hrad::hr
