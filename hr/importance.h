// Importance: the adjoint of the hierarchical transport, solved on the same
// links, transposed (Smits, Arvo & Salesin 1992, "An Importance-Driven
// Radiosity Algorithm", sections 3-4), and the weight the importance check
// (hr/checks/importance_check.cpp) gives every link's error.
//
// Derivation (piecewise constant, leaves l, links a <- s with transfer K_as,
// B_l = E_l + sum over the ancestors a of l (l included) of
//       rho_a sum_s K_as Bbar_s,  Bbar_s = sum_{m in s} (A_m / A_s) B_m):
// a measurement M = sum_l Y0_l B_l is M = Y^T E with the adjoint
//   Y_m = Y0_m + sum over links a <- s with m in s of (A_m / A_s) K_as rho_a Yhat_a,
//   Yhat_a = sum_{l in a} Y_l,
// i.e. Y = Y0 + T^T (rho Y): a link s -> r that carries B_s to r carries
// importance rho_r K_rs Yhat_r back to s, which spreads it over its leaves
// by area. In densities y = Y / A this is the radiosity gather turned round,
//   g_s = (1 / A_s) sum_{links r <- s} K_rs rho_r A_r yhat_r
//       = sum_r rho_r F_sr yhat_r   (reciprocity A_r F_rs = A_s F_sr),
// Smits et al.'s importance equation, pushed down unchanged and pulled up as
// area-weighted means like radiosity (hr/gather.cpp). Y_s = dM/dE_s: an
// error dB in the radiosity gathered at r changes M by y_r A_r dB.
// rho is the luminance of the element's reflectance (one scalar adjoint for
// the luminance image). Clusters: a receiving cluster's rho A yhat is the sum
// over its surfaces; a sending cluster spreads its importance by area (the
// oriented model's cosine hand-over is not transposed: an approximation).
//
// Sources Y0 (hr.importance):
//   camera   every pixel of an hr.importance_pixels image of the render
//            camera (render.eye/target or the scene's; render.width/height's
//            aspect) adds 1/N to the element its primary ray hits (the image
//            mean of B/pi, up to the constant 1/pi); scaled so the mean
//            density over the root patches hit is 1.
//   regions  density 1 on the leaves hr.importance_regions selects.
// The weight of element e is w_e = yhat_e / uhat_e, with u the importance of
// Y0 = 1 on every surface solved on the same links: with every surface
// selected y = u bit for bit and every weight is exactly 1, so the
// view-independent solve comes back (the usual eps meaning); elsewhere w is
// the share of e's effect on all surfaces that reaches the view.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/types.h"
#include "scene/scene.h"

namespace hrad::transport {
class Visibility;
}

namespace hrad::hr {

class Hierarchy;
struct Link;

/// hr.importance_regions: items separated by ';' (a leaf is selected when any
/// item selects it): `all`, `material NAME`, `patch N` or `patch N-M`
/// (root patch ids, inclusive), `box x0 y0 z0 x1 y1 z1` (leaves whose
/// centroid is inside the axis-aligned box).
struct ImportanceRegions {
    bool all = false;
    std::vector<std::string> materials;
    std::vector<std::pair<uint32_t, uint32_t>> patchRanges;
    std::vector<std::pair<Vec3, Vec3>> boxes;
    SourceLocation where;
    /// Parses `text`; bad input throws InputError at `where`.
    static ImportanceRegions parse(const std::string& text, const SourceLocation& where);
};

struct ImportanceSettings {
    enum class Mode { Off, Camera, Regions };
    Mode mode = Mode::Off;
    ImportanceRegions regions;
    int pixels = 256;        ///< hr.importance_pixels: the importance image's longer side
    double tolerance = 1e-6; ///< hr.importance_tolerance: relative change that stops the sweeps
    /// Set by the caller for Mode::Camera (experiments/solvers.cpp): the
    /// render camera and its image's aspect (width, height).
    std::optional<scene::Camera> camera;
    int width = 0, height = 0;
    SourceLocation where;
    static ImportanceSettings fromParams(const Params& p);
};

const char* importanceModeName(ImportanceSettings::Mode m);

/// Camera importance sources: one hit per pixel, on a root patch at (u, v).
struct ImportanceHit {
    uint32_t patch;
    float u, v;
};

/// Primary-ray hits of an image `width` x `height` of `camera` (render/camera.h
/// CameraFrame's pixel convention, pixel centres).
std::vector<ImportanceHit> cameraHits(const scene::Scene& scene,
                                      const transport::Visibility& visibility,
                                      const scene::Camera& camera, int width, int height);

/// The importance of one hierarchy and its links, and the weights.
class ImportanceField {
  public:
    explicit ImportanceField(const ImportanceSettings& s) : s_(s) {}
    /// Solves y (the sources) and u (every surface) on the links (recv[i]
    /// receives links[i]) of h; the camera's hits are traced once.
    void solve(const Hierarchy& h, const transport::Visibility* visibility,
               const std::vector<uint32_t>& recv, const std::vector<Link>& links);
    /// w_e = yhat_e / uhat_e; an element made after solve() takes its
    /// nearest solved ancestor's (its density is the ancestor's).
    double weight(const Hierarchy& h, uint32_t e) const;
    /// Area-weighted mean importance density of node e (the sources' adjoint).
    double density(uint32_t e) const { return yhat_[e]; }
    int sweeps() const { return sweeps_; }
    const std::vector<double>& weights() const { return w_; }

  private:
    /// Source densities on the current leaves.
    std::vector<double> sources(const Hierarchy& h, bool everything) const;
    /// Jacobi sweeps of the adjoint from `y0`; returns yhat per node.
    std::vector<double> adjoint(const Hierarchy& h, const std::vector<double>& y0,
                                const std::vector<uint32_t>& recv, const std::vector<Link>& links);
    bool selected(const Hierarchy& h, uint32_t leaf) const;

    ImportanceSettings s_;
    std::vector<ImportanceHit> hits_;
    bool traced_ = false;
    double hitScale_ = 0.0;  ///< Y0 per hit: visible root-patch area / pixels
    std::vector<double> yhat_, w_;
    int sweeps_ = 0;
};

}  // namespace hrad::hr
