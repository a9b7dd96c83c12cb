// Face clusters (cluster/face_clusters.h, cluster.faces): the builder, the
// tree invariants with face clusters below the bvh, and their links.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "cluster/face_clusters.h"
#include "cluster/link.h"
#include "cluster/tree.h"
#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/cluster/tree_invariants.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"
#include "tests/test_util.h"
#include "transport/visibility.h"

using namespace hrad;
using namespace hrad::cluster;

namespace {

/// An n x n grid of unit-square quads on the plane through `o` spanned by
/// `du`, `dv` (normal du x dv), vertices shared between neighbours.
void addGrid(scene::Scene& s, Vec3 o, Vec3 du, Vec3 dv, int n, uint32_t m) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            Vec3 a = o + double(i) * du + double(j) * dv;
            s.addQuad(a, a + du, a + du + dv, a + dv, m);
        }
}

/// The six faces of the cube [0, n]^3, each an n x n grid, facing outwards
/// (inward = false) or inwards.
scene::Scene tessellatedCube(int n, bool inward, RGB rho = RGB(0.5), RGB E = RGB(0.0)) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", rho, E});
    double N = n;
    Vec3 X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1);
    // (origin, du, dv) with du x dv pointing outwards.
    struct F {
        Vec3 o, du, dv;
    };
    F faces[6] = {{Vec3(0), Y, X},       {Vec3(0, 0, N), X, Y}, {Vec3(0), X, Z},
                  {Vec3(0, N, 0), Z, X}, {Vec3(0), Z, Y},       {Vec3(N, 0, 0), Y, Z}};
    for (F f : faces) {
        if (inward) {
            // Swap the spanning vectors: same square, normal flipped.
            addGrid(s, f.o, f.dv, f.du, n, m);
        } else {
            addGrid(s, f.o, f.du, f.dv, n, m);
        }
    }
    return s;
}

ClusterSettings faceSettings() {
    ClusterSettings cs;
    cs.faces = true;
    return cs;
}

}  // namespace

TEST(FaceClusters, TessellatedPlaneIsOneFlatFaceCluster) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    addGrid(s, Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0), 16, m);
    FaceForest f = buildFaceForest(s, FaceClusterParams{});
    ASSERT_EQ(f.roots.size(), 1u);
    EXPECT_EQ(f.node(f.roots[0]).patches, 256u);
    EXPECT_NEAR(f.node(f.roots[0]).coneCos, 1.0, 1e-12);
    // Balanced: 256 patches in 8 rounds of matching would be perfect.
    EXPECT_LE(f.rounds, 16);
    ClusterTree t(s, faceSettings());
    test::expectTreeInvariants(s, t);
    EXPECT_TRUE(t.node(0).face);
    EXPECT_NEAR(t.faceShape(0).coneCos, 1.0, 1e-12);
    EXPECT_LE(t.faceShape(0).planarity, 1e-12);
    EXPECT_TRUE(t.flatFace(0));
    EXPECT_TRUE(t.planarFace(0));
    EXPECT_EQ(t.numFaceNodes(), t.size());
    EXPECT_LE(t.depth(), 12);
}

TEST(FaceClusters, CubeFacesNeverMergeAcrossRightAngles) {
    for (bool inward : {false, true}) {
        scene::Scene s = tessellatedCube(4, inward);
        // Any cone below 45 degrees (half-angle) keeps 90-degree edges.
        FaceClusterParams fp;
        fp.coneDegrees = 44.0;
        fp.planarity = 1.0;
        FaceForest f = buildFaceForest(s, fp);
        EXPECT_EQ(f.roots.size(), 6u) << "inward " << inward;
        EXPECT_EQ(buildFaceForest(s, FaceClusterParams{}).roots.size(), 6u);
        ClusterTree t(s, faceSettings());
        test::expectTreeInvariants(s, t);
        // Every face cluster's patches share one normal.
        for (uint32_t c = 0; c < t.size(); ++c) {
            const auto& n = t.node(c);
            if (!n.face) continue;
            for (uint32_t i = n.patchBegin; i < n.patchEnd; ++i)
                EXPECT_NEAR(glm::dot(s.patches[t.patchAt(i)].normal, t.faceShape(c).coneAxis), 1.0,
                            1e-12);
        }
        // Six flat roots of 16 patches each.
        int roots16 = 0;
        for (uint32_t c = 0; c < t.size(); ++c)
            roots16 +=
                t.node(c).face && t.node(c).patchEnd - t.node(c).patchBegin == 16 && t.flatFace(c);
        EXPECT_EQ(roots16, 6);
    }
}

