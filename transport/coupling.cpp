#include "transport/coupling.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "scene/element.h"

namespace hrad::transport {

namespace {
/// cos t_x cos t_y / (pi r^2), 0 when either end sees the other's back.
double pointKernel(const Vec3& x, const Vec3& nx, const Vec3& y, const Vec3& ny) {
    Vec3 d = y - x;
    double r2 = glm::dot(d, d);
    if (!(r2 > 0.0)) return 0.0;
    double cx = glm::dot(nx, d), cy = -glm::dot(ny, d);
    if (cx <= 0.0 || cy <= 0.0) return 0.0;
    return cx * cy / (M_PI * r2 * r2);
}
constexpr int kBatch = 64;

/// The rule `base` repeated on each of the 4^levels quadtree sub-elements of
/// the reference domain (weights scaled to keep the total 1).
scene::QuadratureRule compositeRule(scene::PatchKind kind, const scene::QuadratureRule& base,
                                    int levels, std::vector<uint32_t>& cellOf,
                                    std::vector<Vec2>& centres) {
    std::vector<scene::Domain> cells{scene::Domain{}};
    for (int l = 0; l < levels; ++l) {
        std::vector<scene::Domain> next;
        for (const auto& d : cells)
            for (int c = 0; c < 4; ++c) next.push_back(scene::childDomain(kind, d, c));
        cells = std::move(next);
    }
    scene::QuadratureRule r;
    const double w = 1.0 / double(cells.size());
    const double c = kind == scene::PatchKind::Quad ? 0.5 : 1.0 / 3.0;
    cellOf.clear();
    centres.clear();
    for (const auto& d : cells) {
        for (size_t i = 0; i < base.size(); ++i) {
            r.points.push_back(scene::domainParam(d, base.points[i].x, base.points[i].y));
            r.weights.push_back(w * base.weights[i]);
            cellOf.push_back(uint32_t(centres.size()));
        }
        centres.push_back(scene::domainParam(d, c, c));
    }
    return r;
}

double elementRadius(const scene::Patch& p, const scene::Domain& d, const Vec3& centre) {
    Vec3 c[4];
    int n = scene::elementCorners(p, d, c);
    double r2 = 0.0;
    for (int i = 0; i < n; ++i) r2 = std::max(r2, glm::dot(c[i] - centre, c[i] - centre));
    return std::sqrt(r2);
}
}  // namespace

CouplingEngine::CouplingEngine(const scene::Scene& scene, const Visibility* visibility,
                               const FormFactorEngine& ff, const scene::BasisSet& basis, int points,
                               int nearLevels, double checkTolerance)
    : checkTolerance_(checkTolerance),
      scene_(&scene),
      vis_(visibility),
      ff_(&ff),
      basis_(&basis),
      quad_(scene::referenceRule(scene::PatchKind::Quad, points)),
      tri_(scene::referenceRule(scene::PatchKind::Triangle, points)),
      nearQuad_(
          compositeRule(scene::PatchKind::Quad, quad_, nearLevels, nearCellQuad_, cellCentreQuad_)),
      nearTri_(compositeRule(scene::PatchKind::Triangle, tri_, nearLevels, nearCellTri_,
                             cellCentreTri_)) {
    HRAD_CHECK(points >= 1 && nearLevels >= 0);
}

uint32_t CouplingEngine::compute(const ElementRef& r, const ElementRef& s, double visibility,
                                 bool partial, float* out) const {
    const int nb = basis_->size();
    std::fill(out, out + nb * nb, 0.f);
    if (!(visibility > 0.0)) return 0;
    const scene::Patch& pr = scene_->patches[r.patch];
    const scene::Patch& ps = scene_->patches[s.patch];
    Vec3 cr = scene::elementCentroid(pr, r.dom), cs = scene::elementCentroid(ps, s.dom);
    const bool near =
        glm::length(cr - cs) < 1.5 * (elementRadius(pr, r.dom, cr) + elementRadius(ps, s.dom, cs));
    const bool isQuadR = pr.kind == scene::PatchKind::Quad,
               isQuadS = ps.kind == scene::PatchKind::Quad;
    // The column b = 0 always uses the base rule on the receiver: the same
    // points for every sender, so that the exact point form factors to all
    // senders sum to one at each of them and sum_s K^{a0} = delta_a0 in a
    // closed scene (the furnace stays exact). The columns b >= 1 use the
    // composite rules on near pairs.
    const scene::QuadratureRule& q0 = isQuadR ? quad_ : tri_;
    const scene::QuadratureRule& qr = near ? (isQuadR ? nearQuad_ : nearTri_) : q0;
    const scene::QuadratureRule& qs =
        near ? (isQuadS ? nearQuad_ : nearTri_) : (isQuadS ? quad_ : tri_);
    const scene::Basis& br = basis_->of(pr.kind);
    const scene::Basis& bs = basis_->of(ps.kind);
    const size_t ns = qs.size();
    // Sender points, A_s j_s(eta) w_k and basis values. The normalised
    // measure of the reference triangle is 2 da db.
    const double measure = isQuadS ? 1.0 : 0.5;
    std::vector<Vec3> ys(ns);
    std::vector<double> phiS(ns * size_t(nb)), ws(ns);
    for (size_t k = 0; k < ns; ++k) {
        ys[k] = scene::elementPoint(ps, s.dom, qs.points[k].x, qs.points[k].y);
        bs.eval(qs.points[k].x, qs.points[k].y, &phiS[k * size_t(nb)]);
        ws[k] = qs.weights[k] * measure *
                scene::elementJacobian(ps, s.dom, qs.points[k].x, qs.points[k].y);
    }
    // Visibility targets of a partially visible link: the sender points, or
    // for near pairs the centroids of the sender's sub-elements.
    const bool rays = partial && vis_ != nullptr;
    std::vector<Vec3> targets;
    std::vector<uint32_t> cellOf(ns);
    if (rays) {
        if (near) {
            cellOf = isQuadS ? nearCellQuad_ : nearCellTri_;
            for (const Vec2& c : isQuadS ? cellCentreQuad_ : cellCentreTri_)
                targets.push_back(scene::elementPoint(ps, s.dom, c.x, c.y));
        } else {
            targets = ys;
            for (size_t k = 0; k < ns; ++k) cellOf[k] = uint32_t(k);
        }
    }
    uint32_t cast = 0;
    /// V from receiver point x to every target (1 = blocked).
    auto occlusion = [&](const Vec3& x, std::vector<uint8_t>& occ) {
        occ.assign(targets.size(), 0);
        Segment seg[kBatch];
        for (size_t base = 0; base < targets.size(); base += kBatch) {
            size_t n = std::min<size_t>(kBatch, targets.size() - base);
            for (size_t m = 0; m < n; ++m) seg[m] = Segment{x, targets[base + m], r.patch, s.patch};
            vis_->occluded(seg, n, &occ[base]);
            cast += uint32_t(n);
        }
    };
    const double vconst = rays ? 1.0 : visibility;
    std::vector<double> K(size_t(nb * nb), 0.0);
    std::vector<double> inner(static_cast<size_t>(nb), 0.0);
    std::vector<uint8_t> occ;
    double phiR[scene::kMaxBasisSize];
    // Pass 1: column 0 on the base receiver rule; pass 2: columns >= 1 on qr.
    double kernelDev = 0.0, kernelRef = 0.0;
    for (int pass = 0; pass < 2; ++pass) {
        if (pass == 1 && nb == 1) break;
        if (pass == 1 && kernelRef > 0.0 && kernelDev > checkTolerance_ * kernelRef) {
            // The point-to-point rule does not reproduce the exact point form
            // factors (a sliver next to its sender): its higher columns would
            // be wrong, so the link carries the sender's mean only.
            ++fallbacks_;
            break;
        }
        const scene::QuadratureRule& q = pass == 0 ? q0 : qr;
        for (size_t i = 0; i < q.size(); ++i) {
            Vec3 x = scene::elementPoint(pr, r.dom, q.points[i].x, q.points[i].y);
            br.eval(q.points[i].x, q.points[i].y, phiR);
            if (rays) occlusion(x, occ);
            std::fill(inner.begin(), inner.end(), 0.0);
            double open = 0.0, all = 0.0;
            for (size_t k = 0; k < ns; ++k) {
                double g = ws[k] * pointKernel(x, pr.normal, ys[k], ps.normal);
                all += g;
                if (rays && occ[cellOf[k]]) continue;
                open += g;
                if (pass == 1)
                    for (int b = 1; b < nb; ++b)
                        inner[size_t(b)] += g * phiS[k * size_t(nb) + size_t(b)];
            }
            if (pass == 0) {
                // The exact point-to-element form factor, times the
                // kernel-weighted visible fraction of the sender points.
                double frac = rays ? (all > 0.0 ? open / all : 0.0) : 1.0;
                const double exact = ff_->pointToElement(x, pr.normal, s);
                inner[0] = exact * frac;
                kernelDev += q.weights[i] * std::fabs(all - exact);
                kernelRef += q.weights[i] * exact;
            }
            for (int a = 0; a < nb; ++a) {
                double wa = q.weights[i] * phiR[a] * vconst;
                if (pass == 0)
                    K[size_t(a * nb)] += wa * inner[0];
                else
                    for (int b = 1; b < nb; ++b) K[size_t(a * nb + b)] += wa * inner[size_t(b)];
            }
        }
    }
    for (int m = 0; m < nb * nb; ++m) out[m] = float(K[size_t(m)]);
    return cast;
}

void CouplingEngine::projectColumn0(const ElementRef& r, const ElementRef& s, double* K0) const {
    const scene::Patch& pr = scene_->patches[r.patch];
    const scene::QuadratureRule& q = pr.kind == scene::PatchKind::Quad ? quad_ : tri_;
    const scene::Basis& br = basis_->of(pr.kind);
    const int nb = br.size();
    double phi[scene::kMaxBasisSize];
    std::fill(K0, K0 + nb, 0.0);
    for (size_t i = 0; i < q.size(); ++i) {
        Vec3 x = scene::elementPoint(pr, r.dom, q.points[i].x, q.points[i].y);
        double F = ff_->pointToElement(x, pr.normal, s);
        br.eval(q.points[i].x, q.points[i].y, phi);
        for (int a = 0; a < nb; ++a) K0[a] += q.weights[i] * phi[a] * F;
    }
}

double CouplingEngine::projectionResidual(const ElementRef& r, const ElementRef& s) const {
    const scene::Patch& pr = scene_->patches[r.patch];
    const bool isQuad = pr.kind == scene::PatchKind::Quad;
    const scene::Basis& br = basis_->of(pr.kind);
    const int nb = br.size();
    double K0[scene::kMaxBasisSize], phi[scene::kMaxBasisSize];
    projectColumn0(r, s, K0);
    static constexpr double kQuad[9][2] = {{0, 0},   {1, 0},   {1, 1},   {0, 1},    {0.5, 0},
                                           {1, 0.5}, {0.5, 1}, {0, 0.5}, {0.5, 0.5}};
    static constexpr double kTri[7][2] = {
        {0, 0}, {1, 0}, {0, 1}, {0.5, 0}, {0.5, 0.5}, {0, 0.5}, {1.0 / 3.0, 1.0 / 3.0}};
    const int n = isQuad ? 9 : 7;
    const double c = isQuad ? 0.5 : 1.0 / 3.0;
    double worst = 0.0;
    for (int k = 0; k < n; ++k) {
        double a = isQuad ? kQuad[k][0] : kTri[k][0], b = isQuad ? kQuad[k][1] : kTri[k][1];
        a = c + 0.95 * (a - c);
        b = c + 0.95 * (b - c);
        Vec3 x = scene::elementPoint(pr, r.dom, a, b);
        br.eval(a, b, phi);
        double P = 0.0;
        for (int m = 0; m < nb; ++m) P += phi[m] * K0[m];
        worst = std::max(worst, std::fabs(P - ff_->pointToElement(x, pr.normal, s)));
    }
    return worst;
}

int CouplingEngine::residualSamples(const ElementRef& r, const ElementRef& s,
                                    double out[FormFactorEngine::kMaxKernelSamples]) const {
    const scene::Patch& pr = scene_->patches[r.patch];
    const scene::Basis& br = basis_->of(pr.kind);
    const int nb = br.size();
    double K0[scene::kMaxBasisSize], phi[scene::kMaxBasisSize];
    projectColumn0(r, s, K0);
    // The points of FormFactorEngine::kernelSamplePoints in local
    // coordinates: corner i, the midpoint of edge (i, i+1), inset 1e-6
    // towards the centre, then the centre.
    const int nc = pr.kind == scene::PatchKind::Quad ? 4 : 3;
    const Vec2 centre = pr.kind == scene::PatchKind::Quad ? Vec2(0.5) : Vec2(1.0 / 3.0);
    Vec2 pts[FormFactorEngine::kMaxKernelSamples];
    int m = 0;
    for (int i = 0; i < nc; ++i) {
        Vec2 a = scene::cornerLocal(pr.kind, i), b = scene::cornerLocal(pr.kind, (i + 1) % nc);
        pts[m++] = a + 1e-6 * (centre - a);
        Vec2 mid = 0.5 * (a + b);
        pts[m++] = mid + 1e-6 * (centre - mid);
    }
    pts[m++] = centre;
    for (int k = 0; k < m; ++k) {
        Vec3 x = scene::elementPoint(pr, r.dom, pts[k].x, pts[k].y);
        br.eval(pts[k].x, pts[k].y, phi);
        double P = 0.0;
        for (int a = 0; a < nb; ++a) P += phi[a] * K0[a];
        out[k] = ff_->pointToElement(x, pr.normal, s) - P;
    }
    return m;
}

}  // namespace hrad::transport
