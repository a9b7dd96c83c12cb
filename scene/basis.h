// Polynomial bases on the parametric domain of an element (Galerkin radiosity).
//
// Zatz 1993 and Gortler, Schroeder, Cohen & Hanrahan 1993 (higher-order and
// wavelet bases); Bekaert & Willems 1995-96 (RenderPark's Galerkin radiosity
// with constant, linear, quadratic and cubic bases). Radiosity on an element
// is B(x) = sum_a c_a phi_a(xi(x)), where xi = (a, b) are the element's local
// coordinates (scene/element.h domainParam: [0,1]^2 for quads, the reference
// triangle a, b >= 0, a + b <= 1 for triangles, inverted children included).
//
// Degree p uses the polynomials of *total* degree <= p: 1, 3, 6, 10 functions
// for constant, linear, quadratic, cubic, on quads and triangles alike (as
// RenderPark does). They are orthonormal for the *normalised* parametric
// measure (total mass 1): integral phi_a phi_b dxi = delta_ab, and phi_0 = 1,
// so c_0 is the mean of B over the element. For triangles and parallelograms
// the Jacobian of the local map is constant and this is the area measure, so
// c_0 is the area average that the constant solver stores. (Bilinear quads
// that are not parallelograms have a varying Jacobian; the basis is then
// orthonormal in the parametric, not the area, measure: a Petrov-Galerkin
// approximation that is exact for the constant basis and converges with
// refinement.)
//
//   quads:      phi_{ij}(a, b) = L_i(a) L_j(b), i + j <= p, with L_n the
//               Legendre polynomial orthonormal on [0, 1]:
//               L_n(x) = sqrt(2n + 1) P_n(2x - 1).
//   triangles:  Gram-Schmidt of the monomials a^i b^j (i + j <= p, ordered by
//               total degree, then by j) in the normalised measure of the
//               reference triangle, computed once with an exact rule (an
//               orthonormal basis of the same space as Dubiner's).
//
// Two-scale relations. A child covers 1/4 of its parent's parametric domain
// (quads and triangles alike), and a polynomial of degree p restricted to a
// child is a polynomial of degree p there, so with T_c[a][b] = integral over
// the child's reference domain of phi_a(parent coordinates of eta) phi_b(eta)
// pushing (restriction) is exact: child_b = sum_a T_c[a][b] parent_a, and
// pulling (the L2 projection of the children's piecewise polynomial onto the
// parent's) is parent_a = 1/4 sum_c sum_b T_c[a][b] child_b; pull after push
// is the identity. The T_c are computed by quadrature that is exact for
// degree 2p. The relative position of a child in its parent's local
// coordinates is the same for upright and inverted triangles, so one set of
// matrices serves every element of a kind.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace hrad::scene {

inline constexpr int kMaxBasisDegree = 3;
inline constexpr int kMaxBasisSize = 10;

/// Number of polynomials of total degree <= degree in two variables.
constexpr int basisSize(int degree) { return (degree + 1) * (degree + 2) / 2; }

/// The setting's names, by degree: "constant", "linear", "quadratic", "cubic".
const std::vector<std::string>& basisNames();
/// Degree of a name of basisNames() (checked).
int basisDegree(const std::string& name);
std::string basisName(int degree);

/// A quadrature rule on a reference domain, weights summing to 1 (the
/// normalised measure).
struct QuadratureRule {
    std::vector<Vec2> points;
    std::vector<double> weights;
    size_t size() const { return points.size(); }
};

/// Gauss-Legendre nodes and weights on [0, 1] (weights sum to 1); exact for
/// degree 2n - 1.
void gaussLegendre01(int n, std::vector<double>& x, std::vector<double>& w);

/// n x n rule on the reference domain of `kind`: the tensor Gauss-Legendre
/// rule on [0,1]^2 (exact for degree 2n-1 in each variable), or on triangles
/// the collapsed (Duffy) product a = s, b = (1 - s) t with weight (1 - s),
/// exact for total degree 2n - 2.
QuadratureRule referenceRule(PatchKind kind, int n);

class Basis {
  public:
    Basis(PatchKind kind, int degree);

    PatchKind kind() const { return kind_; }
    int degree() const { return degree_; }
    int size() const { return size_; }
    /// phi_0..phi_{size-1} at local coordinates (a, b).
    void eval(double a, double b, double* out) const;
    /// T_c (row-major size x size, [a * size + b]), see the file comment.
    const std::vector<double>& twoScale(int child) const { return twoScale_[size_t(child)]; }
    /// Parent local coordinates of local point (a, b) of child `child`.
    Vec2 childToParent(int child, double a, double b) const;

  private:
    PatchKind kind_;
    int degree_;
    int size_;
    /// Triangles: phi_i = sum_j mono_[i][j] a^{e_j} b^{f_j} (monomial order above).
    std::vector<std::array<double, kMaxBasisSize>> mono_;
    std::array<std::vector<double>, 4> twoScale_;
};

/// Mean over the region `key` of the polynomial with coefficients c[0..n-1]
/// (n = basis.size()) on the element `outer` that contains it (both keys of
/// one patch's quadtree, scene/element.h): c_0 after the two-scale
/// restrictions along the key's path from `outer` down to `key`.
RGB meanOverSubElement(const Basis& basis, std::array<RGB, kMaxBasisSize> c, uint64_t outer,
                       uint64_t key);

/// The bases of one degree for both patch kinds.
struct BasisSet {
    explicit BasisSet(int degree)
        : quad(PatchKind::Quad, degree), tri(PatchKind::Triangle, degree) {}
    const Basis& of(PatchKind k) const { return k == PatchKind::Quad ? quad : tri; }
    int degree() const { return quad.degree(); }
    int size() const { return quad.size(); }
    Basis quad, tri;
};

}  // namespace hrad::scene
