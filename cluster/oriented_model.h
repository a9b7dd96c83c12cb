// cluster.model = oriented (Smits, Arvo & Greenberg 1994, "A clustering
// algorithm for radiosity in complex environments", sec. 4).
//
//   projected area  sum_k A_k max(0, n_k . d) over the surfaces below
//                   (ClusterTree::projectedArea), so g = that / A;
//   sending         the radiosity of the surfaces facing the receiver,
//                   weighted by A_k cos_k (sent(), from the cluster's radiant
//                   moments: RadiantMoments);
//   receiving       ByCosine: K leaves the receiver's g out, and the push
//                   hands each link's irradiance to every surface below with
//                   its own cosine towards the sender;
//   hand-over       (cluster.handover = visible) times each surface's
//                   openness towards the sender within the cluster
//                   (cluster/openness.h; opennessSums() gives the W that the
//                   link's K is divided by), and stand-ins that no direction
//                   hands over by what each surface sees of the sender
//                   (seenWeights(), cluster.stand_in_handover = seen).
//
// The hierarchy (hr/) keeps the links and their flags, and the hand-over
// that handOver() names (hr/openness_handover.h) applies the sums over a
// cluster's surfaces that are here. Measurements:
// papers/notes/2026-12-01-cluster-transfer.md.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "cluster/transfer_model.h"
#include "core/types.h"

namespace hrad::scene {
struct Scene;
}
namespace hrad::transport {
class Visibility;
}

namespace hrad::cluster {

class SurfaceOpenness;

class OrientedModel final : public TransferModel {
  public:
    const char* name() const override { return "oriented"; }
    double projectedFraction(const ClusterTree& tree, uint32_t c, double area,
                             const Vec3& d) const override;
    double maxProjectedFraction() const override { return 1.0; }
    Receive receives() const override { return Receive::ByCosine; }
    bool sendsByDirection() const override { return true; }
    /// "openness" when cluster.handover = visible, else "none" (by cosine).
    const char* handOver(const ClusterLinkSettings& settings) const override;
    RGB sent(const ClusterTree& tree, uint32_t c, const RadiantMoments& m, const RGB& meanB,
             const Vec3& d) const override;

    /// The openness hand-over of links into cluster c: for each direction
    /// dirs[f] (receiver to sender), num[f] += sum_k A_k cos_k w_k and
    /// den[f] += sum_k A_k cos_k over the surfaces k below c that face it
    /// (cos_k > 0), w_k the openness (cluster/openness.h). W = num / den.
    static void opennessSums(const scene::Scene& scene, const ClusterTree& tree,
                             const SurfaceOpenness& openness, uint32_t c,
                             std::span<const glm::vec3> dirs, double* num, double* den);

    /// A sending surface of a stand-in, weighted by the light it sends.
    struct Source {
        uint32_t patch;
        double weight;
    };
    /// Stand-ins into cluster c handed over by what each surface sees: for
    /// link f, whose sources are sources[begin[f] .. begin[f + 1]),
    /// seen[f * count + k] (count the surfaces below c, k in tree order)
    /// receives sum_j weight_j sum_x F(x -> j) v(x, j) over k's openness
    /// points x (hr/openness_handover.h).
    static void seenWeights(const scene::Scene& scene, const ClusterTree& tree,
                            const SurfaceOpenness& openness, const transport::Visibility& vis,
                            uint64_t seed, uint32_t c, std::span<const uint32_t> begin,
                            std::span<const Source> sources, std::vector<double>& seen);
};

}  // namespace hrad::cluster
