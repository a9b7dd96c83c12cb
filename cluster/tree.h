// Cluster trees above the root patches (volume clustering).
//
// A cluster is a node of a tree whose leaves hold root patches: it knows its
// bounding box, the total area and the area-weighted reflectance of the
// surfaces below it, and the first and second moments of their area-weighted
// normals, which is what the transfer models need (cluster/transfer.h).
// Smits, Arvo & Greenberg 1994; Sillion 1995.
//
// Nodes are stored in depth-first pre-order (a parent's index is smaller than
// its children's), node 0 is the root. The patches below node c are the
// contiguous range order[patchBegin, patchEnd) of a permutation of the
// scene's patches, so sampling a point on the surfaces of a cluster is a
// binary search in a prefix sum of areas.
//
// Builders (cluster.builder):
//   bvh     binned surface-area heuristic over patch bounds (16 bins per axis,
//           centroid binning; Wald 2007 "On fast construction of SAH-based
//           bounding volume hierarchies")
//   octree  recursive subdivision of a cube into octants by patch centroid;
//           chains of single children are collapsed
// Face clusters (cluster.faces = true, bvh only): the root patches are first
// grouped into a forest of connected, nearly coplanar face clusters
// (cluster/face_clusters.h; Willmott, Heckbert & Garland 1999). Each forest
// root, and each group of at most leaf_size patches that joined no face
// cluster, becomes an item of the bvh, which is built above the items as
// above. A face cluster with at most leaf_size patches is one leaf; a larger
// one has its two sub-clusters as children (a patch child becomes a leaf of
// one patch). Face-cluster nodes have `face` set. The tree stays one node
// array in pre-order with contiguous patch ranges.
// Every face-cluster node records, in a FaceShape beside the node, its normal
// cone (the face builder's axis, and the cosine of the half-angle around it
// that holds every normal below) and its planarity (largest distance of a
// vertex below from the least-squares plane, over the node's radius); the
// linker treats a face cluster within face_cone and face_planarity as one
// surface (cluster/link.h). Volume nodes have coneCos -1 and planarity 1.
// Settings: cluster.builder, cluster.leaf_size, cluster.max_depth,
// cluster.faces, cluster.face_cone, cluster.face_planarity,
// cluster.face_shape, cluster.face_compactness (`hrad settings cluster.`).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/rng.h"
#include "scene/scene.h"

namespace hrad::cluster {

struct ClusterNode {
    double area = 0.0;
    RGB rho{0.0};         ///< area-weighted mean reflectance of the surfaces below
    Vec3 centroid{0.0};   ///< area-weighted centroid of the surfaces below
    double radius = 0.0;  ///< radius of a sphere around `centroid` containing the box
    Vec3 normalSum{0.0};  ///< S = sum_k A_k n_k
    std::array<double, 6> normalMoment{};     ///< M = sum_k A_k n_k n_k^T (xx, xy, xz, yy, yz, zz)
    uint32_t childBegin = 0, childCount = 0;  ///< sub-clusters: children[childBegin..+childCount)
    uint32_t patchBegin = 0, patchEnd = 0;    ///< all patches below: order[patchBegin..patchEnd)
    uint16_t depth = 0;
    bool face = false;  ///< a face cluster (cluster.faces; its shape: ClusterTree::faceShape)
    /// The patches held directly: a leaf holds its whole range, a node with
    /// sub-clusters none (every builder makes them so; not stored, nor is the
    /// bounding box, which only the build needs: 56 bytes of a node).
    uint32_t ownBegin() const { return childCount ? patchEnd : patchBegin; }
    uint32_t ownEnd() const { return patchEnd; }
};

/// The shape of a face-cluster node (ClusterTree::faceShape). Kept beside the
/// nodes, and only when face clusters are built: volume nodes, the default,
/// do not pay its 64 bytes (two fifths of a node).
struct FaceShape {
    Vec3 coneAxis{0.0};      ///< unit axis of a cone holding every normal below
    double coneCos = -1.0;   ///< min_k n_k . coneAxis (cosine of the cone's half-angle)
    double planarity = 1.0;  ///< max vertex distance from the least-squares plane / radius
    Vec3 planeNormal{0.0};   ///< unit normal of the least-squares plane (towards the normals)
};

struct ClusterSettings {
    std::string builder = "bvh";
    int leafSize = 4;
    int maxDepth = 40;
    bool faces = false;
    double faceCone = 30.0;  ///< degrees
    double facePlanarity = 0.1;
    double faceShape = 0.5;
    double faceCompactness = 0.0;
    static ClusterSettings fromParams(const Params& p);
    std::string describe() const;
};

class ClusterTree {
  public:
    /// Builds the tree with the selected builder. Throws InputError for an
    /// unknown builder (listing the valid ones).
    /// `include` (empty: every patch) leaves out the patches with include[p]
    /// == 0 (hr.reach_rays: patches light cannot reach); they then have no
    /// cluster (patchCluster() UINT32_MAX). Face clusters (settings.faces)
    /// always hold every patch: the mask is ignored there.
    ClusterTree(const scene::Scene& scene, const ClusterSettings& settings,
                const std::vector<uint8_t>& include = {});

