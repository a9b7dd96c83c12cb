// Form factors between elements (see formfactor.h for the notation).
//
// Rules (FormFactorSettings::rule):
//   "gauss"        F_rs = 1/A_r sum_i w_i J_i F_{dA(x_i) -> A_s}: an n x n
//                  Gauss-Legendre rule on the receiver (transport/quadrature.h)
//                  and the inner integral over the sender done exactly by the
//                  contour integral (pointToPolygon). Because the inner integral
//                  is exact, the integrand of the outer rule is bounded even for
//                  elements that share an edge (only its derivative has a log
//                  singularity there), so the rule converges for adjacent
//                  elements, slowly near the shared edge. Cohen & Wallace 1993,
//                  sec. 4.9 ("area-to-area from differential area-to-area").
//   "gauss-gauss"  F_rs = 1/A_r sum_i sum_j w_i w_j cos_i cos_j / (pi r_ij^2):
//                  point-to-point kernel with an n x n rule on the receiver and
//                  an m x m rule on the sender (m = sender_points). Cheap and
//                  accurate for well-separated elements, poor for touching ones
//                  (the kernel is unbounded there).
//   "centroid"     one point on each: F_rs = A_s cos_r cos_s / (pi r^2) at the
//                  centroids (can exceed 1 for near elements; the coarsest rule).
// Settings: rule (string, "gauss"), points (int 1..16, 3), sender_points
// (int 1..16, 3), vis_rays (int 0..1024, 16), vis_sampling (area |
// solid_angle).
//
// Visibility: F = unoccluded F x the kernel-weighted fraction of vis_rays
// segments that are unblocked (the "visibility factored out" approximation,
// Cohen & Wallace 1993 sec. 4.10, with each segment weighted by the
// point-to-point kernel: see areaVisibility), or, by default (vis_sampling =
// solid_angle), half the segments from stratified points of each element
// along directions over the other's solid angle, weighted by multiple
// importance sampling (solidAngleVisibility; Arvo 1995, Veach & Guibas 1995).
// Area-uniform segment ends are stratified jittered samples on both
// elements (quadrature.h stratifiedSquare), drawn from a Pcg32 seeded with
// hashIds(lo.id, hi.id) where (lo, hi) is the pair ordered by id, and segments
// always run from lo to hi: the visibility of (r,s) and (s,r) is bitwise the
// same, so reciprocity A_r F_rs = A_s F_sr holds with visibility up to the
// quadrature error of the unoccluded part, and results do not depend on
// threads or call order. Samples are shrunk towards the element centre by a
// relative 1e-5 so that float rounding of Embree's geometry cannot put a
// segment end behind an adjacent patch.
//
// Point range: compute() also returns the min and max of the values its outer
// rule averages, the point-to-element form factors F_{dA(x_i) -> s} at the
// receiver points x_i (pointMin / pointMax); pointRange() returns the same
// without casting visibility rays. Error-driven refinement oracles use them as
// sample estimates of the variation of the kernel over the receiver
// (Lischinski, Tampieri & Greenberg 1994; Bekaert & Willems 1996).
//
// Everything here is const and allocation-free per call: rule points live in
// fixed stack arrays (at most 16 x 16), visibility segments in batches of 64.
#include "transport/formfactor.h"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "transport/quadrature.h"
#include "transport/pair_visibility.h"

