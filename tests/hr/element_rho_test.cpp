// Reflectance per element on textured root patches (hr.texture_rho =
// element, hr/element_rho.h): children carry their own texel means, leaves
// apply them to the pushed irradiance, and the power the leaves reflect is
// what the links bring through each leaf's rho.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "hr/solver.h"
#include "scene/builtin.h"
#include "scene/element.h"
#include "scene/texture.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"
#include "transport/visibility.h"

namespace hrad::hr {
namespace {

/// A unit floor quad (z = 0, UV = (x, y), rho 0.5) under a black emitting
/// unit square at z = 1 (E = 1), its texture black in the columns u < 1/2
/// and white (1) in the others (test::halfBlackTexture).
scene::Scene halfBlackFloor() { return test::floorUnderLamp(test::halfBlackTexture(1.f)); }

/// The furnace box with an n x n checker (0.1 / 0.7, mean 0.4) on every wall.
scene::Scene checkerFurnace(int n) {
    scene::Scene s = test::furnaceBox(1.0, 0.4);
    scene::Texture t;
    t.file = "checker";
    t.width = t.height = n;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) t.texels.push_back((i + j) % 2 ? 0.7f : 0.1f);
    s.materials[0].diffuseMap.texture = scene::addTexture(s, std::move(t));
    for (scene::Patch& p : s.patches) {
        p.uvs = uint32_t(s.cornerUVs.size());
        s.cornerUVs.push_back({glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
    }
    scene::applyTextureMeans(s);
    return s;
}

/// The uniform oracle at `level` (the same links whatever rho is), converged far.
HrSettings uniformAt(int level, bool elementRho, const std::string& cluster = "none") {
    Params p;
    p.set("hr.oracle", std::string("uniform"));
    p.set("oracle.level", int64_t(level));
    p.set("hr.tolerance", 1e-9);
    p.set("hr.max_iterations", int64_t(400));
    p.set("cluster.model", cluster);
    p.set("hr.texture_rho", std::string(elementRho ? "element" : "patch"));
    HrSettings s = HrSettings::fromParams(p);
    p.reportUnused();
    return s;
}

TEST(ElementRho, HalfBlackFloorsChildrenCarryTheirTexelMeans) {
    const scene::Scene s = halfBlackFloor();
    ASSERT_EQ(s.patches[0].rho.r, 0.5);  // the patch mean
    transport::Visibility vis(s);
    HrResult el = HrSolver(s, vis, uniformAt(3, true)).solve();
    HrResult pa = HrSolver(s, vis, uniformAt(3, false)).solve();
    ASSERT_TRUE(el.converged && pa.converged);
    const Hierarchy& h = *el.hierarchy;
    const Hierarchy& hp = *pa.hierarchy;
    ASSERT_EQ(h.numElements(), hp.numElements());  // the uniform oracle: the same elements
    EXPECT_EQ(h.rho(0).r, 0.5);
    int black = 0, white = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (h.patch(e) != 0 || h.level(e) == 0) continue;
        const scene::Domain d = h.domain(e);
        // Every element lies in one half: the black one's mean is 0, the
        // white one's 1, clamped to scene.clamp_rho (0.99).
        const bool isBlack = d.u0 + d.h <= 0.5;
        ASSERT_TRUE(isBlack || d.u0 >= 0.5);
        for (int c = 0; c < 3; ++c) ASSERT_EQ(h.rho(e)[c], isBlack ? 0.0 : 0.99) << e;
        if (!h.isLeaf(e)) continue;
        if (isBlack) {
            // B = E + 0 * H, exactly E (0).
            for (int c = 0; c < 3; ++c) ASSERT_EQ(h.B(e)[c], 0.0) << e;
            ++black;
        } else {
            // The lamp is black: H per leaf is the links' alone, the same in
            // both solves; B = rho_leaf H here and rho_bar H there.
            EXPECT_GT(h.B(e).g, 0.0);
            EXPECT_NEAR(h.B(e).g / 0.99, hp.B(e).g / 0.5, 1e-12 * hp.B(e).g) << e;
            ++white;
        }
    }
    EXPECT_EQ(black, 32);  // 64 leaves at level 3, half in each half
    EXPECT_EQ(white, 32);
    // The floor's mean: half of 0.99 H against 0.5 H.
    EXPECT_NEAR(h.B(0).g, 0.5 * 0.99 / 0.5 * hp.B(0).g, 1e-12 * hp.B(0).g);
    EXPECT_GT(h.elementRhoBytes(), 0u);
}

/// The block Gauss-Seidel sweep (hr.iteration = gauss-seidel) pushes the
/// same irradiance: the black half stays exactly E, the white half is the
/// Jacobi solve's to the convergence tolerance.
TEST(ElementRho, GaussSeidelSweepAppliesEachLeafsRho) {
    const scene::Scene s = halfBlackFloor();
    transport::Visibility vis(s);
    HrSettings gs = uniformAt(3, true);
    gs.gaussSeidel = true;
    HrResult g = HrSolver(s, vis, gs).solve();
    HrResult j = HrSolver(s, vis, uniformAt(3, true)).solve();
    ASSERT_TRUE(g.converged && j.converged);
    const Hierarchy& h = *g.hierarchy;
    ASSERT_EQ(h.numElements(), j.hierarchy->numElements());
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (h.patch(e) != 0 || !h.isLeaf(e)) continue;
        if (h.rho(e).g == 0.0) {
            EXPECT_EQ(h.B(e).g, 0.0) << e;
        } else {
            // The lamp is black: one bounce, so both are exact after two
            // iterations up to rounding.
            EXPECT_NEAR(h.B(e).g, j.hierarchy->B(e).g, 1e-12 * j.hierarchy->B(e).g) << e;
        }
    }
}

TEST(ElementRho, UntexturedScenesCarryNoTable) {
    const scene::Scene s = test::furnaceBox(1.0, 0.5);
    transport::Visibility vis(s);
    HrResult el = HrSolver(s, vis, uniformAt(2, true)).solve();
    HrResult pa = HrSolver(s, vis, uniformAt(2, false)).solve();
    const Hierarchy& h = *el.hierarchy;
    EXPECT_EQ(h.elementRhoBytes(), 0u);
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        EXPECT_FALSE(h.pushesIrradiance(e));
        for (int c = 0; c < 3; ++c) ASSERT_EQ(h.B(e)[c], pa.hierarchy->B(e)[c]);
    }
}

