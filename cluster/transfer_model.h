// Cluster transfer models as one interface (DESIGN.md "Clustering"):
// what a cluster looks like from a direction, how it sends, and how the
// irradiance it receives reaches its surfaces.
//
// Transfer between two nodes (surface elements or clusters) at distance r
// along unit direction u (sender to receiver), in the point approximation:
//     K = A_s g_s(u) g_r(-u) / (pi r^2)
// with g the projected-area fraction: cos for a surface, projectedFraction()
// for a cluster. A model that receives ByArea keeps g_r in K and its
// cluster gathers the irradiance as a whole, handed to every surface below
// alike (Sillion 1995); a model that receives ByCosine leaves g_r out of K
// and the push hands each link's light to each surface with its own cosine
// (Smits, Arvo & Greenberg 1994). A model that sends by direction has the
// hierarchy keep radiant moments per cluster (RadiantMoments) and sends
// sent() towards each receiver instead of the mean radiosity.
//
// One file per model: none_model.h, isotropic_model.h, oriented_model.h
// (the oriented model also owns the sums of its hand-over by openness and
// by what each surface sees: cluster/openness.h; handOver() names the row
// of hr/handover.h that applies them). The table that names them is
// transfer.cpp (clusterModelNames, parseClusterModel, transferModel).
// Measurements behind the models' choices:
// papers/notes/2026-12-01-cluster-transfer.md.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "cluster/transfer.h"
#include "core/types.h"

namespace hrad::cluster {

class ClusterTree;
struct ClusterLinkSettings;

/// Per cluster and RGB channel: sum A_k B_k, sum A_k B_k n_k,
/// sum A_k B_k n_k n_k^T (xx, xy, xz, yy, yz, zz) over the surfaces below.
/// Summed in double, stored in float (120 bytes per cluster): a relative
/// rounding of 6e-8 on a radiance whose model error is percents.
struct RadiantMoments {
    glm::vec3 ab{0.f};
    std::array<glm::vec3, 3> s{};
    std::array<std::array<float, 6>, 3> m{};
};

class TransferModel {
  public:
    /// How a receiving cluster hands the irradiance of its links to its surfaces.
    enum class Receive : uint8_t {
        ByArea,    ///< gathered by the cluster, every surface takes it alike
        ByCosine,  ///< per link and surface, by the surface's cosine
    };

    virtual ~TransferModel() = default;
    /// The lowercase name of the registry row (cluster.model).
    virtual const char* name() const = 0;
    /// False: the hierarchy has no cluster nodes (model none).
    virtual bool hasClusters() const { return true; }
    /// g of cluster c (area `area`) towards unit direction d.
    virtual double projectedFraction(const ClusterTree& tree, uint32_t c, double area,
                                     const Vec3& d) const = 0;
    /// Largest g over all directions (the upper bound of a cluster link).
    virtual double maxProjectedFraction() const = 0;
    virtual Receive receives() const = 0;
    bool receivesByCosine() const { return receives() == Receive::ByCosine; }
    /// The hand-over the model's receiving clusters use under `settings`:
    /// the name of a row of the hand-over table (hr/handover.h), through
    /// which the solver makes it. "none" (the default): links hand their
    /// light over as receives() says; the oriented model names "openness"
    /// when cluster.handover = visible (cluster/openness.h).
    virtual const char* handOver(const ClusterLinkSettings& settings) const {
        (void)settings;
        return "none";
    }
    /// Whether a cluster sends sent() (true) or its mean radiosity.
    virtual bool sendsByDirection() const { return false; }
    /// The radiosity cluster c (mean radiosity meanB, moments m) sends
    /// towards unit direction d, averaged over its projected area.
    virtual RGB sent(const ClusterTree& tree, uint32_t c, const RadiantMoments& m,
                     const RGB& meanB, const Vec3& d) const {
        (void)tree, (void)c, (void)m, (void)d;
        return meanB;
    }
};

/// The model of a registry row (not Auto, which the solver resolves first).
const TransferModel& transferModel(ClusterModel m);

/// Test hook: adds a row to the table under `name` (lowercase, not yet
/// taken) and returns its id, which parseClusterModel(name) returns from
/// then on. Meant for tests that prove what a new model costs
/// (tests/cluster/transfer_model_test.cpp); a model of the library is a row
/// of the table in transfer.cpp.
ClusterModel registerTransferModel(const std::string& name, std::unique_ptr<TransferModel> model);

}  // namespace hrad::cluster