namespace hrad::transport {

namespace {

constexpr int kMaxRulePoints = kMaxGaussPoints * kMaxGaussPoints;
using detail::kMaxVisRays;

/// Geometry of one element gathered once per call.
struct ElemGeom {
    const scene::Patch* patch = nullptr;
    scene::Domain dom{};
    Vec3 c[4];
    int n = 0;
    Vec3 normal{0.0};
    Vec3 center{0.0};  ///< mean of the corners (bounding sphere centre)
    double radius = 0.0;
    double area = 0.0;
};

ElemGeom makeGeom(const scene::Scene& sc, const ElementRef& e) {
    HRAD_DCHECK(e.patch < sc.patches.size());
    ElemGeom g;
    g.patch = &sc.patches[e.patch];
    g.dom = e.dom;
    g.n = scene::elementCorners(*g.patch, e.dom, g.c);
    g.normal = g.patch->normal;
    Vec3 m(0.0);
    for (int i = 0; i < g.n; ++i) m += g.c[i];
    g.center = m / double(g.n);
    double r2 = 0.0;
    for (int i = 0; i < g.n; ++i) {
        Vec3 d = g.c[i] - g.center;
        r2 = std::max(r2, glm::dot(d, d));
    }
    g.radius = std::sqrt(r2);
    g.area = scene::elementArea(*g.patch, e.dom);
    return g;
}

/// Signed distances of b's corners to a's plane: max over corners.
double maxHeightAbove(const ElemGeom& plane, const ElemGeom& other) {
    double h = -1e300;
    for (int i = 0; i < other.n; ++i)
        h = std::max(h, glm::dot(other.c[i] - plane.center, plane.normal));
    return h;
}

bool facingGeom(const ElemGeom& r, const ElemGeom& s) {
    // "Strictly in front" up to a tolerance relative to the element sizes, so
    // that coplanar elements (round-off heights ~1e-16) never count as facing.
    double tol = 1e-10 * (r.radius + s.radius);
    return maxHeightAbove(r, s) > tol && maxHeightAbove(s, r) > tol;
}

using detail::kernel;

double sumLambert(const Vec3& p, const Vec3& n, const Vec3* poly, int count) {
    // Lambert / Nusselt contour integral (Cohen & Wallace 1993 eq. 4.18; Baum,
    // Rushmeier & Winget 1989): F = 1/(2 pi) sum_k gamma_k n . (R_k x R_k+1)/|R_k x R_k+1|
    // with gamma_k the angle between R_k and R_k+1, here as
    // n . (R_k x R_k+1) * atan2(|R_k x R_k+1|, R_k . R_k+1) / |R_k x R_k+1|.
    double sum = 0.0;
    for (int k = 0; k < count; ++k) {
        Vec3 a = poly[k] - p, b = poly[(k + 1) % count] - p;
        Vec3 c = glm::cross(a, b);
        double s = glm::length(c);
        double d = glm::dot(a, b);
        double nc = glm::dot(n, c);
        if (s > 1e-300) {
            sum += nc * std::atan2(s, d) / s;
        }
        // s == 0: collinear with p; the edge subtends no solid angle (or p lies
        // on the edge, a measure-zero case) and contributes nothing.
    }
    return std::fabs(sum) / (2.0 * kPi);
}

}  // namespace

// ---- closed forms -------------------------------------------------------------

double pointToPolygon(const Vec3& p, const Vec3& n, const Vec3* poly, int count) {
    if (count < 3) return 0.0;
    // Clip the polygon to the half-space in front of p's tangent plane
    // (Sutherland-Hodgman against one plane): the part behind cannot be seen
    // and would contribute negative cosines to the contour integral.
    constexpr int kStack = 32;
    Vec3 stackBuf[2 * kStack + 2];
    std::vector<Vec3> heapBuf;
    Vec3* out = stackBuf;
    if (count > kStack) {
        heapBuf.resize(2 * size_t(count) + 2);
        out = heapBuf.data();
    }
    int m = 0;
    bool anyBehind = false, anyFront = false;
    for (int k = 0; k < count; ++k) {
        double h = glm::dot(poly[k] - p, n);
        anyBehind |= h < 0.0;
        anyFront |= h > 0.0;
    }
    if (!anyFront) return 0.0;
    if (!anyBehind) return sumLambert(p, n, poly, count);
    for (int k = 0; k < count; ++k) {
        const Vec3& a = poly[k];
        const Vec3& b = poly[(k + 1) % count];
        double ha = glm::dot(a - p, n), hb = glm::dot(b - p, n);
        if (ha >= 0.0) out[m++] = a;
        if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0)) {
            double t = ha / (ha - hb);
            out[m++] = a + t * (b - a);
        }
    }
    if (m < 3) return 0.0;
    return sumLambert(p, n, out, m);
}

