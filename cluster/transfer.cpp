#include "cluster/transfer.h"

#include "core/error.h"

namespace hrad::cluster {

std::vector<std::string> clusterModelNames() { return {"none", "isotropic", "oriented"}; }

ClusterModel parseClusterModel(const std::string& name) {
    if (name == "none") return ClusterModel::None;
    if (name == "isotropic") return ClusterModel::Isotropic;
    if (name == "oriented") return ClusterModel::Oriented;
    throw InputError({}, "unknown cluster model '" + name + "'; valid: none, isotropic, oriented");
}

const char* clusterModelName(ClusterModel m) {
    switch (m) {
        case ClusterModel::None: return "none";
        case ClusterModel::Isotropic: return "isotropic";
        case ClusterModel::Oriented: return "oriented";
    }
    return "?";
}

}  // namespace hrad::cluster
