// Smooth (C0) reconstruction of a radiosity field for display: the
// `interpolated` reconstruction of render/render.h, the default of `hrad
// solve` and `hrad render` (issue 60).
//
// Vertex radiosity, Gouraud-style (Cohen & Wallace 1993 ch. 10): every leaf
// corner gets one value per *surface vertex*, bilinear in quad leaves and
// barycentric in triangle leaves in between.
//   - Surfaces. Root patches that share an edge (both end points, in 3D) are
//     one smooth surface when they have the same reflectance and emission and
//     their normals differ by at most `crease_angle` (union-find over shared
//     edges). Corners of leaves of one surface at one 3D position (quantised
//     to 1e-7 of the scene's diagonal) are one vertex, so the image is
//     continuous across element borders *and* across root-patch borders of a
//     tessellated wall; creases, material borders and the two sides of a
//     surface stay sharp.
//   - Vertex value: the plain average of the leaves that have the vertex as a
//     corner (each leaf's value at that corner: its polynomial for hr.basis >
//     constant).
//   - T-vertices (a corner in the interior of a coarser neighbour's edge) are
//     anchored (Baum, Mann, Smith & Winget 1991, "Making radiosity usable":
//     the T-vertex takes the value interpolated along the coarser edge), from
//     the coarsest edges down, so the finer side meets the coarser side's
//     linear edge exactly: C0 everywhere on a surface. They are found as
//     recursive edge midpoints that are vertices of the same surface (dyadic
//     subdivision puts every T-vertex there); a T-junction of the *input* mesh
//     that is not an edge midpoint is not found (the image may then step).
//   - Not handled: shadow edges that a discontinuity mesh resolves with
//     coplanar patches of one material are smoothed like any other border.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/types.h"
#include "scene/element.h"
#include "scene/field.h"

namespace hrad::render {

struct SmoothSettings {
    double creaseDegrees = 30.0;  ///< render.crease_angle
};

/// Vertex tables of one field, built once; at() is thread-safe.
class VertexInterpolation {
  public:
    explicit VertexInterpolation(const scene::RadiosityField& field, const SmoothSettings& s = {});
    ~VertexInterpolation();
    VertexInterpolation(const VertexInterpolation&) = delete;
    VertexInterpolation& operator=(const VertexInterpolation&) = delete;

    /// Interpolated value at parametric (u,v) of `patch`.
    RGB at(uint32_t patch, double u, double v) const;
    /// Value at corner `corner` (0..2 or 0..3, elementCorners order) of leaf
    /// `key` of `patch`; leaves are those of the field.
    RGB cornerValue(uint32_t patch, scene::ElementKey key, int corner) const;
    /// Smooth surface (union of root patches) that `patch` belongs to.
    uint32_t surfaceOf(uint32_t patch) const { return surface_[patch]; }
    size_t numVertices() const { return value_.size(); }
    size_t numAnchored() const { return anchored_; }

  private:
    struct PatchTable;
    const scene::RadiosityField* field_;
    std::vector<uint32_t> surface_;               ///< per patch
    std::vector<std::unique_ptr<PatchTable>> tables_;
    std::vector<RGB> value_;                      ///< per vertex
    size_t anchored_ = 0;

    void buildSurfaces(double creaseDegrees);
    void buildVertices();
};

}  // namespace hrad::render
