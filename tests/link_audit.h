// Per-link audit against Monte Carlo (the house habit, papers/README.md
// "Clustering accuracy"): the power one final link of a solved hierarchy
// moves by the model, against a Monte Carlo integral of what it really
// carries, A_r A_s E[B_s(y) cos cos V / (pi d^2)] over area-uniform point
// pairs of its two ends, with the solved root-patch radiosities as B_s
// (green channel). Used by the face-link and stand-in audits.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "core/rng.h"
#include "core/sampling.h"
#include "cluster/link.h"
#include "hr/link_builder.h"
#include "hr/solver.h"
#include "scene/element.h"
#include "transport/visibility.h"

namespace hrad::test {

struct LinkPower {
    double model = 0.0;   ///< what the solver's link moves (green)
    double mc = 0.0;      ///< the Monte Carlo integral of the same transfer
    double mcVar = 0.0;   ///< the variance of `mc` (its standard error squared)
    double mcOpen = 0.0;  ///< the same integral without visibility (V = 1), same pairs
};

/// An area-uniform point on node e of h (an element or a cluster's surfaces).
inline Vec3 auditPoint(const scene::Scene& s, const hr::Hierarchy& h, uint32_t e, Pcg32& rng,
                       uint32_t& patch) {
    double a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
    if (h.isCluster(e)) return h.clusterTree()->samplePoint(h.clusterIndex(e), a, b, c, patch);
    patch = h.patch(e);
    const auto& P = s.patches[patch];
    if (P.kind == scene::PatchKind::Triangle && a + b > 1) a = 1 - a, b = 1 - b;
    return scene::elementPoint(P, h.domain(e), a, b);
}

/// out.mc and out.mcVar from n samples of sum `sum` and sum of squares
/// `sum2`, each an estimate of mc / scale.
inline void setMonteCarlo(LinkPower& out, double sum, double sum2, int n, double scale) {
    const double mean = n > 0 ? sum / n : 0.0;
    out.mc = scale * mean;
    out.mcVar = n > 1 ? scale * scale * std::max(0.0, sum2 / n - mean * mean) / (n - 1) : 0.0;
}

/// The weights w of the segments `seg` that nothing blocks: their sum and sum
/// of squares; `open` (when given) receives the sum over all.
inline std::pair<double, double> unblockedSums(const transport::Visibility& vis,
                                               std::vector<transport::Segment>& seg,
                                               const std::vector<double>& w,
                                               double* open = nullptr) {
    std::vector<uint8_t> occ(seg.size());
    vis.occluded(seg.data(), seg.size(), occ.data());
    double sum = 0, sum2 = 0, all = 0;
    for (size_t j = 0; j < seg.size(); ++j) {
        all += w[j];
        if (!occ[j]) sum += w[j], sum2 += w[j] * w[j];
    }
    if (open) *open = all;
    return {sum, sum2};
}

/// The area a receiving cluster r hands a link's light to, towards unit
/// direction u (to the sender): sum A_k cos_k w_k over its surfaces, w_k the
/// openness towards u when `byOpenness` (cluster/openness.h), else 1.
inline double handedOverArea(const scene::Scene& s, const hr::HrResult& res, uint32_t r,
                             const Vec3& u, bool byOpenness) {
    const hr::Hierarchy& h = *res.hierarchy;
    const cluster::ClusterTree* t = res.clusterTree.get();
    const auto& nd = t->node(h.clusterIndex(r));
    double area = 0;
    for (uint32_t q = nd.patchBegin; q < nd.patchEnd; ++q) {
        const uint32_t p = t->patchAt(q);
        const auto& P = s.patches[p];
        double cosine = std::max(0.0, glm::dot(P.normal, u));
        double w = 1.0;
        if (byOpenness) {
            auto v = res.openness->view(p);
            w = res.openness->openness(v, res.openness->inside(v, nd.centroid, nd.radius), u,
                                       cosine);
        }
        area += P.area * cosine * w;
    }
    return area;
}

/// Link i of res's hierarchy (receiver recv[i]) audited with `pairs` point
/// pairs (seeded by i, so repeatable).
inline LinkPower auditLink(const scene::Scene& s, const transport::Visibility& vis,
                           const hr::HrResult& res, const std::vector<uint32_t>& recv, uint64_t i,
                           int pairs) {
    const hr::Hierarchy& h = *res.hierarchy;
    const hr::Link& l = h.link(i);
    const uint32_t r = recv[i], sd = l.sender, k = h.numPatches();
    const bool rc = h.isCluster(r), sc = h.isCluster(sd);
    auto point = [&](uint32_t e, Pcg32& rng, uint32_t& patch) { return auditPoint(s, h, e, rng, patch); };
    Vec3 u = h.center(sd) - h.center(r);
    u /= std::max(1e-300, glm::length(u));
    LinkPower out;
    // What the model moves. A stand-in (Link::kStandIn) sends its sampled
    // transfer (Hierarchy::standInSent, per unit receiver area): by area over
    // the receiver, or, handed over, to each surface of a receiving cluster
    // by its cosine towards the sender. Any other link into an oriented
    // cluster lights its surfaces by K cos_k w_k (w_k the openness towards
    // the sender, cluster/openness.h, for links handed over by openness; 1
    // by cosine alone) from the sender's radiosity towards them.
    const bool standIn = l.flags & hr::Link::kStandIn;
    const double recvArea =
        rc && (!standIn || !l.byArea())
            ? handedOverArea(s, res, r, u,
                             !standIn && res.openness && (l.flags & hr::Link::kOpenHandOver))
            : h.area(r);
    if (standIn)
        out.model = recvArea * h.standInSent(l).g;
    else
        out.model = l.K * recvArea * (sc ? h.directionalB(sd, -u).g : h.B(sd).g);
    Pcg32 rng(hashIds(i, 77));
    std::vector<transport::Segment> seg(static_cast<size_t>(pairs));
    std::vector<double> w(static_cast<size_t>(pairs));
    for (int j = 0; j < pairs; ++j) {
        seg[j].a = point(r, rng, seg[j].patchA);
        seg[j].b = point(sd, rng, seg[j].patchB);
        Vec3 d = seg[j].b - seg[j].a;
        double d2 = glm::dot(d, d);
        double ca = glm::dot(s.patches[seg[j].patchA].normal, d);
        double cb = -glm::dot(s.patches[seg[j].patchB].normal, d);
        w[j] = ca > 0 && cb > 0 && d2 > 0 ? ca * cb / (kPi * d2 * d2) : 0.0;
        // The sender's solved radiosity at that point (its root patch).
        w[j] *= h.B(seg[j].patchB < k ? seg[j].patchB : 0).g;
    }
    double open = 0;
    const auto [sum, sum2] = unblockedSums(vis, seg, w, &open);
    const double scale = h.area(r) * h.area(sd);
    setMonteCarlo(out, sum, sum2, pairs, scale);
    out.mcOpen = pairs > 0 ? scale * open / pairs : 0.0;
    return out;
}

/// Link i of res's hierarchy audited by gathering: `rays` receiver points by
/// area, one cosine-distributed ray each from the point's surface, whose first
/// hit counts its solved root-patch radiosity (green) when it lies on the
/// sender: power = A_r E[B(y) 1(y on the sender)] (irradiance is the
/// integral of (B / pi) cos over directions). B is bounded, so this
/// estimate's variance is finite where the pairs' cos cos / (pi d^2) has an
/// infinite one (ends that touch or overlap: the stand-ins taken by area).
/// `orderPos[p]`: patch p's position in the cluster tree's order. The model
/// is auditLink's; mcOpen is not estimated (0).
inline LinkPower auditLinkByGather(const scene::Scene& s, const transport::Visibility& vis,
                                   const hr::HrResult& res, const std::vector<uint32_t>& recv,
                                   uint64_t i, int rays, const std::vector<uint32_t>& orderPos) {
    const hr::Hierarchy& h = *res.hierarchy;
    LinkPower out = auditLink(s, vis, res, recv, i, 0);
    const uint32_t r = recv[i], sd = h.link(i).sender;
    auto onSender = [&](uint32_t q, const Vec3& y) {
        if (h.isCluster(sd)) {
            const auto& nd = h.clusterTree()->node(h.clusterIndex(sd));
            return orderPos[q] >= nd.patchBegin && orderPos[q] < nd.patchEnd;
        }
        if (q != h.patch(sd)) return false;
        const auto& Q = s.patches[q];
        const Vec2 uv = scene::clampToPatchDomain(Q.kind, scene::patchInverse(Q, y));
        return scene::keyAt(Q.kind, uv.x, uv.y, h.level(sd)) == h.key(sd);
    };
    Pcg32 rng(hashIds(i, 91));
    double sum = 0, sum2 = 0;
    for (int j = 0; j < rays; ++j) {
        uint32_t pa = 0;
        const Vec3 x = auditPoint(s, h, r, rng, pa);
        const Vec3 dir = cosineDirection(s.patches[pa].normal, rng.nextDouble(), rng.nextDouble());
        const transport::RayHit hit = vis.intersect(x, dir, 0.0, 1e300, pa);
        double b = 0.0;
        if (hit.hit && glm::dot(s.patches[hit.patch].normal, dir) < 0 && onSender(hit.patch, hit.point))
            b = h.B(hit.patch).g;
        sum += b, sum2 += b * b;
    }
    setMonteCarlo(out, sum, sum2, rays, h.area(r));
    out.mcOpen = 0.0;
    return out;
}

/// Link i audited with `pairs` point pairs whose sender points are drawn half
/// by area and half by area x solved radiosity (green; a defensive mixture,
/// Hesterberg 1995) over the sending cluster's surfaces: where a cluster
/// holds small bright surfaces (Lost Empire's lava and torches), area-uniform
/// pairs and gathered rays meet them too rarely for their sample variance to
/// be trusted (one link's gathered power moved 20x between 2^18 and 2^20
/// rays). The kernel cos cos / (pi d^2) is bounded by 1 / (pi gap^2) when the
/// ends' bounding spheres are apart, so use it there; elsewhere it is
/// auditLink. The model is auditLink's.
inline LinkPower auditLinkBySenderRadiosity(const scene::Scene& s,
                                            const transport::Visibility& vis,
                                            const hr::HrResult& res,
                                            const std::vector<uint32_t>& recv, uint64_t i,
                                            int pairs) {
    const hr::Hierarchy& h = *res.hierarchy;
    const uint32_t r = recv[i], sd = h.link(i).sender;
    if (!h.isCluster(sd)) return auditLink(s, vis, res, recv, i, pairs);
    LinkPower out = auditLink(s, vis, res, recv, i, 0);
    const cluster::ClusterTree& t = *res.clusterTree;
    const auto& nd = t.node(h.clusterIndex(sd));
    // The mixture's probability of each sender patch, as a prefix sum.
    std::vector<double> prob(nd.patchEnd - nd.patchBegin), cdf(prob.size());
    double area = 0, power = 0;
    for (uint32_t q = nd.patchBegin; q < nd.patchEnd; ++q) {
        const uint32_t k = t.patchAt(q);
        area += s.patches[k].area;
        power += s.patches[k].area * std::max(0.0, h.B(k).g);
    }
    double run = 0;
    for (uint32_t q = nd.patchBegin; q < nd.patchEnd; ++q) {
        const uint32_t k = t.patchAt(q);
        const double A = s.patches[k].area;
        const double byPower = power > 0 ? A * std::max(0.0, h.B(k).g) / power : A / area;
        prob[q - nd.patchBegin] = 0.5 * A / area + 0.5 * byPower;
        run += prob[q - nd.patchBegin];
        cdf[q - nd.patchBegin] = run;
    }
    Pcg32 rng(hashIds(i, 83));
    std::vector<transport::Segment> seg(static_cast<size_t>(pairs));
    std::vector<double> w(static_cast<size_t>(pairs), 0.0);
    for (int j = 0; j < pairs; ++j) {
        seg[j].a = auditPoint(s, h, r, rng, seg[j].patchA);
        const double u = rng.nextDouble() * run;
        const size_t m = std::min<size_t>(
            size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()), cdf.size() - 1);
        const uint32_t k = t.patchAt(nd.patchBegin + uint32_t(m));
        const double a = rng.nextDouble(), b = rng.nextDouble();
        seg[j].b = t.pointOnPatch(k, a, b);
        seg[j].patchB = k;
        const Vec3 d = seg[j].b - seg[j].a;
        const double d2 = glm::dot(d, d);
        const double ca = glm::dot(s.patches[seg[j].patchA].normal, d);
        const double cb = -glm::dot(s.patches[k].normal, d);
        // f B_k / p(y), p(y) = prob_k / A_k per unit sender area.
        if (ca > 0 && cb > 0 && d2 > 0)
            w[j] = ca * cb / (kPi * d2 * d2) * h.B(k).g * s.patches[k].area / (prob[m] / run);
    }
    const auto [sum, sum2] = unblockedSums(vis, seg, w);
    setMonteCarlo(out, sum, sum2, pairs, h.area(r));
    return out;
}