double parallelRectangles(double w, double h, double d) {
    // Howell C-11 (Hottel): X = w/d, Y = h/d,
    // F = 2/(pi X Y) [ ln sqrt((1+X^2)(1+Y^2)/(1+X^2+Y^2))
    //                  + X sqrt(1+Y^2) atan(X/sqrt(1+Y^2)) + Y sqrt(1+X^2) atan(Y/sqrt(1+X^2))
    //                  - X atan X - Y atan Y ].
    double X = w / d, Y = h / d;
    double X2 = X * X, Y2 = Y * Y;
    double sx = std::sqrt(1.0 + X2), sy = std::sqrt(1.0 + Y2);
    double t = 0.5 * (std::log1p(X2) + std::log1p(Y2) - std::log1p(X2 + Y2)) +
               X * sy * std::atan(X / sy) + Y * sx * std::atan(Y / sx) - X * std::atan(X) -
               Y * std::atan(Y);
    return 2.0 / (kPi * X * Y) * t;
}

double perpendicularRectangles(double w, double h, double l) {
    // Howell C-14: W = w/l, H = h/l (surface 1 has width w),
    // F_12 = 1/(pi W) [ W atan(1/W) + H atan(1/H) - sqrt(H^2+W^2) atan(1/sqrt(H^2+W^2))
    //   + 1/4 ln{ (1+W^2)(1+H^2)/(1+W^2+H^2)
    //             [W^2 (1+W^2+H^2) / ((1+W^2)(W^2+H^2))]^(W^2)
    //             [H^2 (1+W^2+H^2) / ((1+H^2)(W^2+H^2))]^(H^2) } ].
    double W = w / l, H = h / l;
    double W2 = W * W, H2 = H * H, S = W2 + H2, sS = std::sqrt(S);
    double lg = std::log1p(W2) + std::log1p(H2) - std::log1p(S) +
                W2 * (std::log(W2) + std::log1p(S) - std::log1p(W2) - std::log(S)) +
                H2 * (std::log(H2) + std::log1p(S) - std::log1p(H2) - std::log(S));
    double t =
        W * std::atan(1.0 / W) + H * std::atan(1.0 / H) - sS * std::atan(1.0 / sS) + 0.25 * lg;
    return t / (kPi * W);
}

double pointToDisc(double senderArea, double dist2, double cosR, double cosS) {
    cosR = std::max(cosR, 0.0);
    cosS = std::max(cosS, 0.0);
    double denom = kPi * dist2 + senderArea;
    if (!(denom > 0.0)) return 0.0;
    return senderArea * cosR * cosS / denom;
}

// ---- settings -------------------------------------------------------------------

FormFactorSettings FormFactorSettings::fromParams(const Params& params, const std::string& prefix) {
    return fromParams(params, prefix, FormFactorSettings{});
}

FormFactorSettings FormFactorSettings::fromParams(const Params& params, const std::string& prefix,
                                                  const FormFactorSettings& defaults) {
    Params::Scope scope(params, "form factors (" + prefix + ")");
    FormFactorSettings s = defaults;
    s.rule = params.getEnum({prefix + ".rule",
                             "form-factor quadrature: gauss (points on the receiver, exact polygon "
                             "on the sender), gauss-gauss, or centroid"},
                            s.rule, {"gauss", "gauss-gauss", "centroid"});
    s.points = int(
        params.getInt({prefix + ".points",
                       "quadrature points per axis on the receiver; raise for near or large links"},
                      s.points, 1, kMaxGaussPoints));
    s.senderPoints = int(params.getInt(
        {prefix + ".sender_points", "quadrature points per axis on the sender (gauss-gauss)"},
        s.senderPoints, 1, kMaxGaussPoints));
    s.visRays = int(
        params.getInt({prefix + ".vis_rays",
                       "visibility rays per link (0: assume visible); raise against shadow noise"},
                      s.visRays, 0, kMaxVisRays));
    s.visSampling = params.getEnum({prefix + ".vis_sampling",
                                    "where the visibility rays go: area (area-uniform ends) or "
                                    "solid_angle (directions over each end's solid angle, "
                                    "multiple importance sampling)"},
                                   s.visSampling == VisSampling::SolidAngle ? std::string("solid_angle")
                                                                           : std::string("area"),
                                   {"area", "solid_angle"}) == "solid_angle"
                        ? VisSampling::SolidAngle
                        : VisSampling::Area;
    s.adaptiveDepth = int(params.getInt(
        {prefix + ".adaptive_depth", "adaptive quadrature: subdivision levels at most (0: off)"},
        s.adaptiveDepth, 0, 8));
    s.adaptiveTol = params.getDouble(
        {prefix + ".adaptive_tol", "adaptive quadrature: relative tolerance between levels"},
        s.adaptiveTol, 1e-12, 1.0);
    return s;
}