TEST(FaceClusters, ConeLimitSplitsACurvedSurface) {
    // A half cylinder of 32 strips (5.6 degrees apart): a 30-degree cone
    // (half-angle) holds at most 11 strips, a tight 2-degree cone none.
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    const int n = 32;
    for (int i = 0; i < n; ++i) {
        double a0 = kPi * i / n, a1 = kPi * (i + 1) / n;
        Vec3 p0(std::cos(a0), std::sin(a0), 0), p1(std::cos(a1), std::sin(a1), 0);
        s.addQuad(p0, p1, p1 + Vec3(0, 0, 1), p0 + Vec3(0, 0, 1), m);
    }
    FaceClusterParams wide;
    wide.planarity = 1.0;
    FaceForest f = buildFaceForest(s, wide);
    for (const auto& nd : f.nodes) {
        EXPECT_GE(nd.coneCos, std::cos(30.0 * kPi / 180) - 1e-9);
        EXPECT_LE(nd.patches, 11u);
    }
    EXPECT_GE(f.roots.size(), 3u);
    FaceClusterParams tight;
    tight.coneDegrees = 2.0;
    EXPECT_TRUE(buildFaceForest(s, tight).nodes.empty());
}

TEST(FaceClusters, CompactnessLimitKeepsStripsApart) {
    // A 1 x 32 strip of unit squares: without a limit one face cluster; with
    // face_compactness 0.5 no cluster longer than about 6 / (0.5 pi) = 3.8
    // squares (compactness of a 1 x n strip: 6 / (pi n) for large n).
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    for (int i = 0; i < 32; ++i)
        s.addQuad(Vec3(i, 0, 0), Vec3(i + 1, 0, 0), Vec3(i + 1, 1, 0), Vec3(i, 1, 0), m);
    EXPECT_EQ(buildFaceForest(s, FaceClusterParams{}).roots.size(), 1u);
    FaceClusterParams fp;
    fp.compactness = 0.5;
    FaceForest f = buildFaceForest(s, fp);
    EXPECT_GE(f.roots.size(), 8u);
    for (const auto& nd : f.nodes) EXPECT_LE(nd.patches, 4u);
}

TEST(FaceClusters, TwinSidesNeverShareAFaceCluster) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    addGrid(s, Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0), 8, m);
    ASSERT_EQ(s.addBackSides(true), 64u);
    FaceClusterParams fp;
    fp.coneDegrees = 89.0;
    fp.planarity = 1.0;
    FaceForest f = buildFaceForest(s, fp);
    EXPECT_EQ(f.roots.size(), 2u);  // one per side
    ClusterTree t(s, faceSettings());
    test::expectTreeInvariants(s, t);
    for (uint32_t c = 0; c < t.size(); ++c) {
        const auto& n = t.node(c);
        if (!n.face) continue;
        std::set<bool> sides;
        for (uint32_t i = n.patchBegin; i < n.patchEnd; ++i)
            sides.insert(s.patches[t.patchAt(i)].backSide);
        EXPECT_EQ(sides.size(), 1u) << "face cluster " << c << " holds both sides";
    }
}

TEST(FaceClusters, InvariantsOnOfficeAndCornell) {
    for (const char* name : {"office:2", "cornell"}) {
        scene::Scene s = scene::loadScene(name);
        ClusterTree t(s, faceSettings());
        test::expectTreeInvariants(s, t);
        EXPECT_GT(t.numFaceNodes(), 0u) << name;
        std::cout << name << ": " << t.size() << " clusters, " << t.numFaceNodes() << " face, "
                  << t.numPlanarFaceNodes() << " planar, depth " << t.depth() << "\n";
    }
}

