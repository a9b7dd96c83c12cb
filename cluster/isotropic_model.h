// cluster.model = isotropic: a cluster is a volume whose projected area is
// A/4 in every direction (the mean projected area of a convex body, or of
// surfaces whose normals are spread uniformly) and whose radiosity leaves
// uniformly; the irradiance it receives is gathered by the cluster as a
// whole and spread uniformly over its surfaces (Sillion 1995, "A unified
// hierarchical algorithm for global illumination with scattering volumes
// and object clusters", sec. 3).
//
// Cheap (no per-surface work when pushing, no moments), but a cluster of
// surfaces that all face one way (a wall of tiles, a desk top) sends and
// receives as much towards its back as towards its front.
#pragma once

#include "cluster/transfer_model.h"

namespace hrad::cluster {

class IsotropicModel final : public TransferModel {
  public:
    const char* name() const override { return "isotropic"; }
    double projectedFraction(const ClusterTree&, uint32_t, double, const Vec3&) const override {
        return 0.25;
    }
    double maxProjectedFraction() const override { return 0.25; }
    Receive receives() const override { return Receive::ByArea; }
};

}  // namespace hrad::cluster
