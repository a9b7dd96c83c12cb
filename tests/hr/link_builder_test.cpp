// hr/link_builder.h: the links refinement asks for, from transport/'s form
// factors and visibility, with their flags and per-kind costs. Two unit
// squares facing each other one apart exchange the closed-form form factor
// 0.19982 (Howell's catalogue, C-11: parallel directly opposed squares, side
// over distance 1); a blocker between them sets the visibility.
#include "hr/link_builder.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/scenes.h"
#include "transport/formfactor.h"
#include "transport/visibility.h"

namespace hrad::hr {
namespace {

constexpr double kParallelSquares = 0.19982;

/// Patch 0: unit square at z = 0 facing +z (emitter); patch 1: at z = 1
/// facing -z; then `blocker` (the x-extent of a square at z = 0.5 covering
/// y in [0, 1], facing -z), when its width is positive.
scene::Scene squares(double blockerWidth) {
    scene::Scene s;
    s.name = "test-squares";
    uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(1.0)});
    uint32_t grey = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    test::addQuadFacing(s, Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), light,
                        Vec3(0.5, 0.5, 1));
    test::addQuadFacing(s, Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(0, 1, 1), grey,
                        Vec3(0.5, 0.5, 0));
    if (blockerWidth > 0)
        test::addQuadFacing(s, Vec3(0, 0, 0.5), Vec3(blockerWidth, 0, 0.5),
                            Vec3(blockerWidth, 1, 0.5), Vec3(0, 1, 0.5), grey, Vec3(0.5, 0.5, 0));
    return s;
}

struct Squares {
    scene::Scene scene;
    transport::Visibility vis;
    transport::FormFactorEngine engine;
    Hierarchy h;
    explicit Squares(double blockerWidth)
        : scene(squares(blockerWidth)),
          vis(scene),
          engine(scene, &vis, transport::FormFactorSettings{}),
          h(scene) {}
};

TEST(LinkBuilder, FacingSquaresCarryTheirClosedFormFormFactor) {
    Squares su(0.0);
    LinkBuilder b(su.engine, true);
    uint32_t rays = 0;
    Link l = b.make(su.h, 1, 0, rays);
    EXPECT_EQ(l.sender, 0u);
    EXPECT_NEAR(l.K, kParallelSquares, 1e-4);  // 0.199844 with the default rule
    EXPECT_EQ(l.vis(), 1.0);                   // nothing between them
    EXPECT_FALSE(l.flags & Link::kPartial);
    // The unoccluded form factor is kept as the bound the oracle may read.
    EXPECT_GE(l.Fupper, l.K);
    const LinkKindCost c = b.cost();
    EXPECT_EQ(c.evaluations[0], 1u);
    EXPECT_EQ(c.evaluations[1] + c.evaluations[2] + c.evaluations[3], 0u);
    EXPECT_EQ(c.rays[0], rays);
    b.resetCost();
    EXPECT_EQ(b.cost().evaluations[0], 0u);
}

TEST(LinkBuilder, SurfacesThatDoNotFaceGetNoLinkAndCastNoRays) {
    Squares su(0.0);
    LinkBuilder b(su.engine, true);
    uint32_t rays = 7;
    // The emitter sees the receiver, but a square does not see itself.
    Link l = b.make(su.h, 0, 0, rays);
    EXPECT_EQ(l.K, 0.f);
    EXPECT_EQ(rays, 0u);
    EXPECT_FALSE(b.keepSurfaceLink(l));
}

TEST(LinkBuilder, ABlockerSetsTheVisibilityBothEstimatesSee) {
    // Half the gap covered: both the carried estimate (in K) and the judged
    // one (Link::vis, independent rays) see part of the sender.
    Squares half(0.5);
    for (bool judged : {true, false}) {
        LinkBuilder b(half.engine, judged);
        uint32_t rays = 0;
        Link l = b.make(half.h, 1, 0, rays);
        EXPECT_TRUE(l.flags & Link::kPartial) << judged;
        EXPECT_GT(l.vis(), 0.2) << judged;
        EXPECT_LT(l.vis(), 0.8) << judged;
        EXPECT_GT(l.K, 0.2 * kParallelSquares) << judged;
        EXPECT_LT(l.K, 0.8 * kParallelSquares) << judged;
        EXPECT_GT(rays, 0u);
        if (judged) {
            // The judged estimate draws its own rays: twice the carried ones.
            LinkBuilder carried(half.engine, false);
            uint32_t carriedRays = 0;
            carried.make(half.h, 1, 0, carriedRays);
            EXPECT_EQ(rays, 2 * carriedRays);
        }
    }
    // Fully covered: nothing arrives and nothing is kept.
    Squares full(1.0);
    LinkBuilder b(full.engine, true);
    uint32_t rays = 0;
    Link l = b.make(full.h, 1, 0, rays);
    EXPECT_EQ(l.K, 0.f);
    EXPECT_EQ(l.vis(), 0.0);
    EXPECT_FALSE(b.keepSurfaceLink(l));
}

}  // namespace
}  // namespace hrad::hr
