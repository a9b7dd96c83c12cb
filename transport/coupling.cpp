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
}  // namespace

CouplingEngine::CouplingEngine(const scene::Scene& scene, const Visibility* visibility,
                               const FormFactorEngine& ff, const scene::BasisSet& basis, int points)
    : scene_(&scene), vis_(visibility), ff_(&ff), basis_(&basis),
      quad_(scene::referenceRule(scene::PatchKind::Quad, points)),
      tri_(scene::referenceRule(scene::PatchKind::Triangle, points)) {
    HRAD_CHECK(points >= 1);
}

uint32_t CouplingEngine::compute(const ElementRef& r, const ElementRef& s, double visibility,
                                 bool partial, float* out) const {
    const int nb = basis_->size();
    std::fill(out, out + nb * nb, 0.f);
    if (!(visibility > 0.0)) return 0;
    const scene::Patch& pr = scene_->patches[r.patch];
    const scene::Patch& ps = scene_->patches[s.patch];
    const scene::QuadratureRule& qr = pr.kind == scene::PatchKind::Quad ? quad_ : tri_;
    const scene::QuadratureRule& qs = ps.kind == scene::PatchKind::Quad ? quad_ : tri_;
    const scene::Basis& br = basis_->of(pr.kind);
    const scene::Basis& bs = basis_->of(ps.kind);
    const size_t nr = qr.size(), ns = qs.size();
    // Receiver points and basis values; sender points, A_s j_s(eta) w_k and basis values.
    std::vector<Vec3> xr(nr), ys(ns);
    std::vector<double> phiR(nr * size_t(nb)), phiS(ns * size_t(nb)), ws(ns);
    for (size_t i = 0; i < nr; ++i) {
        xr[i] = scene::elementPoint(pr, r.dom, qr.points[i].x, qr.points[i].y);
        br.eval(qr.points[i].x, qr.points[i].y, &phiR[i * size_t(nb)]);
    }
    // The normalised measure of the reference triangle is 2 da db.
    const double measure = ps.kind == scene::PatchKind::Quad ? 1.0 : 0.5;
    for (size_t k = 0; k < ns; ++k) {
        ys[k] = scene::elementPoint(ps, s.dom, qs.points[k].x, qs.points[k].y);
        bs.eval(qs.points[k].x, qs.points[k].y, &phiS[k * size_t(nb)]);
        ws[k] = qs.weights[k] * measure *
                scene::elementJacobian(ps, s.dom, qs.points[k].x, qs.points[k].y);
    }
    // V between every pair of points of a partially visible link.
    std::vector<uint8_t> occ;
    uint32_t rays = 0;
    if (partial && vis_) {
        occ.assign(nr * ns, 0);
        Segment seg[kBatch];
        size_t total = nr * ns;
        for (size_t base = 0; base < total; base += kBatch) {
            size_t n = std::min<size_t>(kBatch, total - base);
            for (size_t m = 0; m < n; ++m) {
                size_t i = (base + m) / ns, k = (base + m) % ns;
                seg[m].a = xr[i];
                seg[m].b = ys[k];
                seg[m].patchA = r.patch;
                seg[m].patchB = s.patch;
            }
            vis_->occluded(seg, n, &occ[base]);
            rays += uint32_t(n);
        }
    }
    const double vconst = partial && vis_ ? 1.0 : visibility;
    std::vector<double> K(size_t(nb * nb), 0.0);
    std::vector<double> inner(static_cast<size_t>(nb), 0.0);
    for (size_t i = 0; i < nr; ++i) {
        std::fill(inner.begin(), inner.end(), 0.0);
        double open = 0.0, all = 0.0;
        for (size_t k = 0; k < ns; ++k) {
            double g = ws[k] * pointKernel(xr[i], pr.normal, ys[k], ps.normal);
            all += g;
            if (!occ.empty() && occ[i * ns + k]) continue;
            open += g;
            for (int b = 1; b < nb; ++b) inner[size_t(b)] += g * phiS[k * size_t(nb) + size_t(b)];
        }
        // Column b = 0: the exact point-to-element form factor, times the
        // kernel-weighted visible fraction of the sender points.
        double frac = occ.empty() ? 1.0 : (all > 0.0 ? open / all : 0.0);
        inner[0] = ff_->pointToElement(xr[i], pr.normal, s) * frac;
        for (int a = 0; a < nb; ++a) {
            double wa = qr.weights[i] * phiR[i * size_t(nb) + size_t(a)] * vconst;
            for (int b = 0; b < nb; ++b) K[size_t(a * nb + b)] += wa * inner[size_t(b)];
        }
    }
    for (int m = 0; m < nb * nb; ++m) out[m] = float(K[size_t(m)]);
    return rays;
}

}  // namespace hrad::transport
