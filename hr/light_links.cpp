// Light links of the hierarchical solve; see light_links.h.
#include "hr/light_links.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>

#include <spdlog/spdlog.h>

#include "core/rng.h"
#include "cluster/tree.h"
#include "scene/element.h"
#include "transport/light_irradiance.h"

namespace hrad::hr {

namespace {
constexpr int kSide = 3;  ///< 3 x 3 points (light_links.h)
}  // namespace

LightLinkSettings LightLinkSettings::fromParams(const Params& p) {
    LightLinkSettings s;
    s.strata = int(p.getInt({"hr.light_strata",
                             "environment lights: k for k x k stratified cosine directions per "
                             "point of a light link (hr/light_links.h)"},
                            s.strata, 1, 256));
    s.clusters = p.getBool({"hr.light_clusters",
                            "light links start at the root cluster and may end at clusters, "
                            "which hand their mean irradiance to their surfaces alike "
                            "(hr/light_links.h)"},
                           s.clusters);
    return s;
}

void LightLinks::initialLinks(const Hierarchy& h) {
    links_.clear();
    const bool fromRoot = s_.clusters && h.numClusters() > 0;
    for (uint32_t l = 0; l < scene_->lights.size(); ++l) {
        if (fromRoot) {
            links_.push_back(LightLink{h.rootCluster(), l, {0.f, 0.f, 0.f}});
            continue;
        }
        for (uint32_t p = 0; p < h.numPatches(); ++p)
            if (maxComponent(scene_->patches[p].rho) > 0)
                links_.push_back(LightLink{p, l, {0.f, 0.f, 0.f}});
    }
    made_ = true;
}

template <class F>
void LightLinks::forEachPatch(const Hierarchy& h, uint32_t receiver, F&& f) const {
    if (!h.isCluster(receiver)) return;
    const cluster::ClusterTree& tree = *h.clusterTree();
    const cluster::ClusterNode& node = tree.node(h.clusterIndex(receiver));
    for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) f(tree.patchAt(q));
}

LightLinks::Points LightLinks::surfacePoints(const Hierarchy& h, const LightLink& l,
                                             uint64_t& rays) const {
    const uint32_t e = l.receiver;
    const scene::Patch& p = scene_->patches[h.patch(e)];
    const scene::Light& light = *scene_->lights[l.light];
    std::vector<Vec3> x;
    std::vector<double> w;
    Points pt;
    pt.n = transport::elementMeanPoints(p, h.domain(e), kSide, x, w);
    // One direction pattern per (element, light): see the header.
    const uint64_t seed = hashIds(h.stableId(e), 0x4c49474854ULL, l.light);
    // Irradiance with visibility at each point, and without (the bound).
    for (int k = 0; k < pt.n; ++k) {
        const double free = maxComponent(
            transport::lightIrradianceUnoccluded(light, x[k], p.normal, s_.strata, seed));
        if (!(free > 0)) {
            pt.lo = 0.0;
            continue;
        }
        ++pt.reached;
        const RGB E = transport::lightIrradiance(light, *vis_, x[k], p.normal, h.patch(e),
                                                 s_.strata, seed, rays);
        pt.mean += w[k] * E;
        pt.meanFree += w[k] * free;
        pt.lo = std::min(pt.lo, maxComponent(E));
        pt.hi = std::max(pt.hi, maxComponent(E));
        pt.hiFree = std::max(pt.hiFree, free);
        pt.shadowed += maxComponent(E) < free * (1 - 1e-12) ? 1 : 0;
    }
    return pt;
}

LightLinks::Points LightLinks::clusterPoints(const Hierarchy& h, const LightLink& l,
                                             uint64_t& rays) const {
    const scene::Light& light = *scene_->lights[l.light];
    const uint64_t seed = hashIds(h.stableId(l.receiver), 0x4c49474854ULL, l.light);
    Points pt;
    RGB num(0.0), den(0.0);
    double area = 0;
    std::vector<Vec3> x;
    std::vector<double> w;
    forEachPatch(h, l.receiver, [&](uint32_t q) {
        const scene::Patch& p = scene_->patches[q];
        if (!(maxComponent(p.rho) > 0)) return;
        ++pt.n;
        area += p.area;
        den += p.area * p.rho;
        transport::elementMeanPoints(p, h.domain(q), 1, x, w);  // the centroid
        const double free = maxComponent(
            transport::lightIrradianceUnoccluded(light, x[0], p.normal, s_.strata, seed));
        if (!(free > 0)) {
            pt.lo = 0.0;
            return;
        }
        ++pt.reached;
        const RGB E =
            transport::lightIrradiance(light, *vis_, x[0], p.normal, q, s_.strata, seed, rays);
        num += p.area * p.rho * E;
        pt.meanFree += p.area * free;
        pt.lo = std::min(pt.lo, maxComponent(E));
        pt.hi = std::max(pt.hi, maxComponent(E));
        pt.hiFree = std::max(pt.hiFree, free);
        pt.shadowed += maxComponent(E) < free * (1 - 1e-12) ? 1 : 0;
    });
    for (int c = 0; c < 3; ++c) pt.mean[c] = den[c] > 0 ? num[c] / den[c] : 0.0;
    pt.meanFree = area > 0 ? pt.meanFree / area : 0.0;
    return pt;
}