// Real scenes (skipped without ../shared/scenes): the invariants hold, and
// the forest's sizes are printed (bench/results/face_clusters.md).
TEST(FaceClusters, InvariantsOnSharedScenes) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes absent";
    for (const char* rel : {"lost-empire/lost_empire.obj", "renderpark-mgf/salon/classroom.mgf"}) {
        SCOPED_TRACE(rel);
        Params lp;
        lp.set("scene.clamp_rho", 0.99);
        scene::Scene s = scene::loadScene((*dir / rel).string(), lp);
        FaceForest f = buildFaceForest(s, FaceClusterParams{});
        std::vector<uint32_t> sizes;
        uint32_t lone = 0;
        for (uint32_t r : f.roots) {
            if (f.isPatch(r))
                ++lone;
            else
                sizes.push_back(f.node(r).patches);
        }
        std::sort(sizes.begin(), sizes.end());
        ClusterTree t(s, faceSettings());
        test::expectTreeInvariants(s, t);
        uint64_t inRoots = 0;
        for (uint32_t x : sizes) inRoots += x;
        std::cout << rel << ": " << s.patches.size() << " patches, " << f.rounds << " rounds, "
                  << f.roots.size() << " roots (" << lone << " lone patches, " << sizes.size()
                  << " face clusters holding " << inRoots << " patches; median "
                  << (sizes.empty() ? 0 : sizes[sizes.size() / 2]) << ", largest "
                  << (sizes.empty() ? 0 : sizes.back()) << "), tree " << t.size()
                  << " nodes, depth " << t.depth() << "\n";
    }
}

TEST(FaceClusters, BadSettingsAreClearErrors) {
    Params p;
    p.set("cluster.faces", true, {"study.toml", 3});
    p.set("cluster.builder", std::string("octree"), {"study.toml", 4});
    EXPECT_THROW(ClusterSettings::fromParams(p), InputError);
    Params q;
    q.set("cluster.face_cone", 95.0, {"study.toml", 5});
    try {
        ClusterSettings::fromParams(q);
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("cluster.face_cone"), std::string::npos) << e.what();
    }
}

// Two parallel 4 x 4 plates facing each other at a distance where the
// bounding spheres are apart but closer than `separation` (1.5) times the
// sum of the radii: as volume clusters the link must be opened, as planar
// face clusters it is valid (the oracle decides).
TEST(FaceClusterLinks, PlanarFaceClustersAreNotForcedOpen) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    addGrid(s, Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0), 4, m);          // facing +z
    addGrid(s, Vec3(0, 0, 6.5), Vec3(0, 1, 0), Vec3(1, 0, 0), 4, m);  // facing -z
    for (bool faces : {false, true}) {
        ClusterSettings cs;
        cs.faces = faces;
        cs.leafSize = 16;
        ClusterTree t(s, cs);
        // The node holding each plate.
        uint32_t plate[2] = {UINT32_MAX, UINT32_MAX};
        for (uint32_t c = 0; c < t.size(); ++c)
            if (t.node(c).patchEnd - t.node(c).patchBegin == 16)
                plate[s.patches[t.patchAt(t.node(c).patchBegin)].normal.z > 0 ? 0 : 1] = c;
        ASSERT_NE(plate[0], UINT32_MAX);
        ASSERT_NE(plate[1], UINT32_MAX);
        ClusterLinkSettings ls;
        ls.separation = 1.5;
        ls.faceSeparation = 1.0;  // spheres apart
        ClusterLinker linker(s, &t, ClusterModel::Oriented, nullptr, ls);
        auto end = [&](uint32_t c) {
            LinkEnd e;
            e.isCluster = true;
            e.cluster = c;
            e.center = t.node(c).centroid;
            e.radius = t.node(c).radius;
            e.area = t.node(c).area;
            e.stableId = c;
            e.maxB = 1.0;  // carries light: computed, not deferred
            return e;
        };
        LinkEnd a = end(plate[0]), b = end(plate[1]);
        double dist = glm::length(a.center - b.center);
        ASSERT_GT(dist, a.radius + b.radius);
        ASSERT_LT(dist, 1.5 * (a.radius + b.radius));
        EXPECT_EQ(t.planarFace(plate[0]), faces);
        EXPECT_EQ(linker.opening(a, b) == Opening::None, faces) << "faces " << faces;
        if (faces) {
            ClusterLink l = linker.link(a, b, {});
            EXPECT_EQ(l.open, Opening::None);
            EXPECT_GT(l.K, 0.0);
            // An honest bound: A_s / (pi gap^2) >= any point-to-area factor.
            double gap = dist - a.radius - b.radius;
            EXPECT_NEAR(l.Fupper, 16.0 / (kPi * gap * gap), 1e-9 * l.Fupper);
            EXPECT_GE(l.Fupper, l.K);
        }
    }
}

