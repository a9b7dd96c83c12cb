// transport/reachability.h: which patches light can reach at all.
#include "transport/reachability.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "tests/scenes.h"

using namespace hrad;

namespace {

// A lit room (inward box, a light under its ceiling), a closed box standing
// in it (outward faces, lit) with a second box inside (inward faces: a dark
// room of its own), and a quad whose only view is through a slot 2 % of the

struct Room {
    scene::Scene s;
    uint32_t firstInner = 0, lastInner = 0;  ///< the inner box's six faces
};

Room makeRoom() {
    Room r;
    scene::Scene& s = r.s;
    uint32_t wall = s.addMaterial({"wall", RGB(0.6), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(5.0)});
    test::addBox(s, Vec3(0), Vec3(4, 3, 2.5), {wall, wall, wall, wall, wall, wall}, true);
    test::addQuadFacing(s, Vec3(1.5, 1, 2.49), Vec3(2.5, 1, 2.49), Vec3(2.5, 2, 2.49),
                        Vec3(1.5, 2, 2.49), light, Vec3(2, 1.5, 0));
    test::addBox(s, Vec3(0.5, 0.5, 0), Vec3(1.5, 1.5, 1), {wall, wall, wall, wall, wall, wall},
                 false);
    r.firstInner = uint32_t(s.patches.size());
    test::addBox(s, Vec3(0.6, 0.6, 0.1), Vec3(1.4, 1.4, 0.9), {wall, wall, wall, wall, wall, wall},
                 true);
    r.lastInner = uint32_t(s.patches.size()) - 1;
    return r;
}

}  // namespace

TEST(Reachability, ClosedBoxInsideALitRoomIsUnreachable) {
    Room room = makeRoom();
    transport::Visibility vis(room.s);
    transport::Reachability r = transport::reachablePatches(room.s, vis, 64);
    ASSERT_EQ(r.reachable.size(), room.s.patches.size());
    for (uint32_t p = 0; p < room.s.patches.size(); ++p) {
        const bool inner = p >= room.firstInner && p <= room.lastInner;
        EXPECT_EQ(r.reachable[p], inner ? 0 : 1) << "patch " << p;
    }
    EXPECT_EQ(r.unreachable, 6u);
    EXPECT_EQ(r.rays, 64u * room.s.patches.size());
}

TEST(Reachability, SameForAnyThreadCountAndNothingWithoutEmitters) {
    Room room = makeRoom();
    transport::Visibility vis(room.s);
    transport::Reachability many = transport::reachablePatches(room.s, vis, 16, 7);
    transport::Reachability one;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = transport::reachablePatches(room.s, vis, 16, 7);
    }
    EXPECT_EQ(many.reachable, one.reachable);
    // Without an emitter nothing is lit, so nothing is reachable.
    scene::Scene dark;
    uint32_t wall = dark.addMaterial({"wall", RGB(0.6), RGB(0.0)});
    test::addBox(dark, Vec3(0), Vec3(1), {wall, wall, wall, wall, wall, wall}, true);
    transport::Visibility dvis(dark);
    EXPECT_EQ(transport::reachablePatches(dark, dvis, 8).unreachable, 6u);
}

TEST(Reachability, AFaceAgainstTheBackOfAWallSeesNothingLit) {
    // A one-sided floor lit from above, and a quad 1 mm below it facing up:
    // its hemisphere meets only the floor's back.
    scene::Scene s;
    uint32_t grey = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(1.0)});
    test::addQuadFacing(s, Vec3(-5, -5, 0), Vec3(5, -5, 0), Vec3(5, 5, 0), Vec3(-5, 5, 0), grey,
                        Vec3(0, 0, 1));
    test::addQuadFacing(s, Vec3(-1, -1, 2), Vec3(1, -1, 2), Vec3(1, 1, 2), Vec3(-1, 1, 2), light,
                        Vec3(0, 0, 0));
    test::addQuadFacing(s, Vec3(-1, -1, -0.001), Vec3(1, -1, -0.001), Vec3(1, 1, -0.001),
                        Vec3(-1, 1, -0.001), grey, Vec3(0, 0, 1));
    transport::Visibility vis(s);
    transport::Reachability r = transport::reachablePatches(s, vis, 64);
    EXPECT_EQ(r.reachable, (std::vector<uint8_t>{1, 1, 0}));
}
