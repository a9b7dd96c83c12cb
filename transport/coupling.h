// Galerkin coupling coefficients between two surface elements for a
// polynomial basis (scene/basis.h).
//
// With B on an element expanded in a basis orthonormal for the normalised
// measure of its local domain (phi_0 = 1, c_0 the mean), the Galerkin
// projection of the radiosity equation onto receiver r gives
//   c^r_a = E_a + rho_r sum_s sum_b K_rs^{ab} c^s_b,
//   K_rs^{ab} = integral_{xi in r} phi_a(xi)
//               integral_{y in s} phi_b(y) cos t_x cos t_y / (pi |x - y|^2) V dA_y dxi
// (Zatz 1993 eq. 9; Bekaert & Willems 1995), so K^{00} is the form factor
// F_rs and reciprocity reads A_r K_rs^{ab} = A_s K_sr^{ba}.
//
// Quadrature: Gauss-Legendre n x n on quads, collapsed Gauss on triangles
// (scene::referenceRule), n = hr.basis_points (default degree + 2). Column
// b = 0 uses the exact point-to-element form factor (Lambert's contour
// integral) as inner integral, accurate for adjacent elements; the other
// columns use the point-to-point kernel.
//
// Near pairs (centroid distance below 1.5 times the radii sum) use a
// composite rule for the columns b >= 1 (the n x n rule on each of 4^k
// sub-elements, k = hr.basis_near_levels, the same on both sides to keep
// reciprocity); column 0 keeps the base receiver rule so the point form
// factors to all senders sum to one at the same points (exact furnace).
//
// A check on the point-to-point rule (hr.basis_check): where the rule cannot
// follow the kernel (slivers meeting at right angles), the point-kernel
// estimate of the column-0 point form factors, free from the same samples, is
// compared with the exact ones; above the tolerance the link keeps column 0
// only, since a wrong higher coupling can make the iteration diverge.
//
// Visibility: a link that is not partially visible has V equal to its 0/1
// fraction. A partially visible far link casts a ray between every pair of
// quadrature points, and column 0 is scaled per receiver point by the
// kernel-weighted visible fraction; a partially visible near pair casts from
// x_i to the centroid of the sender sub-element holding y_k. Measurements
// behind these rules: papers/notes/2026-12-02-header-notes.md.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "scene/basis.h"
#include "scene/scene.h"
#include "transport/formfactor.h"
#include "transport/visibility.h"

namespace hrad::transport {

class CouplingEngine {
  public:
    /// `points` per axis on each element (>= 1). `visibility` may be null
    /// (everything visible).
    CouplingEngine(const scene::Scene& scene, const Visibility* visibility,
                   const FormFactorEngine& ff, const scene::BasisSet& basis, int points,
                   int nearLevels = 1, double checkTolerance = 0.5);

    /// Links whose higher columns were dropped by the check (see compute()).
    uint64_t fallbacks() const { return fallbacks_.load(); }

    int size() const { return basis_->size(); }
    /// K_rs^{ab} into out[a * size() + b]. `visibility` is the link's
    /// visibility fraction and `partial` whether it is partial (see above).
    /// Returns the number of rays cast.
    uint32_t compute(const ElementRef& r, const ElementRef& s, double visibility, bool partial,
                     float* out) const;

    /// How badly the basis represents the link's transfer over the receiver:
    /// max over check points x_k of |P(x_k) - F(x_k)|, where F(x) is the
    /// unoccluded point-to-element form factor F_{dA(x) -> s} and P its
    /// Galerkin projection onto the receiver's basis (P(x) = sum_a phi_a(x)
    /// K^{a0} with the column-0 rule of compute(), without visibility). The
    /// check points are the receiver's corners, edge midpoints and centroid,
    /// moved 5 % towards the centroid (a corner on the sender's edge has no
    /// finite contour integral). Geometry only: no rays.
    double projectionResidual(const ElementRef& r, const ElementRef& s) const;

    /// The same residual, signed, at the receiver's kernel sample points
    /// (FormFactorEngine::kernelSamplePoints: corners and edge midpoints
    /// inset 1e-6 towards the centre, then the centre, in that order):
    /// out[k] = F(x_k) - P(x_k). Summed over a receiver's links, it is the
    /// error of the receiver's polynomial irradiance (hr/receiver_error.h);
    /// in a closed room the sum over senders is zero at every x_k (the
    /// column-0 rule does not depend on the sender, and sum_s F_s(x) = 1
    /// projects onto 1). Returns the number of points (9 quads, 7 triangles).
    int residualSamples(const ElementRef& r, const ElementRef& s,
                        double out[FormFactorEngine::kMaxKernelSamples]) const;

  private:
    /// K0[a] = integral over the receiver of phi_a(x) F(x) (the column b = 0
    /// of compute() without visibility, base rule).
    void projectColumn0(const ElementRef& r, const ElementRef& s, double* K0) const;

    double checkTolerance_ = 0.5;
    mutable std::atomic<uint64_t> fallbacks_{0};
    const scene::Scene* scene_;
    const Visibility* vis_;
    const FormFactorEngine* ff_;
    const scene::BasisSet* basis_;
    scene::QuadratureRule quad_, tri_;
    /// Per point of the composite rules: its sub-element; and the
    /// sub-elements' centroids (local coordinates). Declared before the
    /// rules, whose initialisers fill them.
    std::vector<uint32_t> nearCellQuad_, nearCellTri_;
    std::vector<Vec2> cellCentreQuad_, cellCentreTri_;
    /// Composite rules for near pairs (nearLevels quadtree levels).
    scene::QuadratureRule nearQuad_, nearTri_;
};

}  // namespace hrad::transport
