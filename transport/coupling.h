// Galerkin coupling coefficients between two surface elements for a
// polynomial basis (scene/basis.h).
//
// With B on an element expanded as sum_b c_b phi_b in a basis orthonormal for
// the normalised measure of its local domain (phi_0 = 1, c_0 the mean), the
// Galerkin projection of the radiosity equation onto receiver r gives
//   c^r_a = E_a + rho_r sum_s sum_b K_rs^{ab} c^s_b,
//   K_rs^{ab} = integral_{xi in r} phi_a(xi)
//               integral_{y in s} phi_b(y) cos t_x cos t_y / (pi |x - y|^2) V dA_y dxi
// (Zatz 1993 eq. 9; Bekaert & Willems 1995, the Galerkin coupling
// coefficients), so K^{00} is the form factor F_rs and reciprocity reads
// A_r K_rs^{ab} = A_s K_sr^{ba} (elements with a constant Jacobian).
//
// Quadrature (Gauss-Legendre n x n on quads, collapsed Gauss n x n on
// triangles: scene::referenceRule) on both elements; n follows the basis
// (hr.basis_points, default degree + 2: exact for the polynomial part of the
// integrand on either side). The column b = 0 uses the exact point-to-element
// form factor as inner integral (transport pointToElement, Lambert's contour
// integral), which stays accurate for adjacent elements where the
// point-to-point kernel is nearly singular; the other columns use the
// point-to-point kernel.
//
// Near pairs (centroid distance below 1.5 times the sum of the elements'
// radii: adjacent elements meeting at an edge, or neighbours) make the
// point-to-point kernel nearly singular where the quadrature points of one
// element come close to the other: with a plain n x n rule the higher-order
// coefficients of the Cornell box's corner links came out wrong enough to stop
// the Jacobi iteration from converging (uniform level 1, quadratic: L2 0.036
// against 0.010 with 8 x 8 points). Near pairs therefore use a composite rule
// on both elements for the columns b >= 1: the n x n rule on each of the 4^k
// sub-elements of the quadtree (k = hr.basis_near_levels, default 1: L2 0.0102
// there; k = 2, 0.0095, costs 16 times more), the same on both sides so that
// reciprocity is kept. The column b = 0 keeps the base rule on the receiver
// whatever the sender, so that the point form factors to all senders sum to
// one at the same points (exact furnace; a rule depending on the sender broke
// that by 1e-5).
//
// A check on the point-to-point rule (hr.basis_check, default 0.5). The
// columns b >= 1 rest on the point-to-point kernel; where its rule cannot
// follow the kernel (a sliver 7 mm wide and 1.2 m long next to another at a
// right angle, as the chamfers of RenderPark's classroom tables: the kernel
// varies over millimetres along the long side, sampled every 30 cm) they are
// wrong, and a wrong higher-order coupling can make the Jacobi iteration
// diverge (classroom, linear and quadratic: a mode growing up to 18x per
// iteration). The same sender points also give the point-kernel estimate of
// the point form factor at the column-0 receiver points, which the exact
// contour integral checks at no extra cost: when sum_i w_i |F_rule(x_i) -
// F(x_i)| exceeds the tolerance times sum_i w_i F(x_i), the link keeps its
// exact column 0 and no higher columns (the sender's mean only). Measured
// relative errors: cornell's near pairs median 4e-6, 99th percentile 0.30;
// classroom's near pairs 99th percentile 0.81, largest 15 (2,967 of 149,781
// above 0.5). With 0.5 the classroom converges for linear and quadratic,
// and every point of the bases study on cornell and the plates is unchanged
// but one (cornell quadratic bfa 1e-3: L2 0.00372 -> 0.00380).
//
// Visibility: a link whose visibility estimate is not partial has V = its
// (0 or 1) visibility fraction everywhere. For a partially visible link that
// is not near, a ray is cast between every pair of quadrature points (V_ik),
// so that shadow boundaries inside the link shape the higher-order terms; the
// exact b = 0 column is then scaled per receiver point by the kernel-weighted
// fraction of visible sender points. For a partially visible near pair
// (whose composite rules would need 4^{2k} times the rays) V(x_i, y_k) is the
// ray from x_i to the centroid of the sender sub-element holding y_k.
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
