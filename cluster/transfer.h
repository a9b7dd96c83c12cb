// Cluster transfer model names (DESIGN.md "Clustering"): the ids of the rows
// of the model table (cluster/transfer.cpp). The models themselves, their
// physics and papers are behind one interface, cluster/transfer_model.h:
// none, isotropic (Sillion 1995), oriented (Smits, Arvo & Greenberg 1994).
// How links touching a cluster are judged and why (a cluster's brightest
// surface, independent visibility estimates, all-blocked links) is in
// cluster/link.h and hr/solver.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace hrad::cluster {

/// Auto resolves per scene: None up to kAutoClusterPatches root patches,
/// Oriented above (O(k^2) initial linking is unaffordable there). Rows
/// added by registerTransferModel (tests) take the ids after Auto.
enum class ClusterModel : uint8_t { None, Isotropic, Oriented, Auto };
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
