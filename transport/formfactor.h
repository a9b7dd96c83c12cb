// Form factors: closed forms, exact point-to-polygon, quadrature between
// elements with visibility, cheap estimates and conservative upper bounds.
//
// Notation: F_ij is the fraction of the energy leaving (diffuse) element i
// that arrives at element j,
//   F_ij = 1/A_i  \int_{A_i} \int_{A_j} cos t_i cos t_j / (pi r^2) V dA_j dA_i
// (Cohen & Wallace 1993, eq. 4.11). Reciprocity: A_i F_ij = A_j F_ji.
#pragma once

#include <cstdint>
#include <string>

#include "core/params.h"
#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::transport {

// ---- closed forms and analytic pieces ---------------------------------------

/// Exact unoccluded form factor from a differential area at p with unit normal
/// n to a planar polygon (corners in order), by Lambert's contour integral
/// F = 1/(2 pi) sum_k n . (gamma_k R_k x R_{k+1} / |R_k x R_{k+1}|)
/// (Cohen & Wallace 1993, eq. 4.18). Parts of the polygon behind p's tangent
/// plane are clipped away first.
double pointToPolygon(const Vec3& p, const Vec3& n, const Vec3* poly, int count);

/// Two identical, directly opposed, parallel w x h rectangles at distance d:
/// the standard closed form (Howell's catalog C-11; Cohen & Wallace 1993 table).
double parallelRectangles(double w, double h, double d);

/// Two rectangles sharing an edge of length l at a right angle; the first has
/// width w (perpendicular to the shared edge), the second height h. Returns
/// F from the first to the second (Howell's catalog C-14).
double perpendicularRectangles(double w, double h, double l);

/// Point-to-disc estimate A cos_r cos_s / (pi r^2 + A): the disc of area A
/// seen from distance r (Wallace, Elmquist & Haines 1989). Cosines clamped at 0.
double pointToDisc(double senderArea, double dist2, double cosR, double cosS);

// ---- element-to-element -----------------------------------------------------

/// An element of a root patch: the patch index and the parametric domain.
struct ElementRef {
    uint32_t patch = 0;
    scene::Domain dom{};
    uint64_t id = 0;  ///< stable id used to seed visibility samples
};

/// Settings for element-to-element form factors.
///   rule           string "gauss"   "gauss": outer Gauss-Legendre points on the
///                                   receiver, inner exact pointToPolygon to the
///                                   sender; "gauss-gauss": point-to-point kernel
///                                   on both; "centroid": one point each
///   points         int    3         points per axis of the outer rule (n x n)
///   sender_points  int    3         points per axis on the sender ("gauss-gauss")
///   vis_rays       int    16        visibility rays per element pair (0: assume visible)
///   adaptive_depth int    0 / 3     "gauss" rule on near pairs (bounding spheres
///                                   closer than the receiver's radius): the
///                                   receiver rule is compared with the rule on
///                                   its 4 children and refined recursively up
///                                   to this many levels (0: off, a fixed rule).
///                                   Default 0 for the hierarchical solver, whose
///                                   oracle refines near pairs itself (corridor,
///                                   bfa: 2-5x the solve time for a smaller gain
///                                   than a smaller eps gives); 3 for the full
///                                   matrix (reference/fullmatrix.h), whose
///                                   mesh is fixed
///   adaptive_tol   double 1e-3      ... until the two agree to this relative
///                                   tolerance. Measured on RenderPark's
///                                   corridor (lamps close to fixtures), the
///                                   fixed 3 x 3 rule overestimates the
///                                   full-matrix power by 2-6 % at mesh levels
///                                   0-1 (papers/README.md).
/// Where a link's visibility rays go (ff.vis_sampling).
enum class VisSampling { Area, SolidAngle };

struct FormFactorSettings {
    std::string rule = "gauss";
    int points = 3;
    int senderPoints = 3;
    int visRays = 16;
    VisSampling visSampling = VisSampling::SolidAngle;
    int adaptiveDepth = 0;
    double adaptiveTol = 1e-3;

    /// The keys above below `prefix`; keys not set keep the values of `defaults`
    /// (the engine's defaults in the first form).
    static FormFactorSettings fromParams(const Params& params, const std::string& prefix = "ff");
    static FormFactorSettings fromParams(const Params& params, const std::string& prefix,
                                         const FormFactorSettings& defaults);
    std::string describe() const;
};

