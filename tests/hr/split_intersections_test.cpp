// Patches that pass through one another (scene/triangulate.h
// splitIntersections): a lit plate half sunk into a closed two-sided box.
// As one patch, the plate's radiosity is an average over both halves and its
// inner half hands it to the box's inner faces, where no path from the lamp
// can bring light; cut along the box's wall, the inner piece sees only the
// inside and stays dark, and so does the inside of the box.
#include <gtest/gtest.h>

#include <cmath>

#include "hr/solver.h"
#include "scene/loader.h"
#include "scene/triangulate.h"
#include "tests/scenes.h"
#include "tests/test_util.h"
#include "transport/reachability.h"
#include "transport/visibility.h"

namespace hrad {
namespace {

/// Adds the room [0,1]^3 (faces inwards, reflectance 0.5, the ceiling
/// emitting 1) that the scenes below stand in.
void addLitRoom(scene::Scene& s) {
    const uint32_t wall = s.addMaterial({"wall", RGB(0.5), RGB(0.0)});
    const uint32_t lamp = s.addMaterial({"lamp", RGB(0.5), RGB(1.0)});
    test::addBox(s, Vec3(0), Vec3(1), {wall, wall, wall, wall, wall, lamp}, true);
}

/// Room [0,1]^3 (inward, 0.5, ceiling emitting), a closed box [0.3,0.6]^3
/// whose faces are two-sided (0.9), and a plate at z = 0.45 over x in
/// [0.5, 0.8], y in [0.35, 0.55], facing up: x < 0.6 is inside the box.
scene::Scene sunkPlate() {
    scene::Scene s;
    s.name = "sunk-plate";
    addLitRoom(s);
    scene::Material boxMat{"box", RGB(0.9), RGB(0.0)};
    boxMat.twoSided = true;
    const uint32_t box = s.addMaterial(boxMat);
    const uint32_t plate = s.addMaterial({"plate", RGB(0.8), RGB(0.0)});
    test::addBox(s, Vec3(0.3), Vec3(0.6), {box, box, box, box, box, box}, false);
    test::addQuadFacing(s, Vec3(0.5, 0.35, 0.45), Vec3(0.8, 0.35, 0.45), Vec3(0.8, 0.55, 0.45),
                        Vec3(0.5, 0.55, 0.45), plate, Vec3(0.65, 0.45, 1.0));
    s.applyMaterials();
    return s;
}

/// Solves (uniform level 2, no clusters); the power max(B) A summed over
/// the patches `count` picks.
template <class Pick>
double powerWhere(const scene::Scene& s, const Pick& count) {
    transport::Visibility vis(s);
    Params p;
    p.set("hr.oracle", std::string("uniform"));
    p.set("oracle.level", int64_t(2));
    p.set("cluster.model", std::string("none"));
    hr::HrSettings settings = hr::HrSettings::fromParams(p);
    p.reportUnused();
    hr::HrResult r = hr::HrSolver(s, vis, settings).solve();
    EXPECT_TRUE(r.converged);
    double power = 0.0;
    for (uint32_t i = 0; i < s.patches.size(); ++i)
        if (count(s.patches[i])) power += s.patches[i].area * maxComponent(r.hierarchy->B(i));
    return power;
}

/// The reflected power on patches inside the box (centroid strictly inside,
/// or a back side of the box).
double powerInside(const scene::Scene& s) {
    return powerWhere(s, [](const scene::Patch& P) {
        const Vec3 c = P.centroid();
        const bool in = c.x > 0.3 + 1e-9 && c.x < 0.6 - 1e-9 && c.y > 0.3 + 1e-9 &&
                        c.y < 0.6 - 1e-9 && c.z > 0.3 + 1e-9 && c.z < 0.6 - 1e-9;
        return in || P.backSide;
    });
}

TEST(SplitIntersections, CutsTheSunkPlateAlongTheWall) {
    scene::Scene s = sunkPlate();
    const size_t before = s.patches.size();
    const double area = s.totalArea();
    const RGB power = s.emittedPower();
    scene::SplitStats st = scene::splitIntersections(s);
    // The plate crosses the box's +x wall: those two are cut, nothing else.
    EXPECT_EQ(st.splitPatches, 2u);
    EXPECT_GE(st.crossings, 1u);
    EXPECT_EQ(s.patches.size(), before - 2 + st.pieces);
    EXPECT_NEAR(s.totalArea(), area, 1e-12);
    EXPECT_NEAR(s.emittedPower().g, power.g, 1e-12);
    // Every piece of the plate lies on one side of the wall x = 0.6.
    for (const scene::Patch& p : s.patches) {
        if (s.materials[p.material].name == "plate") {
            const Vec3 c = p.centroid();
            for (int k = 0; k < 3; ++k) {
                if (c.x < 0.6) {
                    EXPECT_LE(p.v[size_t(k)].x, 0.6 + 1e-12);
                } else {
                    EXPECT_GE(p.v[size_t(k)].x, 0.6 - 1e-12);
                }
            }
        }
    }
}

TEST(SplitIntersections, TouchingCutsNothing) {
    // A box standing on the floor of a room: its walls end on the floor.
    scene::Scene s;
    const uint32_t wall = s.addMaterial({"wall", RGB(0.5), RGB(0.0)});
    const uint32_t lamp = s.addMaterial({"lamp", RGB(0.5), RGB(1.0)});
    test::addBox(s, Vec3(0), Vec3(1), {wall, wall, wall, wall, lamp, wall}, true);
    test::addBox(s, Vec3(0.3, 0.3, 0.0), Vec3(0.6, 0.6, 0.3), {wall, wall, wall, wall, wall, wall},
                 false);
    s.applyMaterials();
    const size_t before = s.patches.size();
    scene::SplitStats st = scene::splitIntersections(s);
    EXPECT_EQ(st.splitPatches, 0u);
    EXPECT_EQ(s.patches.size(), before);
}

TEST(SplitIntersections, TheInsideOfTheBoxStaysDark) {
    // Not cut: the plate's inner half lights the inside of the box.
    scene::Scene whole = sunkPlate();
    whole.addBackSides();
    const double leaked = powerInside(whole);
    EXPECT_GT(leaked, 0.0);
    // Cut: the inner piece, the box's inner faces and the wall's inner
    // pieces are out of light's reach, exactly dark.
    scene::Scene cut = sunkPlate();
    scene::splitIntersections(cut);
    cut.addBackSides();
    EXPECT_EQ(powerInside(cut), 0.0);
}

// split_intersections = "unreachable" (scene/loader.h splitWhereDark): the
// cuts kept are those whose dark pieces light would otherwise reach.
TEST(SplitWhereDark, KeepsTheCutOfTheSunkPlateAndNotOfTheWall) {
    scene::Scene s = sunkPlate();
    const size_t before = s.patches.size();
    scene::SplitStats st = scene::splitWhereDark(
        s, 256, [](scene::Scene& x) { x.addBackSides(); }, transport::lightPathsFn());
    // Both the plate and the box's +x wall cross. Whole, the plate's inner
    // half would light the box's inside: its cut stays. The wall's outer
    // side is lit on both pieces and its inner side on neither: it stays
    // whole.
    EXPECT_EQ(st.candidates, 2u);
    EXPECT_EQ(st.splitPatches, 1u);
    EXPECT_EQ(s.patches.size(), before - 1 + st.pieces);
    for (const scene::Patch& p : s.patches) {
        if (p.kind == scene::PatchKind::Triangle) {
            EXPECT_EQ(s.materials[p.material].name, "plate");
        }
    }
    s.addBackSides();
    EXPECT_EQ(powerInside(s), 0.0);
}

/// Room [0,1]^3 (inward, ceiling emitting) with two one-sided closed legs
/// through its floor into the space below, 0.1 apart: the floor's pieces
/// inside the legs see only the backs of the legs' walls, and the stubs
/// under the floor see one another.
scene::Scene legsThroughTheFloor() {
    scene::Scene s;
    addLitRoom(s);
    const uint32_t leg = s.addMaterial({"leg", RGB(0.7), RGB(0.0)});
    test::addBox(s, Vec3(0.3, 0.4, -0.2), Vec3(0.4, 0.5, 0.3), {leg, leg, leg, leg, leg, leg},
                 false);
    test::addBox(s, Vec3(0.5, 0.4, -0.2), Vec3(0.6, 0.5, 0.3), {leg, leg, leg, leg, leg, leg},
                 false);
    s.applyMaterials();
    return s;
}

TEST(SplitWhereDark, LeavesLegsThroughALitFloorWhole) {
    // Cut everywhere, the floor and the legs' walls each have pieces light
    // reaches and pieces it does not, and the stubs see one another: a rule
    // that kept every cut with a dark piece, or every dark piece another
    // dark piece sees, would cut them all.
    scene::Scene all = legsThroughTheFloor();
    scene::splitIntersections(all);
    {
        transport::Visibility vis(all);
        transport::Reachability r = transport::reachablePatches(all, vis, 256, 1, 0, 4, true);
        EXPECT_GT(r.unreachable, 0u);
        EXPECT_FALSE(r.darkEdges.empty());
    }
    scene::Scene s = legsThroughTheFloor();
    const size_t before = s.patches.size();
    scene::SplitStats st = scene::splitWhereDark(
        s, 256, [](scene::Scene& x) { x.addBackSides(); }, transport::lightPathsFn());
    EXPECT_EQ(st.candidates, 9u);  // the floor and each leg's four walls
    EXPECT_EQ(st.splitPatches, 0u);
    EXPECT_EQ(s.patches.size(), before);
}

/// Room [0,1]^3 (inward, ceiling emitting) with a block that has no bottom
/// and faces inwards standing on the floor, [0.3,0.6]^2 x [0,0.2] (as graz's
/// paper blocks stand in their binders): its faces see only one another and
/// the floor inside their footprint, where no light arrives.
scene::Scene blockOnTheFloor() {
    scene::Scene s;
    addLitRoom(s);
    const uint32_t block = s.addMaterial({"block", RGB(0.8), RGB(0.0)});
    const size_t before = s.patches.size();
    test::addBox(s, Vec3(0.3, 0.3, 0.0), Vec3(0.6, 0.6, 0.2),
                 {block, block, block, block, block, block}, true);
    // No bottom: the -z face of the block (the fifth added) goes.
    s.patches.erase(s.patches.begin() + std::ptrdiff_t(before + 4));
    s.applyMaterials();
    return s;
}

/// The reflected power on the block's faces and on floor pieces within its
/// footprint.
double powerInBlock(const scene::Scene& s) {
    return powerWhere(s, [&](const scene::Patch& P) {
        const Vec3 c = P.centroid();
        const bool footprint = c.z < 1e-9 && c.x > 0.3 && c.x < 0.6 && c.y > 0.3 && c.y < 0.6;
        return s.materials[P.material].name == "block" || footprint;
    });
}

TEST(SplitWhereDark, CutsTheFloorUnderABlockThatClosesIt) {
    // Whole, the lit floor lights the block's inside; cutting only where
    // patches cross (split_intersections = true) cuts nothing here.
    scene::Scene whole = blockOnTheFloor();
    EXPECT_GT(powerInBlock(whole), 1e-3);
    scene::Scene crossed = blockOnTheFloor();
    EXPECT_EQ(scene::splitIntersections(crossed).splitPatches, 0u);
    // The block's walls stand on the floor: their bottom edges cut it
    // around the footprint, which the block's faces see and which no light
    // reaches, so the floor keeps its cut and the block stays dark.
    scene::Scene s = blockOnTheFloor();
    scene::SplitStats st = scene::splitWhereDark(
        s, 256, [](scene::Scene& x) { x.addBackSides(); }, transport::lightPathsFn());
    EXPECT_EQ(st.candidates, 1u);
    EXPECT_EQ(st.splitPatches, 1u);
    EXPECT_EQ(powerInBlock(s), 0.0);
}

TEST(SplitWhereDark, NeedsTheRayTracerAndLeavesUncrossedScenesAlone) {
    Params p;
    p.set("split_intersections", std::string("unreachable"));
    EXPECT_THROW(scene::loadScene("cornell", p), InputError);
    Params q;
    q.set("split_intersections", std::string("unreachable"));
    const scene::Scene withCut = transport::loadScene("cornell", q);
    const scene::Scene plain = scene::loadScene("cornell");
    EXPECT_EQ(withCut.patches.size(), plain.patches.size());
    Params bad;
    bad.set("split_intersections", std::string("some"));
    EXPECT_THROW(transport::loadScene("cornell", bad), InputError);
}

TEST(SplitIntersections, NoPieceOfGrazIsThinnerThanTheToleranceOrOutshinesItsLamps) {
    // graz.mgf (../shared/scenes; skipped where absent), cut: 3,828 patches
    // pass through others. Crossing segments that end a rounding error away
    // from a corner or an edge made pieces of 1e-20 m^2, and the hand-over
    // of a link into a cluster whose only open surface facing the lamp was a
    // 7e-8 m^2 piece put the link's whole power on it (K / W = 51): with
    // ray seeds 1-3 pieces took radiosities of 2e4-1e16 against the lamps'
    // 1,874 (papers/README.md, "graz cut along its crossings").
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes not present";
    const auto path = *dir / "renderpark-mgf" / "office1" / "graz.mgf";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
    Params sp;
    sp.set("split_intersections", true);
    const scene::Scene s = scene::loadScene(path.string(), sp);
    ASSERT_GT(s.stats.splitPatches, 0u);
    // No piece thinner than the tolerance (height over its longest edge;
    // 1e-7 of the diagonal): the cut scene has no more such triangles than
    // the scene as its author made it.
    const double tol = 1e-7 * s.bounds().diagonal();
    auto thin = [&](const scene::Scene& sc) {
        uint32_t n = 0;
        for (const scene::Patch& p : sc.patches) {
            if (p.numVertices() != 3) continue;
            double longest = 0.0;
            for (int k = 0; k < 3; ++k)
                longest =
                    std::max(longest, glm::length(p.v[size_t((k + 1) % 3)] - p.v[size_t(k)]));
            n += 2.0 * p.area <= tol * longest ? 1 : 0;
        }
        return n;
    };
    EXPECT_LE(thin(s), thin(scene::loadScene(path.string())));
    // No surface that does not emit is brighter than rho times the
    // brightest emitter (B = rho H, and H is at most the largest radiosity
    // in view, which an emitter holds).
    transport::Visibility vis(s);
    for (int64_t seed : {1, 2, 3}) {
        Params p;
        p.set("cluster.model", std::string("oriented"));
        p.set("oracle.eps", 1e-5);
        p.set("hr.seed", seed);
        hr::HrSettings settings = hr::HrSettings::fromParams(p);
        hr::HrResult r = hr::HrSolver(s, vis, settings).solve();
        const hr::Hierarchy& h = *r.hierarchy;
        double lamp = 0.0;
        for (uint32_t i = 0; i < s.patches.size(); ++i)
            if (maxComponent(s.patches[i].emission) > 0)
                lamp = std::max(lamp, maxComponent(h.B(i)));
        ASSERT_GT(lamp, 0.0);
        uint32_t brighter = 0;
        for (uint32_t i = 0; i < s.patches.size(); ++i)
            if (!(maxComponent(s.patches[i].emission) > 0) &&
                maxComponent(h.B(i)) > maxComponent(s.patches[i].rho) * lamp)
                ++brighter;
        EXPECT_EQ(brighter, 0u) << "seed " << seed;
    }
}

}  // namespace
}  // namespace hrad