LightLinks::Judged LightLinks::judge(const Hierarchy& h, const LightLink& l,
                                     const oracles::Oracle& oracle, double epsPower,
                                     double emittedRadiosity, uint64_t& rays) const {
    const uint32_t e = l.receiver;
    const bool cluster = h.isCluster(e);
    const Points pt = cluster ? clusterPoints(h, l, rays) : surfacePoints(h, l, rays);
    Judged j;
    j.mean = pt.mean;
    // As a surface link's (hr/link_estimate.cpp): the kernel range from the
    // points where all see the light, [0, unoccluded max] where a shadow
    // may cross the receiver, including receivers whose points are all in
    // shadow (a window's light can fall between them).
    const double S = std::max(pt.hiFree, 1e-300);
    oracles::LinkEstimate est;
    est.F = maxComponent(j.mean) / S;
    est.unoccludedF = pt.meanFree / S;
    est.Fupper = 1.0;
    est.Fmin = pt.shadowed > 0 || pt.reached < pt.n ? 0.0 : pt.lo / S;
    est.Fmax = pt.shadowed > 0 ? 1.0 : pt.hi / S;
    est.visibility = est.unoccludedF > 0 ? est.F / est.unoccludedF : 1.0;
    est.partialVisibility = pt.shadowed > 0;
    est.receiverArea = h.area(e);
    est.senderArea = h.area(e);  // reverseF() = F: a light has no area
    est.senderB = RGB(pt.hiFree);
    est.receiverRho = h.rho(e);
    est.emittedPower = epsPower;
    est.emittedRadiosity = emittedRadiosity;
    est.receiverLevel = h.level(e);
    est.receiverCanSubdivide = h.canSubdivide(e);
    est.senderCanSubdivide = false;
    const oracles::Decision d = oracle.decide(est);
    // A cluster hands its mean to its surfaces alike: kept only where every
    // surface faces the light and no shadow crosses it (the header).
    const bool mixed = cluster && (pt.shadowed > 0 || pt.reached < pt.n);
    const bool refines =
        mixed || d == oracles::Decision::RefineReceiver || d == oracles::Decision::RefineBoth;
    j.decision = refines && est.receiverCanSubdivide ? oracles::Decision::RefineReceiver
                                                     : oracles::Decision::Accept;
    return j;
}

void LightLinks::linkChildren(Hierarchy& h, const LightLink& l,
                              std::vector<LightLink>& next) const {
    if (!h.isCluster(l.receiver)) {
        h.subdivide(l.receiver);
        const uint32_t fc = h.firstChild(l.receiver);
        for (uint32_t c = fc; c < fc + 4; ++c) next.push_back(LightLink{c, l.light, {0, 0, 0}});
        return;
    }
    for (uint32_t i = 0; i < h.numChildren(l.receiver); ++i) {
        const uint32_t c = h.child(l.receiver, i);
        if (maxComponent(h.rho(c)) > 0) next.push_back(LightLink{c, l.light, {0, 0, 0}});
    }
}

uint64_t LightLinks::refine(Hierarchy& h, const oracles::Oracle& oracle, double epsPower,
                            double emittedRadiosity) {
    if (scene_->lights.empty()) return 0;
    if (!made_) initialLinks(h);
    std::vector<LightLink> pending = std::move(links_), accepted;
    links_.clear();
    uint64_t refined = 0;
    // Breadth-first rounds: judge in parallel, subdivide serially (not thread-safe).
    while (!pending.empty()) {
        std::vector<Judged> judged(pending.size());
        std::atomic<uint64_t> rays{0};
        tbb::parallel_for(tbb::blocked_range<size_t>(0, pending.size(), 64), [&](const auto& r) {
            uint64_t local = 0;
            for (size_t i = r.begin(); i != r.end(); ++i)
                judged[i] = judge(h, pending[i], oracle, epsPower, emittedRadiosity, local);
            rays += local;
        });
        rays_ += rays;
        std::vector<LightLink> next;
        for (size_t i = 0; i < pending.size(); ++i) {
            LightLink l = pending[i];
            if (judged[i].decision == oracles::Decision::Accept) {
                for (int c = 0; c < 3; ++c) l.E[c] = float(judged[i].mean[c]);
                accepted.push_back(l);
                continue;
            }
            ++refined;
            linkChildren(h, l, next);
        }
        pending = std::move(next);
    }
    links_ = std::move(accepted);
    apply(h);
    spdlog::info("light links: {} lights, {} links ({} refined), {} rays", scene_->lights.size(),
                 links_.size(), refined, rays_);
    return refined;
}

void LightLinks::apply(Hierarchy& h) const {
    h.lightGathered.assign(h.numElements(), RGB(0.0));
    for (const LightLink& l : links_) {
        const RGB E(l.E[0], l.E[1], l.E[2]);
        if (!h.isCluster(l.receiver)) {
            // In gathered_'s units: rho E, or E on a textured patch whose
            // leaves apply their own rho (Hierarchy::gatherReflectance).
            h.lightGathered[l.receiver] += h.gatherReflectance(l.receiver) * E;
            continue;
        }
        // A cluster's mean to every root patch below it (node q = patch q).
        forEachPatch(h, l.receiver,
                     [&](uint32_t q) { h.lightGathered[q] += h.gatherReflectance(q) * E; });
    }
}

std::vector<RGB> LightLinks::irradiance(const Hierarchy& h) const {
    std::vector<RGB> out(h.numElements(), RGB(0.0));
    for (const LightLink& l : links_) {
        const RGB E(l.E[0], l.E[1], l.E[2]);
        if (!h.isCluster(l.receiver))
            out[l.receiver] += E;
        else
            forEachPatch(h, l.receiver, [&](uint32_t q) { out[q] += E; });
    }
    return out;
}

}  // namespace hrad::hr
