// Face clusters: a bottom-up hierarchy of connected, nearly coplanar root
// patches (Willmott, Heckbert & Garland 1999, "Face cluster radiosity";
// Garland, Willmott & Heckbert 2001, "Hierarchical face clustering on
// polygonal surfaces").
//
// The dual graph has one node per root patch and one edge per pair of
// patches sharing a mesh edge. Vertices are welded by position quantised to
// 1e-7 of the scene's bounding diagonal (loaders store per-patch vertex
// positions; a mesh's shared vertices have equal coordinates, so this only
// absorbs rounding). Patches connect only when both are front sides or both
// back sides (Patch::backSide), so a two-sided surface's two sides are two
// separate face-cluster forests and a back side never joins its front side,
// and only when both or neither emit (a luminaire stays its own cluster, so
// the oracle's largest-radiosity rule does not open its surroundings with it).
//
// Contraction runs in rounds: each round takes every dual edge whose merged
// cluster stays within the limits below, orders them by cost in a priority
// queue, and contracts them greedily as a matching (a cluster merges at most
// once per round). A round thus roughly halves the clusters of a flat region
// and the hierarchy is balanced (depth about log2 of the region's patches),
// where one global greedy queue (Garland et al. 2001) can grow one cluster a
// patch at a time. The cost of merging clusters a and b (dimensionless):
//   fit    sqrt(lambda_min) / r_rms: the RMS distance of the merged surface
//          from its least-squares plane (smallest eigenvalue of the
//          area-weighted covariance of its points, integrated exactly over
//          each triangle: Garland et al. 2001, sec. 3.1) over its RMS radius
//   dir    1 - cos(theta), theta the half-angle of the merged normal cone
//          (orientation term; Garland et al. 2001, sec. 3.2)
//   shape  1 - 4 pi A / P^2, the irregularity of the merged region from its
//          area A and perimeter P (P_a + P_b - 2 |shared edges|; sec. 3.3)
// cost = fit + dir + face_shape * shape. A merge is allowed only while the
// merged normal cone's half-angle is at most face_cone, fit at most
// face_planarity, and the compactness A / (2 pi r_rms^2) (1 for a disc, 0.95
// for a square, 6 / (pi n) for a 1 x n strip) at least face_compactness. The plane fit uses Eigen's
// 3x3 self-adjoint solver.
//
// Settings: cluster.faces and cluster.face_* (read by ClusterSettings;
// `hrad settings cluster.face` lists them).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace hrad::cluster {

struct FaceClusterParams {
    double coneDegrees = 30.0;
    double planarity = 0.1;
    double shapeWeight = 0.5;
    double compactness = 0.0;
};

/// A binary forest over the root patches. Ids below the number of patches
/// are patches; id k + i (k patches) is merged node i, whose children are
/// ids `a` and `b`. Nodes are created in merge order (children before
/// parents).
struct FaceForest {
    struct Node {
        uint32_t a = 0, b = 0;
        uint32_t patches = 0;  ///< number of patches below
        Vec3 coneAxis{0.0};    ///< unit axis of a normal cone holding every normal below
        double coneCos = 1.0;  ///< cosine of that cone's half-angle (builder's bound)
    };
    uint32_t numPatches = 0;
    std::vector<Node> nodes;
    /// Roots of the forest: merged nodes and patches that merged with none.
    std::vector<uint32_t> roots;
    int rounds = 0;  ///< contraction rounds run
    bool isPatch(uint32_t id) const { return id < numPatches; }
    const Node& node(uint32_t id) const { return nodes[id - numPatches]; }
};

FaceForest buildFaceForest(const scene::Scene& scene, const FaceClusterParams& params);

/// Area moments of a set of planar polygons: area, first moment (sum of
/// A times centroid) and second moment of position, integral of x x^T dA
/// (xx, xy, xz, yy, yz, zz).
struct AreaMoments {
    double area = 0.0;
    Vec3 first{0.0};
    std::array<double, 6> second{};
    void addPatch(const scene::Patch& p);
    void add(const AreaMoments& o);
};

/// Least-squares plane of the surfaces with these moments: the centroid,
/// the unit normal (eigenvector of the smallest eigenvalue of the
/// area-weighted covariance, signed to agree with `orient`), the mean
/// squared distance from that plane (the smallest eigenvalue) and the mean
/// squared distance from the centroid (the trace).
struct PlaneFit {
    Vec3 centroid{0.0};
    Vec3 normal{0.0, 0.0, 1.0};
    double meanSquaredDistance = 0.0;
    double meanSquaredRadius = 0.0;
};
PlaneFit fitPlane(const AreaMoments& m, const Vec3& orient);

}  // namespace hrad::cluster
