#include "hr/noise.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "cluster/tree.h"

namespace hrad::hr {

std::vector<float> linkRelativeErrors(const Hierarchy& h, const NoiseRays& rays) {
    std::vector<float> rel(h.numLinks(), 0.f);
    for (uint32_t r = 0; r < h.numElements(); ++r)
        for (uint64_t i = h.linkBegin(r); i < h.linkEnd(r); ++i) {
            const Link& l = h.link(i);
            if (l.sender == kNone || !(l.K > 0)) continue;
            if (l.flags & (Link::kSampled | Link::kStandIn)) {
                // Twice the relative standard error, in percent (255: at
                // least 2.55, taken as 2.55).
                rel[i] = float(l.uncertainty / 200.0);
                continue;
            }
            const bool surface = !h.isCluster(r) && !h.isCluster(l.sender);
            const int n = surface ? rays.surface : rays.cluster;
            if (n <= 0) continue;
            double v = surface ? 0.5 * (h.carriedVisibility(l) + l.vis()) : l.vis();
            if (!(v > 0.0 && v < 1.0)) continue;
            // A kernel-weighted fraction below one ray's share is taken as
            // one ray's: the binomial formula would give it a relative error
            // beyond what one ray of n makes.
            v = std::max(v, 1.0 / n);
            rel[i] = float(std::sqrt((1.0 - v) / (v * n)));
        }
    return rel;
}

SolverNoise estimateNoise(const Hierarchy& h, const NoiseRays& rays, std::vector<RGB>* light) {
    SolverNoise out;
    const std::vector<float> rel = linkRelativeErrors(h, rays);
    std::vector<RGB> reflected, patchVar;
    h.linkLight(reflected, &rel, &patchVar);

    // The share of emitted light in what each sender sends: E / B for a
    // surface element, sum A E / sum A B over the root patches below a
    // cluster (sum A E by prefix sums over the tree's patch order; a
    // cluster's B is the area average of the patches below).
    const scene::Scene& sc = h.scene();
    const cluster::ClusterTree* tree = h.clusterTree();
    std::vector<RGB> prefixE;
    if (tree) {
        prefixE.assign(size_t(tree->orderSize()) + 1, RGB(0.0));
        for (uint32_t q = 0; q < tree->orderSize(); ++q) {
            const scene::Patch& P = sc.patches[tree->patchAt(q)];
            prefixE[q + 1] = prefixE[q] + P.area * P.emission;
        }
    }
    auto emittedShare = [&](uint32_t s) {
        RGB e, b;
        if (h.isCluster(s)) {
            const cluster::ClusterNode& node = tree->node(h.clusterIndex(s));
            e = prefixE[node.patchEnd] - prefixE[node.patchBegin];
            b = h.area(s) * h.B(s);
        } else {
            e = sc.patches[h.patch(s)].emission;
            b = h.B(s);
        }
        RGB share(0.0);
        for (int c = 0; c < 3; ++c)
            if (b[c] > 0.0) share[c] = std::clamp(e[c] / b[c], 0.0, 1.0);
        return share;
    };

    RGB total(0.0), first(0.0), var(0.0);
    for (uint32_t r = 0; r < h.numElements(); ++r)
        for (uint64_t i = h.linkBegin(r); i < h.linkEnd(r); ++i) {
            const RGB& P = reflected[i];
            total += P;
            first += P * emittedShare(h.link(i).sender);
            if (rel[i] > 0.f) {
                ++out.links;
                const RGB d = P * double(rel[i]);
                var += d * d;
            }
        }
    for (int c = 0; c < 3; ++c) {
        out.direct[c] = std::sqrt(var[c]);
        out.amplification[c] = first[c] > 0.0 ? std::max(1.0, total[c] / first[c]) : 1.0;
        out.powerSd[c] = out.direct[c] * out.amplification[c];
        if (total[c] > 0.0) out.relative = std::max(out.relative, out.powerSd[c] / total[c]);
    }

    // Per root patch, the direct part (luminance, patches that do not emit).
    double num = 0.0, den = 0.0;
    for (uint32_t p = 0; p < h.numPatches(); ++p) {
        const scene::Patch& P = sc.patches[p];
        if (maxComponent(P.emission) > 0.0) continue;
        // The channels of one link move together (one draw of its rays).
        const double sd = luminance(glm::sqrt(patchVar[p]));
        const double y = luminance(h.B(p));
        num += P.area * sd * sd;
        den += P.area * y * y;
    }
    out.l2NonEmitter = den > 0.0 ? std::sqrt(num / den) : 0.0;
    if (light) *light = std::move(reflected);
    return out;
}

}  // namespace hrad::hr
