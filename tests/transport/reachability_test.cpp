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
    uint32_t boxBottom = 0;                  ///< the lit box's bottom, lying on the room's floor
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
    r.boxBottom = uint32_t(s.patches.size()) - 2;  // addBox: the face at z = lo.z is the fifth
    r.firstInner = uint32_t(s.patches.size());
    test::addBox(s, Vec3(0.6, 0.6, 0.1), Vec3(1.4, 1.4, 0.9), {wall, wall, wall, wall, wall, wall},
                 true);
    r.lastInner = uint32_t(s.patches.size()) - 1;
    return r;
}

// A lit room whose floor patch P (kLidP) lies under a lid (kLid) 0.1 above
// the floor and 6 wide: P and the lid's underside see the lit floor only
// through the low gap at the lid's edges.
constexpr uint32_t kLid = 6, kLidP = 7;
scene::Scene lidScene() {
    scene::Scene s;
    uint32_t grey = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(1.0)});
    test::addBox(s, Vec3(-10, -10, 0), Vec3(10, 10, 10), {grey, grey, grey, grey, grey, light},
                 true);
    test::addQuadFacing(s, Vec3(-3, -3, 0.1), Vec3(3, -3, 0.1), Vec3(3, 3, 0.1), Vec3(-3, 3, 0.1),
                        grey, Vec3(0, 0, 0));  // lid, facing down
    test::addQuadFacing(s, Vec3(-0.5, -0.5, 0.001), Vec3(0.5, -0.5, 0.001), Vec3(0.5, 0.5, 0.001),
                        Vec3(-0.5, 0.5, 0.001), grey, Vec3(0, 0, 1));  // P, facing up
    return s;
}

TEST(Reachability, RetryRaysFindPatchesSeenThroughAGap) {
    // A lit room whose floor patch P lies under a lid 0.1 above the floor
    // and 6 wide: P and the lid's underside see the lit floor only through
    // the low gap at the lid's edges. One ray each misses that; a retry from
    // the patches left unconnected finds it, and never connects the inside
    // of a closed box.
    scene::Scene s = lidScene();
    const uint32_t lid = kLid, p = kLidP;
    transport::Visibility vis(s);
    transport::Reachability once = transport::reachablePatches(s, vis, 1);
    transport::Reachability retried = transport::reachablePatches(s, vis, 1, 1, 4096);
    EXPECT_EQ(once.reachable[p], 0);
    EXPECT_EQ(retried.reachable[lid], 1);
    EXPECT_EQ(retried.reachable[p], 1);
    for (uint32_t q = 0; q < s.patches.size(); ++q) {
        if (once.reachable[q]) {
            EXPECT_EQ(retried.reachable[q], 1) << q;
        }
    }
    EXPECT_EQ(retried.rays, once.rays + 4096u * once.unreachable);
    // The closed box inside the room of the first test stays closed.
    Room room = makeRoom();
    transport::Visibility rvis(room.s);
    EXPECT_EQ(transport::reachablePatches(room.s, rvis, 8, 1, 512).unreachable, 7u);
}

}  // namespace

TEST(Reachability, ClosedBoxInsideALitRoomIsUnreachable) {
    Room room = makeRoom();
    transport::Visibility vis(room.s);
    transport::Reachability r = transport::reachablePatches(room.s, vis, 64);
    ASSERT_EQ(r.reachable.size(), room.s.patches.size());
    // The six faces inside the box, and the box's bottom: it lies on the
    // floor, facing into it, and sees only the floor's plane, which a ray
    // leaving the bottom never meets past its origin (transport/visibility.h).
    for (uint32_t p = 0; p < room.s.patches.size(); ++p) {
        const bool dark = (p >= room.firstInner && p <= room.lastInner) || p == room.boxBottom;
        EXPECT_EQ(r.reachable[p], dark ? 0 : 1) << "patch " << p;
    }
    EXPECT_EQ(r.unreachable, 7u);
    // In stages: the seven dark faces cast all 64 rays, the others fewer
    // (each casts 4, then 16 and 64 while not reached).
    EXPECT_LT(r.rays, 64u * room.s.patches.size());
    EXPECT_GE(r.rays, 4u * room.s.patches.size() + 60u * 7u);
    transport::Reachability all = transport::reachablePatches(room.s, vis, 64, 1, 0, 64);
    EXPECT_EQ(all.reachable, r.reachable);
    EXPECT_EQ(all.rays, 64u * room.s.patches.size());
}

// Cast in stages, the rays find exactly the patches they find when every
// patch casts all of them, also where patches see the lit room only through
// a narrow gap (reached by chance, at a late stage or not at all). Several
// seeds and ray counts, stages from one ray, with and without retries.
TEST(Reachability, StagesFindWhatAllRaysFind) {
    scene::Scene s = lidScene();
    transport::Visibility vis(s);
    int partial = 0;
    for (uint64_t seed = 1; seed <= 12; ++seed)
        for (int rays : {2, 3, 6, 16}) {
            transport::Reachability staged = transport::reachablePatches(s, vis, rays, seed, 0, 1);
            transport::Reachability all = transport::reachablePatches(s, vis, rays, seed, 0, rays);
            EXPECT_EQ(staged.reachable, all.reachable)
                << "seed " << seed << ", " << rays << " rays";
            EXPECT_LE(staged.rays, all.rays);
            partial += staged.reachable[kLidP] == 0;
            transport::Reachability retried =
                transport::reachablePatches(s, vis, rays, seed, 64, 1);
            transport::Reachability allRetried =
                transport::reachablePatches(s, vis, rays, seed, 64, rays);
            EXPECT_EQ(retried.reachable, allRetried.reachable) << "seed " << seed;
        }
    // The test sees both outcomes for the patch under the lid.
    EXPECT_GT(partial, 0);
    EXPECT_LT(partial, 48);
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
