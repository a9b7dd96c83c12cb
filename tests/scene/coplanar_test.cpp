// Stacked coplanar faces (scene/coplanar.h): which pairs are found and which
// face is in front where they overlap.
#include "scene/coplanar.h"

#include <gtest/gtest.h>

#include <chrono>

#include "tests/scenes.h"

namespace hrad::scene {
namespace {

uint32_t quadUp(Scene& s, double x0, double y0, double x1, double y1, double z, uint32_t m) {
    test::addQuadFacing(s, Vec3(x0, y0, z), Vec3(x1, y0, z), Vec3(x1, y1, z), Vec3(x0, y1, z), m,
                        Vec3(0.5 * (x0 + x1), 0.5 * (y0 + y1), z + 1));
    return uint32_t(s.patches.size() - 1);
}

TEST(CoplanarOverlaps, TilesSharingEdgesAreNotPairs) {
    Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) quadUp(s, i, j, i + 1, j + 1, 0.0, m);
    CoplanarOverlaps ov(s);
    EXPECT_TRUE(ov.empty());
    EXPECT_FALSE(ov.hidden(4, Vec3(1.5, 1.5, 0)));
}

TEST(CoplanarOverlaps, TheSmallerFaceLiesOnTheLargerOne) {
    Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    uint32_t table = quadUp(s, 0, 0, 2, 2, 0.7, m);
    uint32_t box = quadUp(s, 0.5, 0.5, 1.0, 1.0, 0.7, m);
    uint32_t apart = quadUp(s, 0.5, 0.5, 1.0, 1.0, 0.701, m);  // 1 mm above: not coplanar
    CoplanarOverlaps ov(s);
    EXPECT_EQ(ov.numPairs(), 1u);
    EXPECT_EQ(ov.numHiddenPatches(), 1u);
    EXPECT_TRUE(ov.partners(table, box));
    EXPECT_FALSE(ov.partners(table, apart));
    EXPECT_TRUE(ov.hidden(table, Vec3(0.75, 0.75, 0.7)));   // under the box
    EXPECT_FALSE(ov.hidden(table, Vec3(1.5, 1.5, 0.7)));    // outside it
    EXPECT_FALSE(ov.hidden(box, Vec3(0.75, 0.75, 0.7)));    // the box is in front
}

TEST(CoplanarOverlaps, OppositeFacesAndEmittersFirst) {
    Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    uint32_t e = s.addMaterial({"e", RGB(0.0), RGB(1.0)});
    uint32_t wall = quadUp(s, 0, 0, 1, 1, 0.0, m);
    // The same polygon facing down (the other side of a wall): not a pair.
    test::addQuadFacing(s, Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), m,
                        Vec3(0.5, 0.5, -1));
    // A larger emitter in the same plane: an emitter is in front of a
    // non-emitter whatever their sizes.
    uint32_t lamp = quadUp(s, -1, -1, 2, 2, 0.0, e);
    CoplanarOverlaps ov(s);
    EXPECT_EQ(ov.numPairs(), 1u);
    EXPECT_TRUE(ov.hidden(wall, Vec3(0.5, 0.5, 0)));
    EXPECT_FALSE(ov.hidden(lamp, Vec3(0.5, 0.5, 0)));
    EXPECT_FALSE(ov.hidden(1, Vec3(0.5, 0.5, 0)));
}

// Faces in one plane facing opposite ways are the two sides of a sheet: found
// (whatever their order and sizes, across the quantisation of the plane
// offset), flagged, never stacked; a face next to them, or a two-sided
// surface's own back side, is not a sheet.
TEST(CoplanarOverlaps, OppositeFacesAreTheTwoSidesOfASheet) {
    Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    uint32_t two = s.addMaterial({"two", RGB(0.5), RGB(0.0)});
    s.materials[two].twoSided = true;
    const double z = 0.3;  // an offset that is not a multiple of the tolerance
    uint32_t label = quadUp(s, 0.2, 0.2, 0.4, 0.6, z, m);
    test::addQuadFacing(s, Vec3(0, 0, z), Vec3(1, 0, z), Vec3(1, 1, z), Vec3(0, 1, z), m,
                        Vec3(0.5, 0.5, z - 1));  // the cover, facing down
    const uint32_t cover = uint32_t(s.patches.size() - 1);
    uint32_t beside = quadUp(s, 1, 0, 2, 1, z, m);  // shares an edge with the cover
    uint32_t sheet2 = quadUp(s, 5, 5, 6, 6, 1.0, two);
    // A two-sided poster on it: stacked on its front; its back side and the
    // sheet's overlap facing opposite ways, but both see both ways already.
    uint32_t poster = quadUp(s, 5.2, 5.2, 5.5, 5.5, 1.0, two);
    s.applyMaterials();
    ASSERT_EQ(s.addBackSides(), 2u);
    CoplanarOverlaps ov(s);
    EXPECT_EQ(ov.numSheetPairs(), 1u);
    EXPECT_TRUE(ov.inSheet(label));
    EXPECT_TRUE(ov.inSheet(cover));
    EXPECT_FALSE(ov.inSheet(beside));
    EXPECT_FALSE(ov.inSheet(sheet2));
    EXPECT_FALSE(ov.inSheet(s.patches[sheet2].twin));
    EXPECT_FALSE(ov.inSheet(poster));
    // The sheet's faces are not stacked (the poster is, on both sides).
    EXPECT_EQ(ov.numPairs(), 2u);
    EXPECT_FALSE(ov.hidden(label, Vec3(0.3, 0.4, z)));
    EXPECT_FALSE(ov.hidden(cover, Vec3(0.3, 0.4, z)));
}

// Issue 64: the search is O(n log n). 60 k strips in one plane that all span
// the same x range made the former sweep over x test every pair (1.8e9; 200 k
// took 107 s); with a box tree each strip meets its two neighbours only.
TEST(CoplanarOverlaps, ManyFacesInOnePlaneAreFoundInNLogN) {
    Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    const int n = 60000;
    for (int i = 0; i < n; ++i) quadUp(s, 0, i, 100, i + 1, 0.0, m);
    uint32_t decal = quadUp(s, 10, 10.25, 20, 10.75, 0.0, m);
    auto t0 = std::chrono::steady_clock::now();
    CoplanarOverlaps ov(s);
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(ov.numPairs(), 1u);
    EXPECT_TRUE(ov.partners(10, decal));
    EXPECT_TRUE(ov.hidden(10, Vec3(15, 10.5, 0)));
    EXPECT_LT(secs, 5.0) << "coplanar search took " << secs << " s for " << n << " faces";
}

}  // namespace
}  // namespace hrad::scene
