// Hemicube form factors (Cohen & Greenberg 1985, "The hemi-cube: a radiosity
// solution for complex environments", SIGGRAPH '85; Cohen & Wallace 1993
// ch. 4). Selected for the full-matrix solver by `fm.ff.method = hemicube`
// (reference/fullmatrix.h).
//
// What it does. A unit hemicube is centred on a receiver point p with normal
// n: a top face z = 1, x,y in [-1,1], split into res x res cells, and four
// half side faces (res x res/2 cells each). Each cell carries its delta form
// factor, precomputed once (Cohen & Greenberg 1985):
//     top face  (x, y, 1):  dF = dA / (pi (x^2 + y^2 + 1)^2)
//     side face (1, y, z):  dF = z dA / (pi (y^2 + z^2 + 1)^2)
// with dA = (2/res)^2 and (x,y,z) the cell centre. The delta form factors
// sum to 1 up to the midpoint rule's error (O(res^-2)).
// The nearest surface per cell is found by casting one Embree ray through the
// cell centre (transport::Visibility::intersect), not by rasterisation: the
// closest hit is exact (no z-buffer precision, no clipping or scan conversion
// to write), it works for any polygon the Embree scene holds, and it costs
// 3 res^2 rays per hemicube. A hit on the back of a (one-sided) patch
// blocks the ray and contributes nothing. F from p to element j is the sum of
// the dF of the cells whose ray lands on j (F_{dA(p) -> j}).
//
// The point-sampled nature shows the method's known failings, measured in
// papers/ (study hemicube): aliasing of small or distant patches (a patch
// smaller than a cell's solid angle is hit by 0 or 1 rays), proximity error
// (F from one point instead of the area average, large for near patches), and
// visibility decided from the sample points only. With several points per
// receiver (hemicube_points = k: k x k points, the area-weighted mean of
// their F) the proximity and visibility errors shrink.
//
// Settings (below "fm.ff." for the full matrix):
//   method          string "quadrature"  "quadrature" (transport::FormFactorEngine)
//                                        | "hemicube"
//   hemicube_res    int    64            cells per side of the top face (even, 2..4096)
//   hemicube_points int    1             k: hemicubes at k x k points of each
//                                        receiver element (1: the centre)
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/params.h"
#include "scene/element.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::transport {

struct HemicubeSettings {
    bool enabled = false;  ///< method == "hemicube"
    int res = 64;
    int points = 1;

    /// Reads `<prefix>.method`, `<prefix>.hemicube_res`, `<prefix>.hemicube_points`.
    static HemicubeSettings fromParams(const Params& params, const std::string& prefix);
    /// "" for the quadrature method (so that its descriptions and cache keys
    /// do not change), else " method=hemicube hemicube_res=.. hemicube_points=..".
    std::string describe() const;
};

struct HemicubeCell {
    Vec3 dir;   ///< unit direction through the cell centre, local frame (z = normal)
    double dF;  ///< delta form factor
};

class Hemicube {
  public:
    /// res: cells per side of the top face, even, >= 2 (checked).
    explicit Hemicube(int res);
    int res() const { return res_; }
    const std::vector<HemicubeCell>& cells() const { return cells_; }
    /// sum of all dF (1 up to the midpoint rule's discretisation error).
    double sum() const;

    /// Casts one ray per cell from p (on patch `self`, unit normal n) and calls
    /// hit(patch, point, dF) for each cell whose nearest surface is the front
    /// of a patch. Returns the number of rays cast.
    uint64_t project(const Visibility& visibility, const scene::Scene& scene, const Vec3& p,
                     const Vec3& n, uint32_t self,
                     const std::function<void(uint32_t, const Vec3&, double)>& hit) const;

  private:
    int res_;
    std::vector<HemicubeCell> cells_;
};

/// Receiver sample points of an element for k x k hemicubes, with their area
/// weights (summing to 1): quads a k x k grid of cell midpoints weighted by
/// the Jacobian, triangles the centroids of the k^2 congruent sub-triangles.
void hemicubePoints(const scene::Patch& patch, const scene::Domain& dom, int k,
                    std::vector<Vec3>& points, std::vector<double>& weights);

}  // namespace hrad::transport
