// Spherical triangles (core/sampling.h): the solid angle against the
// octant's closed form, and Arvo's directions against the exact form factor
// of a triangle (a uniform density over the solid angle makes the mean of
// cos / pi times the solid angle the point-to-polygon form factor,
// transport::pointToPolygon).
#include "core/sampling.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"
#include "transport/formfactor.h"

namespace hrad {
namespace {

TEST(SphericalTriangle, OctantHasAnEighthOfTheSphere) {
    EXPECT_NEAR(sphericalTriangleArea(Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)), kPi / 2, 1e-12);
    // A tiny triangle far away: the area over the squared distance.
    const double d = 1e3, h = 1e-3;
    const Vec3 a = glm::normalize(Vec3(0, 0, d)), b = glm::normalize(Vec3(h, 0, d)),
               c = glm::normalize(Vec3(0, h, d));
    EXPECT_NEAR(sphericalTriangleArea(a, b, c), 0.5 * h * h / (d * d),
                1e-6 * 0.5 * h * h / (d * d));
}

TEST(SphericalTriangle, DirectionsAreUniformOverTheSolidAngle) {
    // Triangles seen from the origin with normal +z, near and at grazing
    // angles; the estimate of the form factor from n directions has a
    // standard error below 1 / sqrt(n) of Omega / pi.
    const Vec3 n(0, 0, 1);
    const Vec3 tris[][3] = {{Vec3(-1, -1, 1), Vec3(2, -0.5, 1.5), Vec3(0, 1.5, 0.7)},
                            {Vec3(0.05, -0.65, 0.02), Vec3(0.05, 0.65, 0.02), Vec3(0.09, 0, 0.03)},
                            {Vec3(3, 0, 0.1), Vec3(0, 3, 0.1), Vec3(3, 3, 2)}};
    Pcg32 rng(7);
    for (const auto& t : tris) {
        const Vec3 a = glm::normalize(t[0]), b = glm::normalize(t[1]), c = glm::normalize(t[2]);
        const double omega = sphericalTriangleArea(a, b, c);
        const int count = 200000;
        double sum = 0.0, sum2 = 0.0;
        const Vec3 edge[3] = {glm::cross(a, b), glm::cross(b, c), glm::cross(c, a)};
        const double side = glm::dot(edge[0], c) > 0 ? 1.0 : -1.0;
        int outside = 0;
        for (int i = 0; i < count; ++i) {
            const Vec3 w =
                sphericalTriangleDirection(a, b, c, omega, rng.nextDouble(), rng.nextDouble());
            for (const Vec3& e : edge) outside += side * glm::dot(e, w) < -1e-9;
            const double f = std::max(0.0, w.z) * omega / kPi;
            sum += f;
            sum2 += f * f;
        }
        const double mean = sum / count;
        const double se = std::sqrt(std::max(0.0, sum2 / count - mean * mean) / count);
        const double exact = transport::pointToPolygon(Vec3(0.0), n, t, 3);
        EXPECT_EQ(outside, 0);
        EXPECT_NEAR(mean, exact, 4.0 * se + 1e-12) << "omega " << omega;
        EXPECT_LT(se, 0.01 * exact);
    }
}

}  // namespace
}  // namespace hrad
