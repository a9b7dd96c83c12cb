// Quadrature and sampling rules on elements, shared by the form factor engine
// and by anyone who needs weighted points on an element (reference solvers,
// renderers, tests).
//
// Gauss-Legendre rules on [0,1] for n = 1..kMaxGaussPoints are tabulated once
// (nodes by Newton iteration on P_n, Golub-Welsch-free; Abramowitz & Stegun
// 25.4.29). On elements:
//   quad:     tensor rule in the local bilinear (a,b) in [0,1]^2, weighted with
//             the Jacobian |dP/da x dP/db| (scene::elementJacobian);
//   triangle: collapsed ("Duffy") tensor rule, a = xi, b = eta (1 - xi),
//             weight w_i w_j (1 - xi) J (Stroud 1971, "conical product" rule).
// The weights of an n x n rule sum to the element area (exactly for planar
// elements, whose Jacobian is at most bilinear).
#pragma once

#include "core/rng.h"
#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"

namespace hrad::transport {

inline constexpr int kMaxGaussPoints = 16;

/// n-point Gauss-Legendre rule on [0,1]: weights sum to 1.
struct GaussRule {
    int n = 0;
    double x[kMaxGaussPoints]{};
    double w[kMaxGaussPoints]{};
};

/// The tabulated rule with n points (1 <= n <= kMaxGaussPoints). Immutable,
/// built once (thread-safe static initialisation).
const GaussRule& gaussLegendre01(int n);

/// Writes the n x n rule on element (p, d): points and weights (weights sum to
/// the element's area). `pts` and `w` must hold n*n entries. Returns n*n.
int elementGaussPoints(const scene::Patch& p, const scene::Domain& d, int n, Vec3* pts, double* w);

/// Local (a,b) of a point uniformly distributed in area over the local domain
/// for a square sample (s,t) in [0,1)^2: identity on quads, the area-preserving
/// square-root warp on triangles (a = 1 - sqrt(s), b = t sqrt(s)). Quads are
/// sampled uniformly in (a,b) (uniform in area for parallelograms).
Vec2 squareToElementLocal(scene::PatchKind kind, double s, double t);

/// `count` stratified, jittered sample positions in [0,1)^2 (count <= 4096):
/// an nx x ny grid (nx = ceil(sqrt(count)), ny = ceil(count / nx)); when the
/// grid has more cells than samples, a uniformly random subset of `count`
/// distinct cells is used (so no region is favoured); each sample is jittered
/// uniformly inside its cell. Deterministic for a given rng state.
void stratifiedSquare(int count, Pcg32& rng, Vec2* out);

}  // namespace hrad::transport
