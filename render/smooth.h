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
//   - Irradiance (with a LeafReflectance, render/texturing.h: leaves that
//     carry their own reflectance, hr.texture_rho = element): on the patches
//     it covers the tables hold H, not B. A vertex takes sum (B_l - E) / sum
//     rho_l over its leaves per channel (the H whose product with the leaves'
//     mean rho is their mean reflected radiosity; a black leaf, rho_l = 0,
//     tells nothing of H and weighs nothing). Surfaces are those of B (equal
//     patch means), so the picture is the patch solve's wherever the leaves
//     carry the patch mean (joining by material instead smoothed the
//     holodeck's floor into its walls' fillets: papers/notes/
//     2026-12-02-textures.md, 2026-12-04); they never join a patch holding B.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/types.h"
#include "scene/element.h"
#include "scene/field.h"

namespace hrad::render {

class LeafReflectance;

struct SmoothSettings {
    double creaseDegrees = 30.0;  ///< render.crease_angle
};

/// Vertex tables of one field, built once; at() is thread-safe.
class VertexInterpolation {
  public:
    /// With `leaf` (which must outlive this), the patches it covers hold
    /// irradiance H (see above).
    explicit VertexInterpolation(const scene::RadiosityField& field, const SmoothSettings& s = {},
                                 const LeafReflectance* leaf = nullptr);
    ~VertexInterpolation();
    VertexInterpolation(const VertexInterpolation&) = delete;
    VertexInterpolation& operator=(const VertexInterpolation&) = delete;

    /// Interpolated value at parametric (u,v) of `patch` (H where
    /// holdsIrradiance(patch), else B).
    RGB at(uint32_t patch, double u, double v) const;
    /// Value at corner `corner` (0..2 or 0..3, elementCorners order) of leaf
    /// `key` of `patch`; leaves are those of the field.
    RGB cornerValue(uint32_t patch, scene::ElementKey key, int corner) const;
    /// Smooth surface (union of root patches) that `patch` belongs to.
    uint32_t surfaceOf(uint32_t patch) const { return surface_[patch]; }
    /// Whether `patch`'s values are irradiance (a LeafReflectance covers it).
    bool holdsIrradiance(uint32_t patch) const;
    /// Whether this was built with a LeafReflectance that covers some patch.
    bool interpolatesIrradiance() const;
    const SmoothSettings& settings() const { return settings_; }
    size_t numVertices() const { return value_.size(); }
    size_t numAnchored() const { return anchored_; }

  private:
    struct PatchTable;
    const scene::RadiosityField* field_;
    SmoothSettings settings_;
    const LeafReflectance* leaf_ = nullptr;
    std::vector<uint32_t> surface_;               ///< per patch
    std::vector<std::unique_ptr<PatchTable>> tables_;
    std::vector<RGB> value_;                      ///< per vertex
    size_t anchored_ = 0;

    void buildSurfaces(double creaseDegrees);
    void buildVertices();
};

}  // namespace hrad::render
