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
// Visibility: a link whose visibility estimate is not partial has V = its
// (0 or 1) visibility fraction everywhere. For a partially visible link a ray
// is cast between every pair of quadrature points (V_ik), so that shadow
// boundaries inside the link shape the higher-order terms; the exact b = 0
// column is then scaled per receiver point by the kernel-weighted fraction of
// visible sender points.
#pragma once

#include <cstdint>

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
                   const FormFactorEngine& ff, const scene::BasisSet& basis, int points);

    int size() const { return basis_->size(); }
    /// K_rs^{ab} into out[a * size() + b]. `visibility` is the link's
    /// visibility fraction and `partial` whether it is partial (see above).
    /// Returns the number of rays cast.
    uint32_t compute(const ElementRef& r, const ElementRef& s, double visibility, bool partial,
                     float* out) const;

  private:
    const scene::Scene* scene_;
    const Visibility* vis_;
    const FormFactorEngine* ff_;
    const scene::BasisSet* basis_;
    scene::QuadratureRule quad_, tri_;
};

}  // namespace hrad::transport
