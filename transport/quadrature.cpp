#include "transport/quadrature.h"

#include <array>
#include <cmath>

#include "core/error.h"

namespace hrad::transport {

namespace {

// Gauss-Legendre nodes on [-1,1] by Newton's method on the Legendre
// polynomial P_n from the Chebyshev-like initial guess
// cos(pi (i + 3/4) / (n + 1/2)) (Abramowitz & Stegun 22.16.6); weights
// 2 / ((1 - x^2) P_n'(x)^2) (A&S 25.4.29). Converges to machine precision in a
// handful of steps for n <= 16. Mapped to [0,1] with weights halved.
GaussRule buildRule(int n) {
    GaussRule r;
    r.n = n;
    for (int i = 0; i < n; ++i) {
        double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double dp = 1.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = x;
            for (int k = 2; k <= n; ++k) {
                double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            double pn = n == 1 ? x : p1;
            double pnm1 = n == 1 ? 1.0 : p0;
            dp = n * (x * pn - pnm1) / (x * x - 1.0);
            double dx = pn / dp;
            x -= dx;
            if (std::fabs(dx) < 1e-16) break;
        }
        // Recompute the derivative at the converged node for the weight.
        double p0 = 1.0, p1 = x;
        for (int k = 2; k <= n; ++k) {
            double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
            p0 = p1;
            p1 = p2;
        }
        double pn = n == 1 ? x : p1, pnm1 = n == 1 ? 1.0 : p0;
        dp = n * (x * pn - pnm1) / (x * x - 1.0);
        double w = 2.0 / ((1.0 - x * x) * dp * dp);
        // Nodes in increasing order on [0,1].
        r.x[n - 1 - i] = 0.5 * (1.0 + x);
        r.w[n - 1 - i] = 0.5 * w;
    }
    if (n == 1) {
        r.x[0] = 0.5;
        r.w[0] = 1.0;
    }
    return r;
}

struct GaussTables {
    std::array<GaussRule, kMaxGaussPoints + 1> rules;
    GaussTables() {
        for (int n = 1; n <= kMaxGaussPoints; ++n) rules[n] = buildRule(n);
    }
};

}  // namespace

const GaussRule& gaussLegendre01(int n) {
    static const GaussTables tables;  // immutable after thread-safe initialisation
    HRAD_CHECK_MSG(n >= 1 && n <= kMaxGaussPoints, "Gauss rule with {} points", n);
    return tables.rules[n];
}

int elementGaussPoints(const scene::Patch& p, const scene::Domain& d, int n, Vec3* pts, double* w) {
    const GaussRule& g = gaussLegendre01(n);
    int k = 0;
    if (p.kind == scene::PatchKind::Quad) {
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j, ++k) {
                double a = g.x[i], b = g.x[j];
                pts[k] = scene::elementPoint(p, d, a, b);
                w[k] = g.w[i] * g.w[j] * scene::elementJacobian(p, d, a, b);
            }
        return k;
    }
    // Triangle: constant Jacobian; collapsed tensor rule on the unit triangle.
    double jac = scene::elementJacobian(p, d, 0.0, 0.0);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j, ++k) {
            double xi = g.x[i], eta = g.x[j];
            double a = xi, b = eta * (1.0 - xi);
            pts[k] = scene::elementPoint(p, d, a, b);
            w[k] = g.w[i] * g.w[j] * (1.0 - xi) * jac;
        }
    return k;
}

Vec2 squareToElementLocal(scene::PatchKind kind, double s, double t) {
    if (kind == scene::PatchKind::Quad) return {s, t};
    double r = std::sqrt(s);
    return {1.0 - r, t * r};
}

void stratifiedSquare(int count, Pcg32& rng, Vec2* out) {
    if (count <= 0) return;
    HRAD_CHECK(count <= 4096);
    int nx = int(std::ceil(std::sqrt(double(count))));
    while (nx * nx < count) ++nx;
    while ((nx - 1) * (nx - 1) >= count) --nx;
    int ny = (count + nx - 1) / nx;
    int cells = nx * ny;
    // Partial Fisher-Yates: the first `count` entries become a uniformly random
    // subset of distinct cells (in random order, which also decorrelates the
    // pairing of receiver and sender samples).
    uint16_t perm[4096 + 128];
    for (int c = 0; c < cells; ++c) perm[c] = uint16_t(c);
    for (int i = 0; i < count; ++i) {
        int j = i + int(rng.nextU32() % uint32_t(cells - i));
        uint16_t tmp = perm[i];
        perm[i] = perm[j];
        perm[j] = tmp;
    }
    for (int i = 0; i < count; ++i) {
        int c = perm[i];
        int cx = c % nx, cy = c / nx;
        double jx = rng.nextDouble(), jy = rng.nextDouble();
        out[i] = {(cx + jx) / nx, (cy + jy) / ny};
    }
}

}  // namespace hrad::transport