TEST(FaceClusterLinks, FlatSelfLinkAndCoplanarPairsCarryNothing) {
    scene::Scene s;
    uint32_t m = s.addMaterial({"m", RGB(0.5), RGB(0.0)});
    addGrid(s, Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0), 8, m);
    ClusterTree t(s, faceSettings());
    ASSERT_TRUE(t.flatFace(0));
    ClusterLinker linker(s, &t, ClusterModel::Oriented, nullptr, ClusterLinkSettings{});
    LinkEnd root;
    root.isCluster = true;
    root.center = t.node(0).centroid;
    root.radius = t.node(0).radius;
    root.area = t.node(0).area;
    EXPECT_TRUE(linker.coplanar(root, root));
    ClusterLink l = linker.link(root, root, {});
    EXPECT_EQ(l.open, Opening::None);
    EXPECT_EQ(l.K, 0.0);
    EXPECT_EQ(l.rays, 0u);
    // A volume tree over the same patches opens its self-link instead.
    ClusterTree v(s, ClusterSettings{});
    ClusterLinker vl(s, &v, ClusterModel::Oriented, nullptr, ClusterLinkSettings{});
    root.center = v.node(0).centroid;
    root.radius = v.node(0).radius;
    EXPECT_FALSE(vl.coplanar(root, root));
    EXPECT_NE(vl.link(root, root, {}).open, Opening::None);
}

// The furnace (every surface emits E and reflects rho: B = E / (1 - rho)
// everywhere) with tessellated walls, so that face clusters exist. The
// uniform oracle opens every cluster and must give the exact answer. bfa
// (eps 1e-3) accepts approximate cluster links: with face clusters linked as
// surfaces its power error must be no larger than with volume clusters alone
// on the same scene (measured: faces +1.6 %, volume -2.3 %; worst leaf 6.7 %
// and 5.6 %).
TEST(FaceClusterSolve, TessellatedFurnaceStaysExact) {
    scene::Scene s = tessellatedCube(4, true, RGB(0.5), RGB(1.0));
    transport::Visibility vis(s);
    double powerError[3] = {}, worstError[3] = {};
    const char* names[3] = {"uniform faces", "bfa faces", "bfa volume"};
    for (int run = 0; run < 3; ++run) {
        std::string oracle = run == 0 ? "uniform" : "bfa";
        bool faces = run < 2;
        hr::HrSettings hs = test::hrSettings(oracle, 1e-3, "oriented");
        hs.cluster.faces = faces;
        // uniform: level 1 (not the 2 of hrSettings), to keep the test fast.
        if (oracle == "uniform") hs.oracleParams.set("level", int64_t(1));
        hr::HrSolver solver(s, vis, hs);
        hr::HrResult r = solver.solve();
        ASSERT_TRUE(r.clusterTree);
        if (faces) {
            EXPECT_GT(r.clusterTree->numPlanarFaceNodes(), 6u);
        }
        const hr::Hierarchy& h = *r.hierarchy;
        double worst = 0, power = 0, area = 0;
        for (uint32_t e = 0; e < h.numElements(); ++e)
            if (h.isLeaf(e)) {
                worst = std::max(worst, std::fabs(h.B(e).g - 2.0) / 2.0);
                power += h.area(e) * h.B(e).g;
                area += h.area(e);
            }
        powerError[run] = std::fabs(power / (2.0 * area) - 1.0);
        worstError[run] = worst;
        std::cout << names[run] << ": " << h.numLinks() << " links, worst relative error " << worst
                  << ", power " << power / (2.0 * area) << " of exact\n";
    }
    EXPECT_LT(worstError[0], 1e-3);
    EXPECT_LT(powerError[0], 1e-6);
    EXPECT_LE(powerError[1], std::max(0.005, powerError[2]));
    EXPECT_LT(worstError[1], 0.1);
}