/// Where every element covers whole checker periods (levels <= 2 of an 8 x 8
/// checker) its mean is the patch mean, and pushing irradiance gives the
/// constant-rho furnace again: B = E / (1 - rho_bar).
TEST(ElementRho, TexturedFurnaceStaysExact) {
    const scene::Scene s = checkerFurnace(8);
    transport::Visibility vis(s);
    HrResult el = HrSolver(s, vis, uniformAt(2, true)).solve();
    HrResult pa = HrSolver(s, vis, uniformAt(2, false)).solve();
    ASSERT_TRUE(el.converged && pa.converged);
    const Hierarchy& h = *el.hierarchy;
    const double rhoBar = s.patches[0].rho.r;
    ASSERT_NEAR(rhoBar, 0.4, 1e-7);  // float texels
    int leaves = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e)) continue;
        // Midpoints two per texel integrate the bilinear checker exactly
        // over whole periods; the tolerance is double rounding.
        EXPECT_NEAR(h.rho(e).r, rhoBar, 1e-12) << e;
        // The per-patch solve to rounding (multiplying at the leaf instead
        // of at each level), and the closed form to the convergence tolerance.
        EXPECT_NEAR(h.B(e).r, pa.hierarchy->B(e).r, 1e-12) << e;
        EXPECT_NEAR(h.B(e).r, 1.0 / (1.0 - rhoBar), 1e-6) << e;
        ++leaves;
    }
    EXPECT_EQ(leaves, 6 * 16);
    // A linear basis (pushPullPolynomial) likewise, to the same rounding.
    for (bool element : {true, false}) {
        HrSettings st = uniformAt(2, element);
        st.basisDegree = 1;
        HrResult r = HrSolver(s, vis, st).solve();
        ASSERT_TRUE(r.converged);
        (element ? el : pa) = std::move(r);
    }
    for (uint32_t e = 0; e < el.hierarchy->numElements(); ++e)
        if (el.hierarchy->isLeaf(e)) {
            EXPECT_NEAR(el.hierarchy->B(e).r, pa.hierarchy->B(e).r, 1e-12) << e;
            for (int a = 0; a < el.hierarchy->basisSize() - 1; ++a)
                EXPECT_NEAR(el.hierarchy->hi(e)[a].r, pa.hierarchy->hi(e)[a].r, 1e-12) << e;
        }
}

/// One gather and push-pull: the leaves' A (B - E) summed against the
/// links' light (Hierarchy::linkLight), and the checker's rho in the leaves.
void reflectedPowerBalances(Hierarchy& h, const std::string& model, double tolerance = 1e-12) {
    std::vector<RGB> reflected;
    h.linkLight(reflected);
    RGB links(0.0);
    for (const RGB& x : reflected) links += x;
    h.gather();
    h.pushPull();
    const RGB leaves = h.reflectedPower();
    // linkLight reads the radiosities this gather reads, and the leaves' B
    // after the push-pull is what it brought: equal up to the order of the
    // sums (1e-12).
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(leaves[c], links[c], tolerance * leaves[c]) << model;
}

