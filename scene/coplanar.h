// Coplanar overlapping faces: which surface is seen where two faces lie in
// the same plane, face the same way and overlap.
//
// Real scenes stack faces: a box modelled on a table top whose bottom face
// lies in the table's plane, a poster or a light panel on a wall, paper
// inside a binder cover. Seen from the front, two such faces occupy the same
// points; a ray tracer shows whichever it happens to hit first (z-fighting),
// but a radiosity solver that integrates form factors over each of them
// counts that part of the hemisphere twice: on graz.mgf the top of a closed
// box received form factors summing to 1.82 (the box's bottom and the table
// under it), and with reflectance 0.85 the hierarchical iteration created
// light and diverged (papers/README.md, "Error control").
//
// hrad resolves the tie once, geometrically: where faces G and P overlap, G
// is in front of P (P is hidden there) when G emits and P does not; else,
// with the same emission status, when G is the smaller ("a decal lies on the
// surface it decorates"); else when G has the lower index. A point of P that
// lies inside a face in front of it is hidden: it neither sends nor receives
// light (transport/visibility.h applies this to every segment's end points
// and to the nearest hit of every ray), so each point of the plane belongs to
// exactly one face and form factors over a receiver's hemisphere sum to at
// most one.
//
// One-sided faces in one plane facing opposite ways are not stacked: they
// are the two sides of a sheet (a wall modelled as two faces, a label on the outside of a
// cover whose faces point inwards). They are found the same way and only
// flagged (`inSheet`).
//
// Detection: patches are bucketed by their quantised plane (unit normal to
// 1e-3, offset to `planeTolerance`, neighbouring offset cells probed); within
// a bucket, faces whose 2-D bounding boxes overlap (a box tree: O(n log n)
// plus the pairs) are clipped against each other (Sutherland & Hodgman 1974, convex polygons) and a pair counts when
// the common area exceeds 1e-6 of the smaller face. Faces that only share an
// edge (the tiles of a floor) have no common area and are not pairs. Normals
// must agree to 1e-6 in their dot product and offsets to `planeTolerance`,
// 1e-6 of the scene's bounding-box diagonal.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace hrad::scene {

class CoplanarOverlaps {
  public:
    CoplanarOverlaps() = default;
    /// Finds the overlapping pairs of `scene` (all patches, back sides included).
    explicit CoplanarOverlaps(const Scene& scene);

    bool empty() const { return pairs_ == 0; }
    /// Overlapping pairs found.
    uint64_t numPairs() const { return pairs_; }
    /// Patches hidden by another one somewhere.
    uint64_t numHiddenPatches() const;
    /// True when point x of patch p lies inside a face in front of p.
    bool hidden(uint32_t p, const Vec3& x) const;
    /// Every patch overlapping p (either order), for filters that must not
    /// count a face in the plane of a segment's end point as a blocker.
    bool partners(uint32_t p, uint32_t q) const;
    bool hasPartners(uint32_t p) const {
        return p + 1 < partnerOffsets_.size() && partnerOffsets_[p + 1] > partnerOffsets_[p];
    }
    /// Pairs of one-sided overlapping faces in one plane facing opposite ways
    /// (the two sides of a sheet; faces with a two-sided twin excluded), and
    /// whether patch p is in one. Neither side hides the other: transport/visibility.h lets each
    /// see its own side, and a nearest hit on the back of one yields to the
    /// front of the other.
    uint64_t numSheetPairs() const { return sheetPairs_; }
    bool inSheet(uint32_t p) const { return p < sheet_.size() && sheet_[p] != 0; }
    /// True when G is drawn in front of P where they overlap (the rule above).
    static bool inFront(const Patch& g, uint32_t gi, const Patch& p, uint32_t pi);

  private:
    struct Face {
        std::array<Vec3, 4> v{};
        Vec3 normal{0.0};
        int n = 0;
    };
    uint64_t pairs_ = 0;
    uint64_t sheetPairs_ = 0;
    std::vector<uint8_t> sheet_;  ///< per patch, 1 when in a sheet pair (empty: none)
    // CSR: for patch p, the faces in front of it (coverOffsets_), and all its
    // partners (partnerOffsets_). Empty when there are no pairs.
    std::vector<uint64_t> coverOffsets_;
    std::vector<Face> covers_;
    std::vector<uint64_t> partnerOffsets_;
    std::vector<uint32_t> partners_;
};

}  // namespace hrad::scene
