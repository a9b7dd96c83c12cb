// Polynomial bases (scene/basis.h): orthonormality, exact quadrature and the
// two-scale relations, for quads and triangles and every degree.
#include "scene/basis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"
#include "scene/element.h"

using namespace hrad;
using namespace hrad::scene;

namespace {
struct Case {
    PatchKind kind;
    int degree;
};
std::string caseName(const ::testing::TestParamInfo<Case>& i) {
    return std::string(i.param.kind == PatchKind::Quad ? "quad_" : "tri_") +
           basisName(i.param.degree);
}
}  // namespace

class Bases : public ::testing::TestWithParam<Case> {};

TEST_P(Bases, AreOrthonormalWithConstantFirst) {
    Basis b(GetParam().kind, GetParam().degree);
    EXPECT_EQ(b.size(), basisSize(GetParam().degree));
    QuadratureRule q = referenceRule(b.kind(), b.degree() + 3);
    std::vector<double> G(size_t(b.size() * b.size()), 0.0);
    double f[kMaxBasisSize];
    for (size_t m = 0; m < q.size(); ++m) {
        b.eval(q.points[m].x, q.points[m].y, f);
        EXPECT_NEAR(f[0], 1.0, 1e-13);
        for (int i = 0; i < b.size(); ++i)
            for (int j = 0; j < b.size(); ++j)
                G[size_t(i * b.size() + j)] += q.weights[m] * f[i] * f[j];
    }
    for (int i = 0; i < b.size(); ++i)
        for (int j = 0; j < b.size(); ++j)
            EXPECT_NEAR(G[size_t(i * b.size() + j)], i == j ? 1.0 : 0.0, 1e-12);
}

// Push (restriction to the children) then pull (projection back) is the
// identity, and the pushed child coefficients reproduce the parent's
// polynomial pointwise on every child.
TEST_P(Bases, TwoScaleRelationsAreExact) {
    Basis b(GetParam().kind, GetParam().degree);
    const int n = b.size();
    Pcg32 rng(7);
    std::vector<double> parent(static_cast<size_t>(n), 0.0);
    for (double& c : parent) c = rng.nextDouble() - 0.5;
    std::vector<double> back(size_t(n), 0.0);
    double fp[kMaxBasisSize], fc[kMaxBasisSize];
    for (int c = 0; c < 4; ++c) {
        const auto& T = b.twoScale(c);
        std::vector<double> child(size_t(n), 0.0);
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                child[size_t(j)] += T[size_t(i * n + j)] * parent[size_t(i)];
        for (int k = 0; k < 20; ++k) {
            double x = rng.nextDouble(), y = rng.nextDouble();
            if (b.kind() == PatchKind::Triangle && x + y > 1) {
                x = 1 - x;
                y = 1 - y;
            }
            Vec2 pp = b.childToParent(c, x, y);
            b.eval(pp.x, pp.y, fp);
            b.eval(x, y, fc);
            double vp = 0, vc = 0;
            for (int i = 0; i < n; ++i) {
                vp += parent[size_t(i)] * fp[i];
                vc += child[size_t(i)] * fc[i];
            }
            EXPECT_NEAR(vp, vc, 1e-12);
        }
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                back[size_t(i)] += 0.25 * T[size_t(i * n + j)] * child[size_t(j)];
    }
    for (int i = 0; i < n; ++i) EXPECT_NEAR(back[size_t(i)], parent[size_t(i)], 1e-12);
}

// The children's domains as childDomain lays them out (inverted middle
// triangle included) match childToParent.
TEST_P(Bases, ChildMapMatchesElementLayout) {
    Basis b(GetParam().kind, GetParam().degree);
    Domain parent{0.25, 0.5, 0.25};
    for (int c = 0; c < 4; ++c) {
        Domain d = childDomain(b.kind(), parent, c);
        Vec2 local = b.childToParent(c, 0.2, 0.3);
        Vec2 viaParent = domainParam(parent, local.x, local.y);
        Vec2 direct = domainParam(d, 0.2, 0.3);
        EXPECT_NEAR(viaParent.x, direct.x, 1e-15);
        EXPECT_NEAR(viaParent.y, direct.y, 1e-15);
    }
}

INSTANTIATE_TEST_SUITE_P(AllDegrees, Bases,
                         ::testing::Values(Case{PatchKind::Quad, 0}, Case{PatchKind::Quad, 1},
                                           Case{PatchKind::Quad, 2}, Case{PatchKind::Quad, 3},
                                           Case{PatchKind::Triangle, 0},
                                           Case{PatchKind::Triangle, 1},
                                           Case{PatchKind::Triangle, 2},
                                           Case{PatchKind::Triangle, 3}),
                         caseName);

TEST(Quadrature, TriangleRuleIntegratesMonomialsExactly) {
    // Normalised: 2 * integral a^i b^j over the triangle = 2 i! j! / (i+j+2)!.
    QuadratureRule q = referenceRule(PatchKind::Triangle, 4);
    auto fact = [](int n) {
        double f = 1;
        for (int k = 2; k <= n; ++k) f *= k;
        return f;
    };
    for (int i = 0; i <= 3; ++i)
        for (int j = 0; i + j <= 6; ++j) {
            double s = 0;
            for (size_t m = 0; m < q.size(); ++m)
                s += q.weights[m] * std::pow(q.points[m].x, i) * std::pow(q.points[m].y, j);
            EXPECT_NEAR(s, 2 * fact(i) * fact(j) / fact(i + j + 2), 1e-14) << i << " " << j;
        }
}
