#include "scene/basis.h"

#include <cmath>

#include "core/error.h"
#include "scene/element.h"

namespace hrad::scene {

const std::vector<std::string>& basisNames() {
    static const std::vector<std::string> names{"constant", "linear", "quadratic", "cubic"};
    return names;
}

int basisDegree(const std::string& name) {
    const auto& n = basisNames();
    for (size_t i = 0; i < n.size(); ++i)
        if (n[i] == name) return int(i);
    HRAD_CHECK(false && "unknown basis name");
    return 0;
}

std::string basisName(int degree) {
    HRAD_CHECK(degree >= 0 && degree <= kMaxBasisDegree);
    return basisNames()[size_t(degree)];
}

void gaussLegendre01(int n, std::vector<double>& x, std::vector<double>& w) {
    HRAD_CHECK(n >= 1 && n <= 64);
    x.assign(size_t(n), 0.0);
    w.assign(size_t(n), 0.0);
    // Newton on P_n from the Chebyshev guesses (Numerical Recipes gauleg).
    for (int i = 0; i < (n + 1) / 2; ++i) {
        double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), pp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p1 = 1.0, p2 = 0.0;
            for (int j = 1; j <= n; ++j) {
                double p3 = p2;
                p2 = p1;
                p1 = ((2.0 * j - 1.0) * z * p2 - (j - 1.0) * p3) / j;
            }
            pp = n * (z * p1 - p2) / (z * z - 1.0);
            double z1 = z;
            z = z1 - p1 / pp;
            if (std::fabs(z - z1) < 1e-16) break;
        }
        double wi = 2.0 / ((1.0 - z * z) * pp * pp);
        // Map [-1, 1] to [0, 1]: the weights sum to 2 there, so w / 2 sums to 1.
        x[size_t(i)] = 0.5 * (1.0 - z);
        x[size_t(n - 1 - i)] = 0.5 * (1.0 + z);
        w[size_t(i)] = w[size_t(n - 1 - i)] = 0.5 * wi;
    }
}

QuadratureRule referenceRule(PatchKind kind, int n) {
    std::vector<double> x, w;
    gaussLegendre01(n, x, w);
    QuadratureRule r;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            if (kind == PatchKind::Quad) {
                r.points.push_back({x[size_t(i)], x[size_t(j)]});
                r.weights.push_back(w[size_t(i)] * w[size_t(j)]);
            } else {
                // Collapsed product; the reference triangle has area 1/2, so
                // the normalised weight is 2 (1 - s) w_i w_j.
                double s = x[size_t(i)], t = x[size_t(j)];
                r.points.push_back({s, (1.0 - s) * t});
                r.weights.push_back(2.0 * (1.0 - s) * w[size_t(i)] * w[size_t(j)]);
            }
        }
    return r;
}

namespace {

/// Legendre polynomials orthonormal on [0, 1], L_0..L_p at x.
void legendre01(int p, double x, double* out) {
    double t = 2.0 * x - 1.0;
    double p0 = 1.0, p1 = t;
    out[0] = 1.0;
    if (p >= 1) out[1] = std::sqrt(3.0) * t;
    for (int n = 2; n <= p; ++n) {
        double p2 = ((2.0 * n - 1.0) * t * p1 - (n - 1.0) * p0) / n;
        p0 = p1;
        p1 = p2;
        out[n] = std::sqrt(2.0 * n + 1.0) * p2;
    }
}

/// Exponents (i, j) of the k-th function: by total degree, then by j.
void exponents(int k, int& i, int& j) {
    int d = 0;
    while (basisSize(d) <= k) ++d;
    j = k - basisSize(d - 1);  // basisSize(-1) = 0
    i = d - j;
}

double ipow(double x, int e) {
    double r = 1.0;
    for (int k = 0; k < e; ++k) r *= x;
    return r;
}

}  // namespace

