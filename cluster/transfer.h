// Cluster transfer models: how a cluster emits and receives (DESIGN.md
// "Clustering").
//
//   isotropic  a cluster is a volume whose projected area is A/4 in every
//              direction and whose radiosity leaves uniformly; received
//              irradiance is spread uniformly over its surfaces (Sillion 1995,
//              "A unified hierarchical algorithm for global illumination with
//              scattering volumes and object clusters", sec. 3).
//   oriented   projected area sum_k A_k max(0, n_k . d) over the surfaces below
//              (ClusterTree::projectedArea); irradiance received by a cluster
//              is handed to each surface with its own cosine when pushed
//              (Smits, Arvo & Greenberg 1994, "A clustering algorithm for
//              radiosity in complex environments", sec. 4), times its
//              openness towards the sender within the cluster
//              (cluster.handover = visible, cluster/openness.h).
//
// Transfer between two nodes (surface elements or clusters) at distance r
// along unit direction u (sender to receiver), in the point approximation:
//   irradiance on the receiver per unit sender radiosity
//       K = A_s g_s(u) g_r(-u) / (pi r^2)
// with g the projected-area fraction: cos for a surface, 1/4 for an
// isotropic cluster, projectedArea/A for an oriented one. For an oriented
// receiving cluster the factor g_r is applied per surface when pushing, so
// the link stores K without it; an oriented sending cluster sends the
// radiosity of its surfaces facing the receiver (Hierarchy::directionalB) in
// gather and push alike. K is multiplied by a visibility fraction estimated
// with rays; how those links are judged and why (a cluster's brightest
// surface, independent visibility estimates, all-blocked links) is in
// hr/solver.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace hrad::cluster {

/// Auto resolves per scene: None up to kAutoClusterPatches root patches,
/// Oriented above (O(k^2) initial linking is unaffordable there).
enum class ClusterModel { None, Isotropic, Oriented, Auto };
inline constexpr size_t kAutoClusterPatches = 2000;

ClusterModel parseClusterModel(const std::string& name);
const char* clusterModelName(ClusterModel m);
std::vector<std::string> clusterModelNames();

/// One sample of a stand-in from a sending cluster (ClusterLinker::standIn):
/// the irradiance it puts on the receiver per unit area is the sum over its
/// samples of weight times the radiosity of root patch `patch`.
struct StandInSample {
    uint32_t patch = 0;
    float weight = 0.f;
};

}  // namespace hrad::cluster
