#include "cluster/oriented_model.h"

#include <algorithm>
#include <cmath>

#include "cluster/link.h"
#include "cluster/openness.h"
#include "cluster/tree.h"
#include "core/rng.h"
#include "scene/scene.h"
#include "transport/formfactor.h"
#include "transport/visibility.h"

namespace hrad::cluster {

double OrientedModel::projectedFraction(const ClusterTree& tree, uint32_t c, double area,
                                        const Vec3& d) const {
    return area > 0 ? tree.projectedArea(c, d) / area : 0.0;
}

RGB OrientedModel::sent(const ClusterTree& tree, uint32_t c, const RadiantMoments& m,
                        const RGB& meanB, const Vec3& d) const {
    double proj = tree.projectedArea(c, d);
    if (!(proj > 0)) return meanB;
    RGB out;
    for (int k = 0; k < 3; ++k) {
        const auto& M = m.m[k];
        double q = d.x * (M[0] * d.x + M[1] * d.y + M[2] * d.z) +
                   d.y * (M[1] * d.x + M[3] * d.y + M[4] * d.z) +
                   d.z * (M[2] * d.x + M[4] * d.y + M[5] * d.z);
        // sum A B max(0, n.d) = (sum A B |n.d| + sum A B n.d) / 2, the first
        // sum estimated as sqrt(sum A B * sum A B (n.d)^2) (Cauchy-Schwarz;
        // exact when |n.d| is the same for all surfaces that carry light).
        const double ab = m.ab[k];
        double p = 0.5 * (std::sqrt(std::max(0.0, ab * q)) + glm::dot(Vec3(m.s[k]), d));
        out[k] = std::clamp(p, 0.0, ab) / proj;
    }
    return out;
}

const char* OrientedModel::handOver(const ClusterLinkSettings& settings) const {
    return settings.visibleHandover ? "openness" : "none";
}

void OrientedModel::opennessSums(const scene::Scene& scene, const ClusterTree& tree,
                                 const SurfaceOpenness& openness, uint32_t c,
                                 std::span<const glm::vec3> dirs, double* num, double* den) {
    const ClusterNode& node = tree.node(c);
    for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
        const uint32_t p = tree.patchAt(q);
        const glm::vec3 n(scene.patches[p].normal);
        const double area = scene.patches[p].area;
        bool haveView = false;
        SurfaceOpenness::View view;
        SurfaceOpenness::Inside inside;
        for (size_t f = 0; f < dirs.size(); ++f) {
            const glm::vec3& dir = dirs[f];
            double cosine = glm::dot(n, dir);
            if (!(cosine > 0)) continue;
            if (!haveView) {
                view = openness.view(p);
                inside = openness.inside(view, node.centroid, node.radius);
                haveView = true;
            }
            den[f] += area * cosine;
            num[f] += area * cosine * openness.openness(view, inside, Vec3(dir), cosine);
        }
    }
}

void OrientedModel::seenWeights(const scene::Scene& scene, const ClusterTree& tree,
                                const SurfaceOpenness& openness, const transport::Visibility& vis,
                                uint64_t seed, uint32_t c, std::span<const uint32_t> begin,
                                std::span<const Source> sources, std::vector<double>& seen) {
    struct Term {
        uint32_t link;
        double w;
    };
    const ClusterNode& node = tree.node(c);
    const uint32_t count = node.patchEnd - node.patchBegin;
    const size_t links = begin.size() - 1;
    std::vector<transport::Segment> segments;
    std::vector<Term> terms;
    std::vector<uint8_t> blocked;
    seen.assign(links * size_t(count), 0.0);
    for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
        const uint32_t p = tree.patchAt(q);
        const scene::Patch& P = scene.patches[p];
        const SurfaceOpenness::View view = openness.view(p);
        // One shadow ray per receiver point and sender surface, to a point
        // stratified over the sender (a fixed 2x2 pattern, shifted per
        // pair): F(x -> j) counts where it is unblocked.
        segments.clear();
        terms.clear();
        for (size_t f = 0; f < links; ++f) {
            for (uint32_t k = begin[f]; k < begin[f + 1]; ++k) {
                const uint32_t sp = sources[k].patch;
                const scene::Patch& S = scene.patches[sp];
                if (sp == p || sp == P.twin) continue;
                Pcg32 rng(reseed(hashIds(p, sp), seed));
                const double su = rng.nextDouble(), sv = rng.nextDouble();
                for (int j = 0; j < SurfaceOpenness::kPoints; ++j) {
                    const Vec3& x = view.x[j];
                    // Only the front of a one-sided sender sends.
                    if (!(glm::dot(x - S.v[0], S.normal) > 0)) continue;
                    const double F =
                        transport::pointToPolygon(x, P.normal, S.v.data(), S.numVertices());
                    if (!(F > 0)) continue;
                    const double u1 = std::fmod(0.25 + 0.5 * (j & 1) + su, 1.0);
                    const double u2 = std::fmod(0.25 + 0.5 * (j >> 1) + sv, 1.0);
                    const Vec3 y = tree.pointOnPatch(sp, u1, u2);
                    // A point behind either surface's plane is not seen (the
                    // rest of the sender may be: F holds it, the ray only
                    // tells whether the view is blocked).
                    if (!(glm::dot(y - x, P.normal) > 0) || !(glm::dot(x - y, S.normal) > 0))
                        continue;
                    segments.push_back({x, y, p, sp});
                    terms.push_back({uint32_t(f), sources[k].weight * F});
                }
            }
        }
        blocked.resize(segments.size());
        if (!segments.empty()) vis.occluded(segments.data(), segments.size(), blocked.data());
        for (size_t i = 0; i < segments.size(); ++i)
            if (!blocked[i]) seen[terms[i].link * count + (q - node.patchBegin)] += terms[i].w;
    }
}

}  // namespace hrad::cluster