/// Energy balance: one gather and push-pull after the solve reflect, summed
/// over the leaves (A_l (B_l - E)), exactly the light the links bring with
/// each receiver's leaves' own rho (Hierarchy::linkLight: sum over leaves
/// below the receiver of A_l rho_l). On a 4 x 4 checker level-2 elements
/// cover one texel each, whose means are the texels' 0.1 and 0.7, so rho
/// varies from element to element.
TEST(ElementRho, ReflectedPowerIsTheLinksLightThroughEachLeafsRho) {
    const scene::Scene s = checkerFurnace(4);
    transport::Visibility vis(s);
    for (const std::string model : {"none", "isotropic", "oriented"}) {
        HrResult r = HrSolver(s, vis, uniformAt(2, true, model)).solve();
        Hierarchy& h = *r.hierarchy;
        double lo = 1.0, hi = 0.0;
        for (uint32_t e = 0; e < h.numElements(); ++e)
            if (h.isLeaf(e)) lo = std::min(lo, h.rho(e).r), hi = std::max(hi, h.rho(e).r);
        // The checker shows in the elements: a level-2 leaf is one texel,
        // whose mean as a square (scene/texture.h) is its value.
        EXPECT_NEAR(lo, 0.1, 1e-7) << model;
        EXPECT_NEAR(hi, 0.7, 1e-7) << model;
        reflectedPowerBalances(h, model);
    }
}

/// The same where links into clusters stay (a coarse bfa eps): what they
/// hand a textured patch is reflected by its leaves, not by its mean.
TEST(ElementRho, ClusterLinksLightTexturedLeavesThroughTheirRho) {
    // office:1 (a furnished room) with a 2 x 2 checker of 0.1 and 1.6 (an
    // HDR texture) on every non-emitting patch: patch means 0.85, children
    // (10 a + 6 b) / 16 = 0.6625 and 1.0375, the bright one clamped to 0.99,
    // so a subdivided patch's leaves reflect less than its mean (the
    // children of an unclamped texture average to the patch mean exactly).
    scene::Scene s = scene::makeOffice(1);
    scene::Texture t;
    t.file = "checker";
    t.width = t.height = 2;
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) t.texels.push_back((i + i / 2) % 2 ? 1.6f : 0.1f);
    const int32_t tex = scene::addTexture(s, std::move(t));
    for (scene::Material& m : s.materials)
        if (maxComponent(m.emission) == 0) m.diffuseMap.texture = tex;
    s.cornerUVs.push_back({glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
    for (scene::Patch& p : s.patches) p.uvs = 0;
    ASSERT_GT(scene::applyTextureMeans(s), 0u);
    transport::Visibility vis(s);
    for (const std::string model : {"isotropic", "oriented"}) {
        HrSettings st = test::hrSettings("bfa", 0.01, model);
        st.elementRho = true;
        HrResult r = HrSolver(s, vis, st).solve();
        Hierarchy& h = *r.hierarchy;
        uint64_t intoClusters = 0;
        for (uint32_t e = 0; e < h.numElements(); ++e)
            if (h.isCluster(e)) intoClusters += h.linkEnd(e) - h.linkBegin(e);
        std::cout << model << ": " << intoClusters << " links into clusters, " << h.numLinks()
                  << " links\n";
        EXPECT_GT(intoClusters, 0u) << model;
        // Links into clusters above subdivided textured patches, whose
        // leaves reflect other than the patch mean.
        uint64_t aboveLeaves = 0;
        for (uint32_t p = 0; p < h.numPatches(); ++p) {
            if (h.firstChild(p) == kNone) continue;
            for (uint32_t c = h.parent(p); c != kNone; c = h.parent(c))
                aboveLeaves += h.linkEnd(c) - h.linkBegin(c);
        }
        std::cout << model << ": " << aboveLeaves << " links into clusters above subdivided patches\n";
        EXPECT_GT(aboveLeaves, 0u) << model;
        // The oriented push hands each link's light to the patches below as
        // a float (clusterIrradianceToRoots' `sent`), linkLight in double:
        // float rounding, 6e-8 of what those links bring (1e-10 measured).
        reflectedPowerBalances(h, model, model == "oriented" ? 1e-7 : 1e-12);
    }
}

}  // namespace
}  // namespace hrad::hr
