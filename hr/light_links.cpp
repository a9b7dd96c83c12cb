// Light links of the hierarchical solve; see light_links.h.
#include "hr/light_links.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>

#include <spdlog/spdlog.h>

#include "core/rng.h"
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
    return s;
}

void LightLinks::initialLinks(const Hierarchy& h) {
    links_.clear();
    for (uint32_t l = 0; l < scene_->lights.size(); ++l)
        for (uint32_t p = 0; p < h.numPatches(); ++p)
            if (maxComponent(scene_->patches[p].rho) > 0)
                links_.push_back(LightLink{p, l, {0.f, 0.f, 0.f}});
    made_ = true;
}

LightLinks::Judged LightLinks::judge(const Hierarchy& h, const LightLink& l,
                                     const oracles::Oracle& oracle, double epsPower,
                                     double emittedRadiosity, uint64_t& rays) const {
    const uint32_t e = l.receiver;
    const scene::Patch& p = scene_->patches[h.patch(e)];
    const scene::Light& light = *scene_->lights[l.light];
    std::vector<Vec3> x;
    std::vector<double> w;
    const int n = transport::elementMeanPoints(p, h.domain(e), kSide, x, w);
    // One direction pattern per (element, light): see the header.
    const uint64_t seed = hashIds(h.stableId(e), 0x4c49474854ULL, l.light);
    Judged j;
    // Irradiance with visibility at each point, and without (the bound).
    double lo = 1e300, hi = 0.0, hiFree = 0.0, meanFree = 0.0;
    int shadowed = 0, reached = 0;
    for (int k = 0; k < n; ++k) {
        const double free = maxComponent(
            transport::lightIrradianceUnoccluded(light, x[k], p.normal, s_.strata, seed));
        if (!(free > 0)) {
            lo = 0.0;
            continue;
        }
        ++reached;
        const RGB E = transport::lightIrradiance(light, *vis_, x[k], p.normal, h.patch(e),
                                                 s_.strata, seed, rays);
        j.mean += w[k] * E;
        meanFree += w[k] * free;
        lo = std::min(lo, maxComponent(E));
        hi = std::max(hi, maxComponent(E));
        hiFree = std::max(hiFree, free);
        shadowed += maxComponent(E) < free * (1 - 1e-12) ? 1 : 0;
    }
    // As a surface link's (hr/link_estimate.cpp): the kernel range from the
    // points where all see the light, [0, unoccluded max] where a shadow
    // may cross the receiver, including receivers whose points are all in
    // shadow (a window's light can fall between them).
    const double S = std::max(hiFree, 1e-300);
    oracles::LinkEstimate est;
    est.F = maxComponent(j.mean) / S;
    est.unoccludedF = meanFree / S;
    est.Fupper = 1.0;
    est.Fmin = shadowed > 0 || reached < n ? 0.0 : lo / S;
    est.Fmax = shadowed > 0 ? 1.0 : hi / S;
    est.visibility = est.unoccludedF > 0 ? est.F / est.unoccludedF : 1.0;
    est.partialVisibility = shadowed > 0;
    est.receiverArea = h.area(e);
    est.senderArea = h.area(e);  // reverseF() = F: a light has no area
    est.senderB = RGB(hiFree);
    est.receiverRho = p.rho;
    est.emittedPower = epsPower;
    est.emittedRadiosity = emittedRadiosity;
    est.receiverLevel = h.level(e);
    est.receiverCanSubdivide = h.canSubdivide(e);
    est.senderCanSubdivide = false;
    const oracles::Decision d = oracle.decide(est);
    const bool refines = d == oracles::Decision::RefineReceiver || d == oracles::Decision::RefineBoth;
    j.decision = refines && est.receiverCanSubdivide ? oracles::Decision::RefineReceiver
                                                     : oracles::Decision::Accept;
    return j;
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
            h.subdivide(l.receiver);
            const uint32_t fc = h.firstChild(l.receiver);
            for (uint32_t c = fc; c < fc + 4; ++c) next.push_back(LightLink{c, l.light, {0, 0, 0}});
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
        h.lightGathered[l.receiver] += scene_->patches[h.patch(l.receiver)].rho * E;
    }
}

std::vector<RGB> LightLinks::irradiance(const Hierarchy& h) const {
    std::vector<RGB> out(h.numElements(), RGB(0.0));
    for (const LightLink& l : links_) out[l.receiver] += RGB(l.E[0], l.E[1], l.E[2]);
    return out;
}

}  // namespace hrad::hr