    const std::vector<ClusterNode>& nodes() const { return nodes_; }
    const ClusterNode& node(uint32_t c) const { return nodes_[c]; }
    uint32_t size() const { return uint32_t(nodes_.size()); }
    uint32_t child(uint32_t c, uint32_t i) const { return children_[nodes_[c].childBegin + i]; }
    /// Normal cone and planarity of node c: a volume node's (coneCos -1,
    /// planarity 1) unless c is a face-cluster node.
    const FaceShape& faceShape(uint32_t c) const {
        static const FaceShape kVolume{};
        return c < faces_.size() ? faces_[c] : kVolume;
    }
    uint32_t patchAt(uint32_t i) const { return order_[i]; }
    /// Number of patches in the tree's order (patchAt(0 .. orderSize() - 1)).
    uint32_t orderSize() const { return uint32_t(order_.size()); }
    /// Parent cluster of every cluster (UINT32_MAX for the root).
    const std::vector<uint32_t>& parents() const { return parent_; }
    /// Leaf cluster holding each patch.
    const std::vector<uint32_t>& patchCluster() const { return patchCluster_; }
    int depth() const { return depth_; }
    const ClusterSettings& settings() const { return settings_; }
    /// A face cluster that links as one surface: `face`, its normal cone
    /// within face_cone and its planarity within face_planarity.
    bool planarFace(uint32_t c) const;
    /// A planar face cluster whose surfaces are coplanar (normal cone and
    /// planarity zero up to rounding): its surfaces exchange no light.
    bool flatFace(uint32_t c) const;
    /// Number of face-cluster nodes, and of those that are planarFace().
    uint32_t numFaceNodes() const;
    uint32_t numPlanarFaceNodes() const;
    double buildSeconds() const { return buildSeconds_; }
    uint64_t memoryBytes() const;

    /// Projected area of the surfaces below c towards unit direction d,
    /// sum_k A_k max(0, n_k . d), estimated from the normal moments as
    /// (sqrt(A d^T M d) + S . d) / 2. Exact when every |n_k . d| is equal (in
    /// particular for coplanar surfaces, and for surfaces all facing away,
    /// which then give 0); otherwise an upper bound by Cauchy-Schwarz.
    double projectedArea(uint32_t c, const Vec3& d) const;

    /// A point on the surfaces below c, chosen with probability proportional
    /// to area; `patch` receives the patch it lies on.
    Vec3 samplePoint(uint32_t c, double u0, double u1, double u2, uint32_t& patch) const;
    /// The patch samplePoint(c, u0, ...) lies on, without drawing the point.
    uint32_t samplePatch(uint32_t c, double u0) const;
    /// A point on patch `patch`, uniform by area, from (u1, u2) in [0,1)^2.
    Vec3 pointOnPatch(uint32_t patch, double u1, double u2) const;

  private:
    void finalize();
    const scene::Scene* scene_;
    ClusterSettings settings_;
    double faceConeCos_ = 1.0;
    std::vector<ClusterNode> nodes_;
    std::vector<FaceShape> faces_;  ///< per node when settings_.faces, else empty
    std::vector<uint32_t> children_;
    std::vector<uint32_t> order_;
    std::vector<double> areaPrefix_;  ///< prefix sums of patch areas in `order_`
    /// Per patch, twice the areas of a quad's two triangles (v0 v1 v2,
    /// v0 v2 v3; zeros for a triangle): pointOnPatch picks one by area.
    /// Stored, not recomputed per point, where quads are at least a quarter
    /// of the patches: every cluster link's visibility rays draw their ends
    /// through it (tens of millions of points per large solve; the cost of
    /// recomputing them on an all-quad scene is in bench/results/
    /// large_scenes.md, "Cluster nodes slimmed"). Empty otherwise, as
    /// triangles never read it: 16 bytes per patch saved where most
    /// patches are triangles.
    std::vector<std::array<double, 2>> halves_;
    static std::array<double, 2> quadHalves(const scene::Patch& p);
    std::vector<uint32_t> parent_;
    std::vector<uint32_t> patchCluster_;
    int depth_ = 0;
    double buildSeconds_ = 0.0;
    friend struct TreeBuilder;
};

std::vector<std::string> builderNames();

}  // namespace hrad::cluster