std::string FormFactorSettings::describe() const {
    return fmt::format("rule={} points={} sender_points={} vis_rays={} vis_sampling={} "
                       "adaptive_depth={} adaptive_tol={}",
                       rule, points, senderPoints, visRays,
                       visSampling == VisSampling::SolidAngle ? "solid_angle" : "area",
                       adaptiveDepth, adaptiveTol);
}

// ---- engine ---------------------------------------------------------------------

namespace {
enum class Rule : int { Gauss, GaussGauss, Centroid };

Rule parseRule(const std::string& r) {
    if (r == "gauss") return Rule::Gauss;
    if (r == "gauss-gauss") return Rule::GaussGauss;
    if (r == "centroid") return Rule::Centroid;
    throwInputError(SourceLocation{},
                    "form factor rule '{}' is not one of: gauss, gauss-gauss, centroid", r);
}

}  // namespace

FormFactorEngine::FormFactorEngine(const scene::Scene& scene, const Visibility* visibility,
                                   FormFactorSettings settings)
    : scene_(&scene), visibility_(visibility), settings_(std::move(settings)) {
    parseRule(settings_.rule);
    auto range = [](const char* key, int v, int lo, int hi) {
        if (v < lo || v > hi)
            throwInputError(SourceLocation{},
                            "form factor setting '{}' = {} is out of range [{}, {}]", key, v, lo,
                            hi);
    };
    range("points", settings_.points, 1, kMaxGaussPoints);
    range("sender_points", settings_.senderPoints, 1, kMaxGaussPoints);
    range("vis_rays", settings_.visRays, 0, kMaxVisRays);
    range("adaptive_depth", settings_.adaptiveDepth, 0, 8);
    if (!(settings_.adaptiveTol > 0.0))
        throwInputError(SourceLocation{}, "form factor setting 'adaptive_tol' must be > 0");
    (void)gaussLegendre01(1);  // build the tables now rather than in the first hot call
}