/// Stand-ins drawn afresh (cluster/stand_in.cpp): a stand-in's transfer is
/// one draw of a Monte Carlo estimator, and one solve keeps one draw per
/// link, so an audit of the estimator's bias compares its mean over
/// independent draws (the receiver's stable id, which seeds them, rehashed),
/// not the kept draw, with the Monte Carlo power wherever a link's own noise
/// is large. The sender's surfaces are weighted by the solved radiosities.
class StandInRedraw {
  public:
    StandInRedraw(const scene::Scene& s, const transport::Visibility& vis,
                  const hr::HrResult& res, const cluster::ClusterLinkSettings& settings)
        : s_(s),
          res_(res),
          linker_(s, res.clusterTree.get(), res.hierarchy->clusterModel(), &vis, settings) {
        std::vector<RGB> rootB(s.patches.size());
        for (uint32_t q = 0; q < s.patches.size(); ++q) rootB[q] = res.hierarchy->B(q);
        linker_.prepareSenders(rootB);
    }
    /// The power (green) link i's stand-in moves, over `draws` draws: `model`
    /// the mean, `modelVar` the variance of the mean.
    struct Power {
        double model = 0.0, modelVar = 0.0;
    };
    Power power(const std::vector<uint32_t>& recv, uint64_t i, int draws) const {
        const hr::Hierarchy& h = *res_.hierarchy;
        const uint32_t r = recv[i], sd = h.link(i).sender;
        Vec3 u = h.center(sd) - h.center(r);
        u /= std::max(1e-300, glm::length(u));
        double sum = 0, sum2 = 0;
        for (int d = 0; d < draws; ++d) {
            cluster::LinkEnd re = hr::LinkBuilder::endOf(h, r);
            const cluster::LinkEnd se = hr::LinkBuilder::endOf(h, sd);
            re.stableId = hashIds(re.stableId, 0x72656472ULL + uint64_t(d));
            std::vector<cluster::StandInSample> samples;
            const cluster::ClusterLink c = linker_.standIn(re, se, &samples, true);
            // What Hierarchy::standInSent moves (nothing when K is 0).
            double sent = 0.0;
            if (c.K > 0 && !h.isCluster(sd)) sent = c.K * h.B(sd).g;
            if (c.K > 0 && h.isCluster(sd))
                for (const cluster::StandInSample& x : samples) sent += x.weight * h.B(x.patch).g;
            const double area =
                h.isCluster(r) && c.byCosine ? handedOverArea(s_, res_, r, u, false) : h.area(r);
            sum += area * sent, sum2 += area * sent * area * sent;
        }
        Power p;
        p.model = sum / draws;
        p.modelVar = draws > 1 ? std::max(0.0, sum2 / draws - p.model * p.model) / (draws - 1) : 0.0;
        return p;
    }

  private:
    const scene::Scene& s_;
    const hr::HrResult& res_;
    cluster::ClusterLinker linker_;
};

}  // namespace hrad::test
