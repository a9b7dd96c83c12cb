// cluster.model = none: no clusters. The hierarchy has no cluster nodes and
// the root patches link pairwise (Hanrahan, Salzman & Aupperle 1991): O(k^2)
// initial links for k root patches. The default for small scenes
// (cluster.model = auto, kAutoClusterPatches).
#pragma once

#include "cluster/transfer_model.h"

namespace hrad::cluster {

class NoneModel final : public TransferModel {
  public:
    const char* name() const override { return "none"; }
    bool hasClusters() const override { return false; }
    /// Never asked (there are no clusters).
    double projectedFraction(const ClusterTree&, uint32_t, double, const Vec3&) const override {
        return 0.0;
    }
    double maxProjectedFraction() const override { return 1.0; }
    Receive receives() const override { return Receive::ByArea; }
};

}  // namespace hrad::cluster