namespace {
/// Unoccluded F_rs of two facing elements by the given rule, with the min and
/// max of the per-receiver-point values F_{dA(x_i) -> s} whose weighted mean
/// it is (the weights of elementGaussPoints are positive and sum to A_r).
/// Tracking min/max does not change the summation, so F is bitwise the same
/// whether or not the range is wanted.
double ruleF(const ElemGeom& gr, const ElemGeom& gs, Rule rule, const FormFactorSettings& st,
             PointRange& range) {
    double F = 0.0;
    double lo = 1e300, hi = -1e300;
    if (rule == Rule::Centroid) {
        Vec3 x = scene::elementCentroid(*gr.patch, gr.dom),
             y = scene::elementCentroid(*gs.patch, gs.dom);
        F = gs.area * kernel(x, gr.normal, y, gs.normal);
        lo = hi = F;
    } else {
        Vec3 xr[kMaxRulePoints];
        double wr[kMaxRulePoints];
        int nr = elementGaussPoints(*gr.patch, gr.dom, st.points, xr, wr);
        if (rule == Rule::Gauss) {
            // Receiver points behind the sender's plane see its back: 0.
            auto gaussSum = [&](const Vec3* x, const double* w, int count) {
                double sum = 0.0;
                for (int i = 0; i < count; ++i) {
                    double g = glm::dot(x[i] - gs.center, gs.normal) <= 0.0
                                   ? 0.0
                                   : pointToPolygon(x[i], gr.normal, gs.c, gs.n);
                    lo = std::min(lo, g);
                    hi = std::max(hi, g);
                    sum += w[i] * g;
                }
                return sum;
            };
            double sum = gaussSum(xr, wr, nr);
            // Near pairs: the point form factor varies steeply over the
            // receiver (it has a log singularity at a shared edge), so one
            // n x n rule can be off by several per cent. When the bounding
            // spheres are closer than the receiver's radius, compare the rule
            // with the sum of the rule on the four children and recurse into
            // the children (adaptive quadrature, e.g. Davis & Rabinowitz
            // 1984 ch. 6) until they agree to adaptive_tol or adaptive_depth
            // levels are reached.
            double gap = glm::length(gs.center - gr.center) - gr.radius - gs.radius;
            if (st.adaptiveDepth > 0 && gap < gr.radius) {
                const scene::PatchKind kind = gr.patch->kind;
                std::function<double(const scene::Domain&, double, int)> refine =
                    [&](const scene::Domain& d, double whole, int depth) -> double {
                    scene::Domain cd[4];
                    double part[4], total = 0.0;
                    Vec3 xc[kMaxRulePoints];
                    double wc[kMaxRulePoints];
                    for (int c = 0; c < 4; ++c) {
                        cd[c] = scene::childDomain(kind, d, c);
                        int m = elementGaussPoints(*gr.patch, cd[c], st.points, xc, wc);
                        part[c] = gaussSum(xc, wc, m);
                        total += part[c];
                    }
                    if (std::abs(total - whole) <= st.adaptiveTol * std::abs(total) ||
                        depth + 1 >= st.adaptiveDepth)
                        return total;
                    total = 0.0;
                    for (int c = 0; c < 4; ++c) total += refine(cd[c], part[c], depth + 1);
                    return total;
                };
                sum = refine(gr.dom, sum, 0);
            }
            F = sum / gr.area;
        } else {
            Vec3 ys[kMaxRulePoints];
            double ws[kMaxRulePoints];
            int ns = elementGaussPoints(*gs.patch, gs.dom, st.senderPoints, ys, ws);
            double sum = 0.0;
            for (int i = 0; i < nr; ++i) {
                double inner = 0.0;
                for (int j = 0; j < ns; ++j)
                    inner += ws[j] * kernel(xr[i], gr.normal, ys[j], gs.normal);
                lo = std::min(lo, inner);
                hi = std::max(hi, inner);
                sum += wr[i] * inner;
            }
            F = sum / gr.area;
        }
    }
    range.min = lo <= hi ? lo : 0.0;
    range.max = lo <= hi ? hi : 0.0;
    return F;
}
}  // namespace

FormFactorResult FormFactorEngine::compute(const ElementRef& r, const ElementRef& s) const {
    FormFactorResult res;
    ElemGeom gr = makeGeom(*scene_, r), gs = makeGeom(*scene_, s);
    if (!facingGeom(gr, gs) || !(gr.area > 0.0)) {
        res.F = res.unoccludedF = 0.0;
        return res;  // visibility 1 (not evaluated), no rays
    }

    const Rule rule = parseRule(settings_.rule);  // validated in the constructor
    PointRange range;
    double F = ruleF(gr, gs, rule, settings_, range);
    res.pointMin = range.min;
    res.pointMax = range.max;
    res.unoccludedF = F;
    res.F = F;
    if (F > 0.0 && settings_.visRays > 0 && visibility_) {
        detail::VisEstimate v =
            detail::pairVisibility(*visibility_, *scene_, r, s, settings_.visRays, settings_.visSampling);
        res.rays = v.cast;
        res.visibility = v.fraction;
        res.partial = v.partial;
        res.F = F * res.visibility;
    }
    return res;
}

