// Polygon intake (scene/triangulate.h).
#include <gtest/gtest.h>

#include "scene/element.h"
#include "scene/triangulate.h"

namespace hrad::scene {
namespace {

Scene emptyScene() {
    Scene s;
    s.addMaterial({"m", RGB(0.5), RGB(1.0)});
    return s;
}

double area(const std::vector<Vec3>& v) { return polygonArea(v.data(), int(v.size())); }

TEST(AddPolygon, TriangleAndPlanarConvexQuadKeepTheirShape) {
    Scene s = emptyScene();
    EXPECT_EQ(addPolygon(s, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, 0), 1u);
    EXPECT_EQ(addPolygon(s, {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}}, 0), 1u);
    ASSERT_EQ(s.patches.size(), 2u);
    EXPECT_EQ(s.patches[0].kind, PatchKind::Triangle);
    EXPECT_EQ(s.patches[1].kind, PatchKind::Quad);
    EXPECT_EQ(s.patches[1].v[1], Vec3(2, 0, 0));  // order kept
    EXPECT_NEAR(s.patches[1].normal.z, 1.0, 1e-15);
    EXPECT_EQ(s.stats.triangulatedFaces, 0u);
    EXPECT_EQ(s.stats.inputFaces, 2u);
}

TEST(AddPolygon, NonConvexAndNonPlanarQuadsAreTriangulated) {
    Scene s = emptyScene();
    std::vector<Vec3> dart = {{0, 0, 0}, {2, 1, 0}, {0, 2, 0}, {0.5, 1, 0}};  // reflex at vertex 3
    EXPECT_EQ(addPolygon(s, dart, 0), 2u);
    std::vector<Vec3> bent = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.3}, {0, 1, 0}};
    EXPECT_EQ(addPolygon(s, bent, 0), 2u);
    EXPECT_EQ(s.count(PatchKind::Quad), 0u);
    EXPECT_EQ(s.stats.triangulatedFaces, 2u);
    double a = s.patches[0].area + s.patches[1].area;
    EXPECT_NEAR(a, area(dart), 1e-12);
    for (const auto& p : s.patches) EXPECT_GT(p.normal.z, 0.0);
}

TEST(AddPolygon, LShapedHexagonAreaAndOrientationPreserved) {
    for (bool reversed : {false, true}) {
        Scene s = emptyScene();
        std::vector<Vec3> l = {{0, 0, 0}, {3, 0, 0}, {3, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
        if (reversed) std::reverse(l.begin(), l.end());
        size_t n = addPolygon(s, l, 0);
        EXPECT_EQ(n, 4u);
        double a = 0;
        for (const auto& p : s.patches) {
            a += p.area;
            EXPECT_NEAR(p.normal.z, reversed ? -1.0 : 1.0, 1e-12);
            // Every triangle lies inside the L (centroid not in the notch).
            Vec3 c = p.centroid();
            EXPECT_FALSE(c.x > 1 && c.y > 1);
        }
        EXPECT_NEAR(a, 4.0, 1e-12);
    }
}

TEST(AddPolygon, DuplicateAndCollinearVerticesAreRemovedFirst) {
    Scene s = emptyScene();
    // A square with a repeated vertex and a midpoint on an edge: still one quad.
    EXPECT_EQ(addPolygon(s, {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {0, 0, 0}}, 0), 1u);
    EXPECT_EQ(s.patches[0].kind, PatchKind::Quad);
    EXPECT_NEAR(s.patches[0].area, 4.0, 1e-12);
}

TEST(AddPolygon, DegenerateFacesAreDroppedAndCounted) {
    Scene s = emptyScene();
    EXPECT_EQ(addPolygon(s, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, 0), 0u);           // collinear
    EXPECT_EQ(addPolygon(s, {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, 0), 0u);  // a point
    EXPECT_EQ(addPolygon(s, {{0, 0, 0}, {1, 0, 0}}, 0), 0u);
    EXPECT_EQ(s.patches.size(), 0u);
    EXPECT_EQ(s.stats.droppedDegenerate, 3u);
    EXPECT_EQ(s.stats.inputFaces, 3u);
}

TEST(AddPolygon, RegularNGonInTiltedPlane) {
    Scene s = emptyScene();
    std::vector<Vec3> ngon;
    Vec3 u = glm::normalize(Vec3(1, 1, 0)), w = glm::normalize(Vec3(-1, 1, 2));
    const int n = 12;
    for (int i = 0; i < n; ++i) {
        double t = 2 * kPi * i / n;
        ngon.push_back(Vec3(5, 5, 5) + std::cos(t) * u + std::sin(t) * w);
    }
    EXPECT_EQ(addPolygon(s, ngon, 0), size_t(n - 2));
    double a = 0;
    Vec3 nrm = glm::normalize(glm::cross(u, w));
    for (const auto& p : s.patches) {
        a += p.area;
        EXPECT_NEAR(glm::dot(p.normal, nrm), 1.0, 1e-9);
    }
    EXPECT_NEAR(a, area(ngon), 1e-12 * a);
    EXPECT_NEAR(a, 0.5 * n * std::sin(2 * kPi / n), 1e-12);
}

TEST(AddPolygon, MgfStyleHoleThroughSeam) {
    // A 4x4 square with a 2x2 hole, joined by a seam (as MGF writes holes).
    Scene s = emptyScene();
    std::vector<Vec3> v = {{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}, {0, 0, 0},
                           {1, 1, 0}, {1, 3, 0}, {3, 3, 0}, {3, 1, 0}, {1, 1, 0}};
    EXPECT_GT(addPolygon(s, v, 0), 0u);
    double a = 0;
    for (const auto& p : s.patches) {
        a += p.area;
        Vec3 c = p.centroid();
        EXPECT_FALSE(c.x > 1 && c.x < 3 && c.y > 1 && c.y < 3) << "triangle in the hole";
        EXPECT_GT(p.normal.z, 0.0);
    }
    EXPECT_NEAR(a, 12.0, 1e-9);
}

}  // namespace
}  // namespace hrad::scene
