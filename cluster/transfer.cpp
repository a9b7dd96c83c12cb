#include "cluster/transfer.h"

#include "core/error.h"

namespace hrad::cluster {

std::vector<std::string> clusterModelNames() { return {"auto", "none", "isotropic", "oriented"}; }

ClusterModel parseClusterModel(const std::string& name) {
    if (name == "none") return ClusterModel::None;
    if (name == "isotropic") return ClusterModel::Isotropic;
    if (name == "oriented") return ClusterModel::Oriented;
    if (name == "auto") return ClusterModel::Auto;
    throw InputError({}, "unknown cluster model '" + name + "'; valid: auto, none, isotropic, oriented");
}

const char* clusterModelName(ClusterModel m) {
    switch (m) {
        case ClusterModel::None: return "none";
        case ClusterModel::Isotropic: return "isotropic";
        case ClusterModel::Oriented: return "oriented";
        case ClusterModel::Auto: return "auto";
    }
    return "?";
}

}  // namespace hrad::cluster