PointRange FormFactorEngine::pointRange(const ElementRef& r, const ElementRef& s) const {
    PointRange range;
    ElemGeom gr = makeGeom(*scene_, r), gs = makeGeom(*scene_, s);
    if (!facingGeom(gr, gs) || !(gr.area > 0.0)) return range;
    // The rule's interior points, then the receiver's corners and edge
    // midpoints: the point form factor is smooth inside the receiver and
    // takes its extremes on the boundary nearest to and farthest from the
    // sender (at a shared edge it peaks on the edge itself), which interior
    // Gauss points miss by up to the whole variation (Lischinski, Smits &
    // Greenberg 1994 bound the kernel over the receiver's extent; Holzschuch
    // & Sillion 1998 locate its extremes on the boundary). Boundary points
    // are moved towards the centroid by a relative 1e-6 so that a point on
    // an edge shared with the sender stays off the sender's edge line.
    ruleF(gr, gs, parseRule(settings_.rule), settings_, range);
    double lo = range.min, hi = range.max;
    auto probe = [&](const Vec3& x) {
        Vec3 p = x + 1e-6 * (gr.center - x);
        double g = glm::dot(p - gs.center, gs.normal) <= 0.0
                       ? 0.0
                       : pointToPolygon(p, gr.normal, gs.c, gs.n);
        lo = std::min(lo, g);
        hi = std::max(hi, g);
    };
    for (int i = 0; i < gr.n; ++i) {
        probe(gr.c[i]);
        probe(0.5 * (gr.c[i] + gr.c[(i + 1) % gr.n]));
    }
    range.min = lo;
    range.max = hi;
    return range;
}

int FormFactorEngine::kernelSamplePoints(const ElementRef& r,
                                         Vec3 out[kMaxKernelSamples]) const {
    // The point form factor is smooth inside the receiver and takes its
    // extremes on the boundary nearest to and farthest from the sender (at
    // an edge shared with the sender it peaks on the edge itself), so the
    // corners and edge midpoints are sampled, not only interior quadrature
    // points (Holzschuch & Sillion 1998 locate the kernel's extremes on the
    // receiver's boundary). The 1e-6 inset keeps a point on an edge shared
    // with the sender off the sender's edge line, where the contour integral
    // has a 0/0 term.
    ElemGeom g = makeGeom(*scene_, r);
    Vec3 c = scene::elementCentroid(*g.patch, g.dom);
    int m = 0;
    for (int i = 0; i < g.n; ++i) {
        out[m++] = g.c[i] + 1e-6 * (c - g.c[i]);
        Vec3 mid = 0.5 * (g.c[i] + g.c[(i + 1) % g.n]);
        out[m++] = mid + 1e-6 * (c - mid);
    }
    out[m++] = c;
    return m;
}

int FormFactorEngine::kernelSamples(const ElementRef& r, const ElementRef& s,
                                    double out[kMaxKernelSamples]) const {
    Vec3 x[kMaxKernelSamples];
    int m = kernelSamplePoints(r, x);
    kernelSamplesAt(x, m, scene_->patches[r.patch].normal, s, out);
    return m;
}

void FormFactorEngine::kernelSamplesAt(const Vec3* x, int m, const Vec3& n, const ElementRef& s,
                                       double* out) const {
    const scene::Patch& ps = scene_->patches[s.patch];
    Vec3 cs[4];
    int ns = scene::elementCorners(ps, s.dom, cs);
    Vec3 sc(0.0);
    for (int i = 0; i < ns; ++i) sc += cs[i];
    sc /= double(ns);
    for (int k = 0; k < m; ++k)
        out[k] = glm::dot(x[k] - sc, ps.normal) <= 0.0 ? 0.0 : pointToPolygon(x[k], n, cs, ns);
}

double FormFactorEngine::estimate(const ElementRef& r, const ElementRef& s) const {
    const scene::Patch& pr = scene_->patches[r.patch];
    const scene::Patch& ps = scene_->patches[s.patch];
    Vec3 x = scene::elementCentroid(pr, r.dom), y = scene::elementCentroid(ps, s.dom);
    Vec3 d = y - x;
    double d2 = glm::dot(d, d);
    if (!(d2 > 0.0)) return 0.0;
    double inv = 1.0 / std::sqrt(d2);
    double cr = glm::dot(pr.normal, d) * inv, cs = -glm::dot(ps.normal, d) * inv;
    return pointToDisc(scene::elementArea(ps, s.dom), d2, cr, cs);
}