struct FormFactorResult {
    double F = 0.0;           ///< receiver-to-sender form factor, visibility included
    double unoccludedF = 0.0; ///< same without visibility
    double visibility = 1.0;  ///< fraction of visibility rays that got through
                              ///< (1 when no rays were cast: unoccludedF == 0,
                              ///< vis_rays == 0, or no Visibility given)
    bool partial = false;     ///< some but not all rays were blocked
    uint32_t rays = 0;        ///< occlusion rays cast
    /// Smallest and largest unoccluded point-to-element form factor
    /// F_{dA(x_i) -> s} over the outer rule's receiver points x_i: the values
    /// whose weighted mean is unoccludedF, so pointMin <= unoccludedF <=
    /// pointMax up to round-off (see pointRange). 0 when the pair does not face.
    double pointMin = 0.0, pointMax = 0.0;
};

/// Range of the unoccluded point-to-element form factor over receiver points.
struct PointRange {
    double min = 0.0, max = 0.0;
};

class FormFactorEngine {
  public:
    /// `visibility` may be null: every pair is then treated as fully visible.
    /// Throws InputError for an unknown rule or out-of-range point/ray counts.
    FormFactorEngine(const scene::Scene& scene, const Visibility* visibility,
                     FormFactorSettings settings);

    /// F from receiver r to sender s (fraction of r's outgoing energy... i.e.
    /// F_rs with 1/A_r normalisation). Deterministic: visibility sample
    /// positions depend only on (r.id, s.id); (r,s) and (s,r) share the same
    /// segments, so their visibility is identical. Ids should be unique per element.
    FormFactorResult compute(const ElementRef& r, const ElementRef& s) const;

    /// The pointMin / pointMax of compute() without its visibility rays: the
    /// min and max over the outer rule's receiver points x_i of the unoccluded
    /// point-to-element form factor F_{dA(x_i) -> s} ("gauss": exact
    /// pointToPolygon, 0 for points behind s's plane; "gauss-gauss": the inner
    /// sender rule; "centroid": the single centroid value). These are samples
    /// of the variation of F_{dA(x) -> s} over r, not conservative bounds: the
    /// extremes may lie between the points (near a shared edge, at r's
    /// boundary). Used by error-driven oracles (oracles/error_oracle.h).
    PointRange pointRange(const ElementRef& r, const ElementRef& s) const;

    /// Receiver sample points for kernel-error estimates: the corners, the
    /// edge midpoints and the centroid of r (9 for a quad, 7 for a triangle),
    /// corners and midpoints moved towards the centroid by a relative 1e-6.
    /// The same points, in the same order, for every sender.
    static constexpr int kMaxKernelSamples = 9;
    int kernelSamplePoints(const ElementRef& r, Vec3 out[kMaxKernelSamples]) const;
    /// Unoccluded point-to-element form factor F_{dA(x_k) -> s} at the
    /// receiver sample points x_k of kernelSamplePoints (exact contour
    /// integral; 0 where x_k is behind s's plane). Returns the count.
    int kernelSamples(const ElementRef& r, const ElementRef& s,
                      double out[kMaxKernelSamples]) const;
    /// The same at m given points x of a receiver plane with normal n (the
    /// points of kernelSamplePoints, computed once for many senders).
    void kernelSamplesAt(const Vec3* x, int m, const Vec3& n, const ElementRef& s,
                         double* out) const;

    /// Cheap estimate of F_rs (centroid point-to-disc, no visibility).
    double estimate(const ElementRef& r, const ElementRef& s) const;

    /// Conservative upper bound on the unoccluded F_rs (>= the true value for
    /// any pair, including touching elements; capped at 1).
    double upperBound(const ElementRef& r, const ElementRef& s) const;

    /// Visibility fraction between two elements with n rays (no form factor).
    /// A non-zero `salt` draws the segments from a different seed (still the
    /// same for (r, s) and (s, r)): an estimate independent of compute()'s.
    /// `partial` (optional): some weighted segments blocked, some not.
    double visibilityFraction(const ElementRef& r, const ElementRef& s, int rays,
                              uint32_t* raysCast = nullptr, uint64_t salt = 0,
                              bool* partial = nullptr) const;

    /// True when some point of s is in front of r and vice versa (the elements
    /// can exchange energy when unoccluded).
    bool facing(const ElementRef& r, const ElementRef& s) const;

    /// Exact unoccluded form factor from a differential area at p with unit
    /// normal n to element s (pointToPolygon on s's corners; 0 when p is
    /// behind s's plane, i.e. sees its back). Added for point gathers
    /// (renderers, Monte Carlo references).
    double pointToElement(const Vec3& p, const Vec3& n, const ElementRef& s) const;

    const FormFactorSettings& settings() const { return settings_; }
    const scene::Scene& scene() const { return *scene_; }
    const Visibility* visibility() const { return visibility_; }

  private:
    const scene::Scene* scene_;
    const Visibility* visibility_;
    FormFactorSettings settings_;
};

}  // namespace hrad::transport