Basis::Basis(PatchKind kind, int degree) : kind_(kind), degree_(degree), size_(basisSize(degree)) {
    HRAD_CHECK(degree >= 0 && degree <= kMaxBasisDegree);
    if (kind_ == PatchKind::Triangle) {
        // Modified Gram-Schmidt of the monomials, twice (re-orthogonalisation),
        // in the normalised measure with a rule exact for degree 2p.
        QuadratureRule q = referenceRule(kind_, degree_ + 2);
        mono_.assign(size_t(size_), {});
        for (int k = 0; k < size_; ++k) mono_[size_t(k)][size_t(k)] = 1.0;
        auto values = [&](int k, std::vector<double>& v) {
            v.assign(q.size(), 0.0);
            for (size_t m = 0; m < q.size(); ++m)
                for (int j = 0; j < size_; ++j) {
                    int ei, ej;
                    exponents(j, ei, ej);
                    v[m] += mono_[size_t(k)][size_t(j)] * ipow(q.points[m].x, ei) *
                            ipow(q.points[m].y, ej);
                }
        };
        auto dot = [&](const std::vector<double>& a, const std::vector<double>& b) {
            double s = 0;
            for (size_t m = 0; m < q.size(); ++m) s += q.weights[m] * a[m] * b[m];
            return s;
        };
        std::vector<double> vk, vl;
        for (int k = 0; k < size_; ++k) {
            for (int pass = 0; pass < 2; ++pass)
                for (int l = 0; l < k; ++l) {
                    values(k, vk);
                    values(l, vl);
                    double c = dot(vk, vl);
                    for (int j = 0; j < size_; ++j)
                        mono_[size_t(k)][size_t(j)] -= c * mono_[size_t(l)][size_t(j)];
                }
            values(k, vk);
            double nrm = std::sqrt(dot(vk, vk));
            for (int j = 0; j < size_; ++j) mono_[size_t(k)][size_t(j)] /= nrm;
        }
    }
    // Two-scale matrices by quadrature exact for degree 2p on the child.
    QuadratureRule q = referenceRule(kind_, degree_ + 2);
    double fp[kMaxBasisSize], fc[kMaxBasisSize];
    for (int c = 0; c < 4; ++c) {
        auto& T = twoScale_[size_t(c)];
        T.assign(size_t(size_ * size_), 0.0);
        for (size_t m = 0; m < q.size(); ++m) {
            Vec2 pp = childToParent(c, q.points[m].x, q.points[m].y);
            eval(pp.x, pp.y, fp);
            eval(q.points[m].x, q.points[m].y, fc);
            for (int a = 0; a < size_; ++a)
                for (int b = 0; b < size_; ++b)
                    T[size_t(a * size_ + b)] += q.weights[m] * fp[a] * fc[b];
        }
    }
}

Vec2 Basis::childToParent(int child, double a, double b) const {
    Domain d = childDomain(kind_, Domain{}, child);
    return domainParam(d, a, b);
}

void Basis::eval(double a, double b, double* out) const {
    if (kind_ == PatchKind::Quad) {
        double la[kMaxBasisDegree + 1], lb[kMaxBasisDegree + 1];
        legendre01(degree_, a, la);
        legendre01(degree_, b, lb);
        for (int k = 0; k < size_; ++k) {
            int i, j;
            exponents(k, i, j);
            out[k] = la[i] * lb[j];
        }
        return;
    }
    double m[kMaxBasisSize];
    for (int k = 0; k < size_; ++k) {
        int i, j;
        exponents(k, i, j);
        m[k] = ipow(a, i) * ipow(b, j);
    }
    for (int k = 0; k < size_; ++k) {
        double s = 0;
        for (int j = 0; j <= k; ++j) s += mono_[size_t(k)][size_t(j)] * m[j];
        out[k] = s;
    }
}

RGB meanOverSubElement(const Basis& basis, std::array<RGB, kMaxBasisSize> c, uint64_t outer,
                       uint64_t key) {
    HRAD_CHECK(keyContains(outer, key));
    const int n = basis.size();
    std::array<RGB, kMaxBasisSize> next{};
    for (int l = keyLevel(outer); l < keyLevel(key); ++l) {
        const auto& T = basis.twoScale(keyChildAt(key, l));
        for (int j = 0; j < n; ++j) {
            RGB v(0.0);
            for (int a = 0; a < n; ++a) v += T[size_t(a * n + j)] * c[size_t(a)];
            next[size_t(j)] = v;
        }
        c = next;
    }
    return c[0];
}

}  // namespace hrad::scene