double FormFactorEngine::upperBound(const ElementRef& r, const ElementRef& s) const {
    // Elements of one planar patch never see each other.
    if (r.patch == s.patch) return 0.0;
    ElemGeom gr = makeGeom(*scene_, r), gs = makeGeom(*scene_, s);
    // Exact (tolerance-free) back-facing test: if no point of s is strictly in
    // front of r (or vice versa) every cosine product is <= 0 and F_rs = 0.
    if (maxHeightAbove(gr, gs) <= 0.0 || maxHeightAbove(gs, gr) <= 0.0) return 0.0;
    double bound = 1.0;  // F_rs <= 1 always
    // Reciprocity: A_r F_rs = A_s F_sr <= A_s, so F_rs <= A_s / A_r.
    if (gr.area > 0.0) bound = std::min(bound, gs.area / gr.area);
    // Bounding spheres (centre = mean of corners, radius with a relative slack
    // against round-off) of the two convex elements.
    double rr = gr.radius * (1.0 + 1e-9), rs = gs.radius * (1.0 + 1e-9);
    Vec3 u = gs.center - gr.center;
    double L = glm::length(u);
    if (L - rr > rs) {
        // Sphere cap: from any x on r, s lies in a cone of half-angle alpha
        // around x -> c_s with sin alpha = rs / |x - c_s| <= rs / (L - rr). The
        // projected solid angle of a set of directions of given solid angle is
        // largest for a cap centred on the normal (cos decreases with the polar
        // angle), which gives pi sin^2 alpha; so F_{dA_x -> s} <= sin^2 alpha and
        // F_rs, an average of these, obeys the same bound.
        double sa = rs / (L - rr);
        bound = std::min(bound, sa * sa);
    }
    double gap = L - rr - rs;
    if (gap > 0.0) {
        // Kernel bound: every x in r, y in s has |y - x| >= gap and the direction
        // x -> y lies in the cone around u of half-angle beta = asin((rr+rs)/L),
        // so cos_r <= cos(max(0, theta_r - beta)), likewise for s. Then
        // F_rs = 1/A_r int int cos cos/(pi r^2) <= A_s cosmax_r cosmax_s / (pi gap^2).
        u /= L;
        double beta = std::asin(std::min(1.0, (rr + rs) / L));
        double thr = std::acos(std::clamp(glm::dot(gr.normal, u), -1.0, 1.0));
        double ths = std::acos(std::clamp(-glm::dot(gs.normal, u), -1.0, 1.0));
        auto cosMax = [&](double th) {
            double a = th - beta;
            if (a <= 0.0) return 1.0;
            if (a >= 0.5 * kPi) return 0.0;
            return std::cos(a);
        };
        double kb = gs.area * cosMax(thr) * cosMax(ths) / (kPi * gap * gap);
        bound = std::min(bound, kb);
    }
    return std::clamp(bound, 0.0, 1.0);
}

double FormFactorEngine::visibilityFraction(const ElementRef& r, const ElementRef& s, int rays,
                                            uint32_t* raysCast, uint64_t salt,
                                            bool* partial) const {
    if (raysCast) *raysCast = 0;
    if (partial) *partial = false;
    if (!visibility_ || rays <= 0) return 1.0;
    detail::VisEstimate v = detail::pairVisibility(*visibility_, *scene_, r, s, rays, settings_.visSampling, salt);
    if (raysCast) *raysCast = v.cast;
    if (partial) *partial = v.partial;
    return v.fraction;
}

bool FormFactorEngine::facing(const ElementRef& r, const ElementRef& s) const {
    return facingGeom(makeGeom(*scene_, r), makeGeom(*scene_, s));
}

double FormFactorEngine::pointToElement(const Vec3& p, const Vec3& n, const ElementRef& s) const {
    const scene::Patch& ps = scene_->patches[s.patch];
    Vec3 c[4];
    int k = scene::elementCorners(ps, s.dom, c);
    Vec3 m(0.0);
    for (int i = 0; i < k; ++i) m += c[i];
    if (glm::dot(p - m / double(k), ps.normal) <= 0.0) return 0.0;
    return pointToPolygon(p, n, c, k);
}

}  // namespace hrad::transport
