// Volume clustering inside the hierarchical solver (issue "Volume clustering").
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <iostream>
#include <optional>

#include "cluster/openness.h"
#include "core/rng.h"
#include "hr/openness_handover.h"
#include "hr/receiver_error.h"
#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "tests/scenes.h"
#include "tests/test_util.h"

using namespace hrad;
using namespace hrad::hr;

namespace {
HrSettings clustered(const std::string& model, const std::string& oracle, double eps) {
    return test::hrSettings(oracle, eps, model);
}

// Two solves gave the same hierarchy and radiosities, bit for bit (the first
// difference in the message).
::testing::AssertionResult sameSolution(const HrResult& a, const HrResult& b) {
    const Hierarchy &ha = *a.hierarchy, &hb = *b.hierarchy;
    if (ha.numElements() != hb.numElements())
        return ::testing::AssertionFailure()
               << "elements " << ha.numElements() << " vs " << hb.numElements();
    if (ha.numLinks() != hb.numLinks())
        return ::testing::AssertionFailure()
               << "links " << ha.numLinks() << " vs " << hb.numLinks();
    for (uint32_t e = 0; e < ha.numElements(); ++e)
        if (std::memcmp(&ha.B(e), &hb.B(e), sizeof(RGB)) != 0)
            return ::testing::AssertionFailure() << "B differs at element " << e;
    return ::testing::AssertionSuccess();
}
}  // namespace

class ClusterModels : public ::testing::TestWithParam<std::string> {};

// The uniform oracle opens every cluster and subdivides every surface to its
// level, so the clustered solve must reproduce the exact furnace answer.
TEST_P(ClusterModels, FurnaceStillGivesEOverOneMinusRho) {
    scene::Scene s = test::furnaceBox(1.0, 0.5);
    transport::Visibility vis(s);
    HrSolver solver(s, vis, clustered(GetParam(), "uniform", 0));
    HrResult r = solver.solve();
    EXPECT_TRUE(r.converged);
    ASSERT_TRUE(r.clusterTree);
    const Hierarchy& h = *r.hierarchy;
    EXPECT_GT(h.numClusters(), 0u);
    double worst = 0;
    for (uint32_t e = 0; e < h.numElements(); ++e)
        if (h.isLeaf(e)) worst = std::max(worst, std::fabs(h.B(e).g - 2.0) / 2.0);
    std::cout << GetParam() << ": worst relative error " << worst << "\n";
    EXPECT_LT(worst, 1e-3);
}

// Push-pull through clusters conserves power: what a cluster gathers reaches
// the surfaces below it (isotropic: rho_p H on every patch; oriented: rho_p K B
// cos per link), and clusters hold the area average of their children.
TEST_P(ClusterModels, PushPullConservesPowerThroughClusters) {
    scene::Scene s = scene::loadScene("office:1");
    cluster::ClusterTree tree(s, cluster::ClusterSettings{});
    auto model = cluster::parseClusterModel(GetParam());
    Hierarchy h(s, &tree, model);
    Pcg32 rng(5);
    // Links into clusters from an emitting patch (oriented model needs them).
    uint32_t emitter = 0;
    while (!s.patches[emitter].isEmitter()) ++emitter;
    std::vector<uint32_t> recv;
    std::vector<Link> links;
    for (uint32_t c = h.rootCluster() + 1; c < h.rootCluster() + h.numClusters(); c += 5) {
        Link l;
        l.sender = emitter;
        l.K = float(0.01 * (1 + rng.nextDouble()));
        l.setVis(1.0);
        recv.push_back(c);
        links.push_back(l);
    }
    h.setLinks(recv, std::vector<Link>(links));
    h.gather();
    // Expected power from the clusters' incoming links, computed here.
    RGB expected = s.emittedPower();
    const RGB& Be = h.B(emitter);
    for (size_t i = 0; i < recv.size(); ++i) {
        const auto& node = tree.node(h.clusterIndex(recv[i]));
        Vec3 u = glm::normalize(h.center(emitter) - node.centroid);
        for (uint32_t k = node.patchBegin; k < node.patchEnd; ++k) {
            const auto& p = s.patches[tree.patchAt(k)];
            double w = GetParam() == "isotropic"
                           ? 1.0
                           : std::max(0.0, double(glm::dot(glm::vec3(p.normal), glm::vec3(u))));
            expected += p.area * p.rho * double(links[i].K) * w * Be;
        }
    }
    h.pushPull();
    RGB got = h.radiosityPower();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-6 * expected[c]);
    // Clusters hold the area-weighted average of the leaves below them.
    RGB rootAvg = h.B(h.rootCluster()) * h.area(h.rootCluster());
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rootAvg[c], got[c], 1e-9 * got[c]);
}

// The share of the light the leaf estimates do not see
// (uncoveredLightShare): what the links into clusters deliver, over what
// every link delivers, each computed here from the transfer of the test
// above (surface receiver: A rho K B; cluster: its surfaces' A rho K w B).
TEST_P(ClusterModels, UncoveredShareIsTheLightOfTheClusterLinks) {
    scene::Scene s = scene::loadScene("office:1");
    cluster::ClusterTree tree(s, cluster::ClusterSettings{});
    const auto model = cluster::parseClusterModel(GetParam());
    Hierarchy h(s, &tree, model);
    uint32_t emitter = 0;
    while (!s.patches[emitter].isEmitter()) ++emitter;
    std::vector<uint32_t> recv;
    std::vector<Link> links;
    auto add = [&](uint32_t r, double K) {
        Link l;
        l.sender = emitter;
        l.K = float(K);
        l.setVis(1.0);
        recv.push_back(r);
        links.push_back(l);
    };
    // Surface links only: nothing is left out.
    for (uint32_t p = 0; p < h.numPatches(); p += 7)
        if (!s.patches[p].isEmitter()) add(p, 0.02);
    const std::vector<uint32_t> surfaceRecv = recv;
    const std::vector<Link> surfaceLinks = links;
    h.setLinks(recv, std::vector<Link>(links));
    h.gather();
    h.pushPull();
    auto share = [&h] {
        std::vector<RGB> light;
        h.linkLight(light);
        return uncoveredLightShare(h, h.linkReceivers(), light);
    };
    EXPECT_EQ(share(), 0.0);
    // Then clusters too.
    for (uint32_t c = h.rootCluster() + 1; c < h.rootCluster() + h.numClusters(); c += 5)
        add(c, 0.01);
    h.setLinks(recv, std::vector<Link>(links));
    h.gather();
    h.pushPull();
    const RGB Be = h.B(emitter);
    double surface = 0.0, clustered = 0.0;
    for (size_t i = 0; i < recv.size(); ++i) {
        const double K = links[i].K;
        if (!h.isCluster(recv[i])) {
            const auto& p = s.patches[recv[i]];
            surface += p.area * K * luminance(p.rho * Be);
            continue;
        }
        const auto& node = tree.node(h.clusterIndex(recv[i]));
        const Vec3 u = glm::normalize(h.center(emitter) - node.centroid);
        for (uint32_t k = node.patchBegin; k < node.patchEnd; ++k) {
            const auto& p = s.patches[tree.patchAt(k)];
            const double w = GetParam() == "isotropic"
                                 ? 1.0
                                 : std::max(0.0, double(glm::dot(glm::vec3(p.normal), glm::vec3(u))));
            clustered += p.area * K * w * luminance(p.rho * Be);
        }
    }
    ASSERT_GT(clustered, 0.0);
    ASSERT_GT(surface, 0.0);
    const double got = share();
    std::cout << GetParam() << ": share of the light through cluster links " << got << "\n";
    EXPECT_NEAR(got, clustered / (clustered + surface), 1e-5);
}

INSTANTIATE_TEST_SUITE_P(Cluster, ClusterModels, ::testing::Values("isotropic", "oriented"));

// The oriented hand-over with the openness table (cluster.handover = visible,
// cluster/openness.h): a cluster holding a roof, a plate under the roof and a
// plate in the open, lit from far above through one link. Every upward ray
// from the covered plate meets the roof inside the cluster, so it gets
// nothing; the power the link delivers, K B_e sum_k A_k cos_k, is the same as
// by cosine alone (the linker divides K by the cluster's openness W), and
// lands on the roof and the open plate. By cosine alone the covered plate
// would get as much per unit area as the open one.
TEST(ClusterTransfer, HandOverLightsOnlyTheSurfacesThatSeeOut) {
    scene::Scene s;
    uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(1.0)});
    uint32_t grey = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    const Vec3 up(0, 0, 100);
    s.addQuad(Vec3(1.5, 0, 10), Vec3(1.5, 1, 10), Vec3(2.5, 1, 10), Vec3(2.5, 0, 10), light);
    test::addQuadFacing(s, Vec3(-0.5, -0.5, 0.3), Vec3(1.5, -0.5, 0.3), Vec3(1.5, 1.5, 0.3),
                        Vec3(-0.5, 1.5, 0.3), grey, up);  // roof
    test::addQuadFacing(s, Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), grey,
                        up);  // under the roof
    test::addQuadFacing(s, Vec3(3, 0, 0), Vec3(4, 0, 0), Vec3(4, 1, 0), Vec3(3, 1, 0), grey,
                        up);  // in the open
    const uint32_t emitter = 0, roof = 1, covered = 2, exposed = 3;
    ASSERT_TRUE(s.patches[emitter].isEmitter());
    ASSERT_GT(s.patches[roof].normal.z, 0.99);
    transport::Visibility vis(s);
    cluster::ClusterSettings cs;
    cs.leafSize = 3;
    cluster::ClusterTree tree(s, cs);
    // The cluster of the three grey plates.
    uint32_t c = UINT32_MAX;
    for (uint32_t i = 0; i < tree.size(); ++i)
        if (tree.node(i).patchEnd - tree.node(i).patchBegin == 3) c = i;
    ASSERT_NE(c, UINT32_MAX);
    const cluster::ClusterNode& node = tree.node(c);
    cluster::SurfaceOpenness openness(s, tree, vis);
    EXPECT_EQ(openness.rays(), 4u * 64u);
    Hierarchy h(s, &tree, cluster::ClusterModel::Oriented);
    const uint32_t ce = h.numPatches() + c;
    Vec3 u = glm::normalize(h.center(emitter) - h.center(ce));
    // Openness within the cluster: the covered plate is closed, the others
    // open; within a sphere that ends below the roof, the covered plate is
    // open too.
    auto w = [&](uint32_t p, const Vec3& d, const Vec3& center, double radius) {
        auto v = openness.view(p);
        return openness.openness(v, openness.inside(v, center, radius), d,
                                 glm::dot(s.patches[p].normal, d));
    };
    EXPECT_EQ(w(covered, u, node.centroid, node.radius), 0.0);
    EXPECT_EQ(w(exposed, u, node.centroid, node.radius), 1.0);
    EXPECT_EQ(w(roof, u, node.centroid, node.radius), 1.0);
    EXPECT_EQ(w(covered, u, Vec3(0.5, 0.5, -0.5), 0.75), 1.0);
    EXPECT_EQ(w(covered, -u, node.centroid, node.radius), 0.0);
    double sumCos = 0.0, sumOpen = 0.0;
    for (uint32_t p : {roof, covered, exposed}) {
        double cosine = std::max(0.0, glm::dot(s.patches[p].normal, u));
        sumCos += s.patches[p].area * cosine;
        if (p != covered) sumOpen += s.patches[p].area * cosine;
    }
    // The cluster's openness towards the sender: the roof and the exposed
    // plate's share of sum A cos.
    const double W = sumOpen / sumCos;
    const double K = 0.01;
    auto run = [&](bool visible) {
        Hierarchy hh(s, &tree, cluster::ClusterModel::Oriented);
        if (visible) hh.setHandOver(std::make_unique<OpennessHandOver>(s, tree, openness, nullptr));
        Link l;
        l.sender = emitter;
        l.K = float(K);
        l.setVis(1.0);
        hh.setLinks({ce}, {l});
        // setLinks hands the new link over once: K divided by W, flagged.
        const Link& set = hh.link(0);
        EXPECT_TRUE(set.flags & Link::kHandedOver || !visible);
        EXPECT_EQ(bool(set.flags & Link::kOpenHandOver), visible);
        EXPECT_NEAR(set.K, visible ? K / W : K, 1e-6 * K / W);
        EXPECT_EQ(hh.handOver().counts().byOpenness, visible ? 1u : 0u);
        hh.gather();
        hh.pushPull();
        std::array<double, 4> reflected{};
        for (uint32_t p : {roof, covered, exposed}) reflected[p] = hh.B(p).g;
        return reflected;
    };
    auto byCosine = run(false), byOpenness = run(true);
    const double Kf = double(float(double(float(K)) / W));
    EXPECT_EQ(byOpenness[covered], 0.0);
    EXPECT_GT(byCosine[covered], 0.9 * byCosine[exposed]);
    EXPECT_NEAR(byOpenness[exposed], 0.5 * Kf * glm::dot(s.patches[exposed].normal, u), 1e-9);
    auto power = [&](const std::array<double, 4>& b) {
        return s.patches[roof].area * b[roof] + s.patches[covered].area * b[covered] +
               s.patches[exposed].area * b[exposed];
    };
    EXPECT_NEAR(power(byOpenness), power(byCosine), 1e-6 * power(byCosine));
    EXPECT_NEAR(power(byCosine), 0.5 * double(float(K)) * sumCos, 1e-9);
    // No surface takes more than the link's unoccluded bound: with Fupper
    // between K and K / W, K / W is held to Fupper and the power past it is
    // not delivered (hr/openness_handover.h).
    ASSERT_LT(W, 0.9);
    const double bound = 0.5 * (K + K / W);
    Hierarchy hb(s, &tree, cluster::ClusterModel::Oriented);
    hb.setHandOver(std::make_unique<OpennessHandOver>(s, tree, openness, nullptr));
    Link l;
    l.sender = emitter;
    l.K = float(K);
    l.Fupper = float(bound);
    l.setVis(1.0);
    hb.setLinks({ce}, {l});
    EXPECT_TRUE(hb.link(0).flags & Link::kOpenHandOver);
    EXPECT_NEAR(hb.link(0).K, bound, 1e-6 * bound);
    EXPECT_EQ(hb.handOver().counts().capped, 1u);
    EXPECT_EQ(hb.handOver().counts().byOpenness, 1u);
}

// An emitter below a group of small quads that all face up, away from it.
// Accepted at cluster level (eps = 1), the oriented model gives the group
// nothing, the isotropic model A/4-weighted irradiance:
//   B = rho * E * A_e cos_e * (1/4) / (pi d^2).
TEST(ClusterTransfer, OrientedAndIsotropicModelsDiffer) {
    scene::Scene s;
    uint32_t light = s.addMaterial({"light", RGB(0.0), RGB(1.0)});
    uint32_t grey = s.addMaterial({"grey", RGB(0.5), RGB(0.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), light);  // faces +z
    double z = 10.0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            double x = 0.35 + 0.3 * i, y = 0.35 + 0.3 * j, a = 0.05;
            s.addQuad(Vec3(x - a, y - a, z), Vec3(x + a, y - a, z), Vec3(x + a, y + a, z),
                      Vec3(x - a, y + a, z), grey);  // faces +z, away from the light
        }
    transport::Visibility vis(s);
    auto run = [&](const std::string& model) {
        Params p;
        p.set("cluster.model", model);
        p.set("oracle.eps", 1.0);
        p.set("cluster.leaf_size", int64_t(4));
        // The four quads face away from the light: light cannot reach them,
        // and the reachability pass would leave them out. The isotropic
        // model's transfer to them (it ignores orientation) is what is
        // tested here, so the pass is off.
        p.set("hr.reach_rays", int64_t(0));
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        return solver.solve();
    };
    HrResult oriented = run("oriented");
    HrResult isotropic = run("isotropic");
    // The group receives as a cluster from the emitter surface.
    EXPECT_GT(isotropic.linksCS, 0u) << "the group should be linked as a cluster";
    double expectedB = 0.5 * 1.0 * 1.0 * 0.25 / (kPi * z * z);
    for (uint32_t p = 1; p < 5; ++p) {
        EXPECT_EQ(oriented.hierarchy->B(p), RGB(0.0)) << "oriented cluster facing away";
        EXPECT_NEAR(isotropic.hierarchy->B(p).r, expectedB, 1e-6 * expectedB);
    }
}

// Initial cost on office:N: links after the first refinement pass grow no
// faster than k log k with clustering, against k^2 without. Without
// clustering the visible pairs of a grid of rooms grow slower than k^2
// (walls hide most pairs), but every pair must be evaluated: the cost of the
// first pass (node pairs whose transfer is computed) is k(k-1).
TEST(ClusterScaling, FirstPassLinksNearLinearInPatches) {
    auto firstPass = [](const std::string& scene, const std::string& model, double& k,
                        double& evaluated) {
        scene::Scene s = scene::loadScene(scene);
        k = double(s.patches.size());
        transport::Visibility vis(s);
        Params p;
        p.set("cluster.model", model);
        p.set("hr.max_iterations", int64_t(1));
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        HrResult r = solver.solve();
        evaluated = double(r.initialPairs + r.history.at(0).formFactors);
        return double(r.history.at(0).links);
    };
    auto slope = [](const std::vector<double>& x, const std::vector<double>& y) {
        double n = double(x.size()), sx = 0, sy = 0, sxx = 0, sxy = 0;
        for (size_t i = 0; i < x.size(); ++i) {
            double lx = std::log(x[i]), ly = std::log(y[i]);
            sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
        }
        return (n * sxy - sx * sy) / (n * sxx - sx * sx);
    };
    std::vector<double> kc, lc, ec;
    for (int n : {1, 2, 4, 8}) {
        double k, ev;
        lc.push_back(firstPass("office:" + std::to_string(n), "oriented", k, ev));
        kc.push_back(k);
        ec.push_back(ev);
        std::cout << "office:" << n << " k=" << k << " clustered: first-pass links " << lc.back()
                  << ", pairs evaluated " << ev << "\n";
    }
    std::vector<double> ku, lu, eu;
    for (int n : {1, 2}) {
        double k, ev;
        lu.push_back(firstPass("office:" + std::to_string(n), "none", k, ev));
        ku.push_back(k);
        eu.push_back(ev);
        std::cout << "office:" << n << " k=" << k << " unclustered: first-pass links " << lu.back()
                  << ", pairs evaluated " << ev << "\n";
    }
    double sc = slope(kc, lc), sce = slope(kc, ec), su = slope(ku, lu), sue = slope(ku, eu);
    // k log k over k = 225..14400 has a fitted exponent of about 1.2.
    std::cout << "fitted exponents: clustered links " << sc << ", evaluations " << sce
              << "; unclustered links " << su << ", evaluations " << sue << "\n";
    EXPECT_LT(sc, 1.25);
    EXPECT_LT(sce, 1.25);
    EXPECT_GT(sue, 1.9);
}

// Oriented clustering keeps the light of the unclustered solve (bfa, eps 1e-3)
// on office:2: two furnished rooms joined by a 1 x 2.1 m doorway, 900 patches.
// Radiosity power (sum A B, green), measured at eps 1e-3 with 8 cluster
// visibility rays:
//   unclustered (cluster.model = none)                182.43   134k links
//   oriented, before (mean B judged, one visibility
//     estimate for oracle and K, all-blocked links
//     dropped, mean B pushed)                          174.27   -4.5 %
//   oriented, brightest-patch judging etc.             182.65   +0.1 %, 21k links
//   oriented, now (power-sampled, kernel-weighted
//     cluster visibility; cluster.separation 1.5)      182.73   +0.2 %
// The tolerance of 1 % leaves a margin of ~0.9 % for changes of sampling
// (the estimate converges to +0.1 % with 256 rays) and fails the old loss.
TEST(ClusterTransfer, OrientedKeepsTheLightOfTheUnclusteredSolve) {
    scene::Scene s = scene::loadScene("office:2");
    transport::Visibility vis(s);
    auto power = [&](const std::string& model, uint64_t& links) {
        Params p;
        p.set("cluster.model", model);
        p.set("oracle.eps", 1e-3);
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        HrResult r = solver.solve();
        EXPECT_TRUE(r.converged) << model;
        links = r.hierarchy->numLinks();
        return r.hierarchy->radiosityPower();
    };
    uint64_t linksNone = 0, linksOriented = 0;
    RGB none = power("none", linksNone);
    RGB oriented = power("oriented", linksOriented);
    for (int c = 0; c < 3; ++c) {
        double rel = (oriented[c] - none[c]) / none[c];
        std::cout << "channel " << c << ": none " << none[c] << ", oriented " << oriented[c] << " ("
                  << 100 * rel << " %)\n";
        EXPECT_LT(std::fabs(rel), 0.01) << "channel " << c;
    }
    // Clustering must still pay: far fewer links than the unclustered solve.
    std::cout << "links: none " << linksNone << ", oriented " << linksOriented << "\n";
    EXPECT_LT(linksOriented * 3, linksNone);
}

// cluster.partial_receivers = open (the default): a partially visible link
// into a cluster may hand its unseen fraction to the wrong surfaces, so that
// power, and its sum over the links into one cluster, must be within eps or
// the receiving cluster is opened (hr/solver.h). The check's misplaced power
// comes from the decision pass's own estimate and the per-cluster sums are
// judged after it; this pins that the check still refines. Measured on
// office:2 (oriented, bfa 1e-3): 50,580 links with it, 43,265 without.
TEST(ClusterTransfer, PartialReceiversAreOpenedWhereTheirUnseenLightMatters) {
    scene::Scene s = scene::loadScene("office:2");
    transport::Visibility vis(s);
    auto solve = [&](const std::string& mode) {
        Params p;
        p.set("cluster.model", "oriented");
        p.set("cluster.partial_receivers", mode);
        p.set("oracle.eps", 1e-3);
        HrSolver solver(s, vis, HrSettings::fromParams(p));
        HrResult r = solver.solve();
        EXPECT_TRUE(r.converged) << mode;
        return std::pair<uint64_t, RGB>(r.hierarchy->numLinks(), r.hierarchy->radiosityPower());
    };
    auto [openLinks, openPower] = solve("open");
    auto [keepLinks, keepPower] = solve("keep");
    std::cout << "links: open " << openLinks << ", keep " << keepLinks << "\n";
    EXPECT_GT(double(openLinks), 1.1 * double(keepLinks));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(openPower[c] / keepPower[c], 1.0, 0.01) << c;
}

// office:3 (odd N: the BVH lays clusters across the walls between rooms)
// lost 4.1 % of the radiosity power with oriented clustering (389.09 against
// 405.79, green), 3.7 % even with 64 cluster visibility rays. Measured per
// link against Monte Carlo integrals of the same links, accepted links
// between two clusters whose bounding spheres were less than twice their
// radii apart carried 15-19 % too little unoccluded transfer (the point
// approximation along the centroid direction), and cluster links'
// visibility, a plain fraction of area-sampled rays, came out low (hr/solver.h).
// With cluster.separation 1.5 and power-sampled, kernel-weighted visibility
// it was -0.3 %. The unclustered powers (bfa, eps 1e-3; a 4 s solve) are
// stored here, re-measured after surface links' visibility became
// kernel-weighted (transport/formfactor.cpp), which brightened the
// unclustered solve by 1.4 %: against the old constants a clustered solve
// 1 % dark passed. Oriented: 506.09 / 410.09 / 290.47 (-0.3 %).
TEST(ClusterTransfer, OrientedKeepsTheLightOnOffice3) {
    scene::Scene s = scene::loadScene("office:3");
    transport::Visibility vis(s);
    Params p;
    p.set("cluster.model", "oriented");
    p.set("oracle.eps", 1e-3);
    HrSolver solver(s, vis, HrSettings::fromParams(p));
    HrResult r = solver.solve();
    EXPECT_TRUE(r.converged);
    RGB oriented = r.hierarchy->radiosityPower();
    const double none[3] = {507.663, 411.551, 291.521};  // cluster.model = none
    for (int c = 0; c < 3; ++c) {
        double rel = (oriented[c] - none[c]) / none[c];
        std::cout << "channel " << c << ": none " << none[c] << ", oriented " << oriented[c] << " ("
                  << 100 * rel << " %)\n";
        EXPECT_LT(std::fabs(rel), 0.01) << "channel " << c;
    }
}

// Links from clusters that carry no light are made without rays and
// computed in the first judging pass after the cluster carries light
// (cluster.defer_dark, cluster/link.h). After the solve no link that still
// waits may have a lit sender (it would carry nothing), and every link that
// waits holds no transfer. The rays are compared in the first judging pass,
// where both solves make the same links and the deferred one casts none for
// the links from dark clusters (office:3, this test's settings: 84,074 links,
// 1,546,112 rays against 2,085,568). The solves' totals are not compared:
// they refine differently once the deferred links are computed with the
// light of their senders, and differ by that alone (2,600,352 deferred
// against 2,600,912 eager, then 2,623,696 against 2,618,992 once a cluster's
// ray ends were drawn among its facing surfaces only).
TEST(ClusterTransfer, DeferredLinksAreComputedOnceTheirSenderIsLit) {
    scene::Scene s = scene::loadScene("office:3");
    transport::Visibility vis(s);
    auto run = [&](bool defer) {
        Params p;
        p.set("cluster.model", "oriented");
        p.set("oracle.eps", 1e-3);
        p.set("cluster.defer_dark", defer);
        // The published bfa: with the receiver check (the default) the two
        // solves refine differently once deferred links are computed, and
        // deferring saved nothing here (2,782,032 rays against 2,764,352).
        p.set("hr.receiver_eps", std::string("off"));
        // Near pairs always opened: with judged stand-ins (the default) the
        // deferred solve cast 0.05 % more rays than the eager one
        // (2,570,306 against 2,568,954), its refinement judged on other
        // estimates.
        p.set("cluster.near", std::string("open"));
        return HrSolver(s, vis, HrSettings::fromParams(p)).solve();
    };
    HrResult deferred = run(true);
    HrResult eager = run(false);
    EXPECT_TRUE(deferred.converged);
    const Hierarchy& h = *deferred.hierarchy;
    uint64_t waiting = 0, waitingLit = 0;
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        const Link& l = h.link(i);
        if (!(l.flags & Link::kDeferred)) continue;
        ++waiting;
        EXPECT_EQ(l.K, 0.f);
        if (maxComponent(h.maxB(l.sender)) > 0) ++waitingLit;
    }
    std::cout << "links still deferred: " << waiting << " (lit senders: " << waitingLit
              << "); computed later: " << deferred.deferredLinksComputed << "; rays "
              << deferred.totalRays << " deferred, " << eager.totalRays << " computed when made\n";
    EXPECT_EQ(waitingLit, 0u);
    EXPECT_GT(deferred.deferredLinksComputed, 1000u);
    EXPECT_EQ(eager.deferredLinksComputed, 0u);
    ASSERT_FALSE(deferred.history.empty());
    ASSERT_FALSE(eager.history.empty());
    EXPECT_EQ(deferred.history[0].links, eager.history[0].links);
    EXPECT_LT(deferred.history[0].rays, eager.history[0].rays);
}

namespace {
// RenderPark's classroom solved with oriented clusters and the settings
// `set` adds: the result and its reflected power (green). nullopt without
// ../shared/scenes.
struct ClassroomSolve {
    HrResult result;
    double reflected = 0.0;
};
std::optional<ClassroomSolve> solveClassroom(const std::function<void(Params&)>& set) {
    auto dir = test::sharedScenesDir();
    if (!dir) return std::nullopt;
    scene::Scene s = scene::loadScene((*dir / "renderpark-mgf/salon/classroom.mgf").string());
    transport::Visibility vis(s);
    Params p;
    p.set("cluster.model", "oriented");
    set(p);
    ClassroomSolve out{HrSolver(s, vis, HrSettings::fromParams(p)).solve()};
    EXPECT_TRUE(out.result.converged);
    out.reflected = out.result.hierarchy->radiosityPower().g - s.emittedPower().g;
    return out;
}
}  // namespace

// RenderPark's classroom lost 6.7 % of its reflected light (green) with
// oriented clustering against the unclustered solve (bfa, eps 1e-3; the
// unclustered reflected power, 1,147.75, is stored here: a 100 s solve,
// re-measured on 2026-11-28; 1,136.72 with the code of a few days before).
// Two causes were found and fixed: cluster links made in the first judging
// pass, when only the lamps carry light, drew their senders' ray end points
// over surfaces that stay dark as much as over lit ones (deferred links and
// the ambient term: 3.1 % left), and receiving clusters handed their light
// by cosine alone, as much to the surfaces hidden inside them as to those
// that see out, which differ in reflectance (the hand-over by openness,
// cluster/openness.h: 1.4 % left). The tolerance of 2 % fails either
// earlier state (papers/README.md, "Clustering accuracy").
TEST(ClusterTransfer, ClassroomKeepsMoreThan98PercentOfTheUnclusteredLight) {
    auto c = solveClassroom([](Params& p) { p.set("oracle.eps", 1e-3); });
    if (!c) GTEST_SKIP() << "../shared/scenes absent";
    const double reflected = c->reflected;
    const double none = 1147.75;  // cluster.model = none, reflected power, green
    std::cout << "reflected power (green): oriented " << reflected << ", none " << none << " ("
              << 100 * (reflected / none - 1) << " %)\n";
    EXPECT_GT(reflected, 0.98 * none);
    EXPECT_LT(reflected, 1.01 * none);
}

// ff with clusters. The checks the solver adds to the oracle's decisions
// (the light a stand-in or a partially visible cluster link may put on the
// wrong surfaces, a sampled link's error) hold a power to a fraction of the
// emitted power; they took ff's F_eps, a form factor, as that fraction, so
// at F_eps 0.1 each such link could misplace a tenth of the emitted power.
// Measured at F_eps 0.1, reflected power (green): unclustered 1114.8;
// oriented 1026.9 (-7.9 %, 17 % of the light through stand-ins) with
// F_eps, 1080.2 (-3.1 %, 0.5 %) with F_eps / 100, ff's receiver check's
// mapping (oracles/oracle.h receiverCheckEps; papers/README.md, "ff's
// clustered solves were dark"). The remaining loss is not traced (without
// ff's receiver check the clustered solve is brighter than the unclustered).
TEST(ClusterTransfer, FfHoldsWhatClusterLinksMisplaceToItsPowerEps) {
    auto c = solveClassroom([](Params& p) {
        p.set("hr.oracle", "ff");
        p.set("oracle.eps", 0.1);
    });
    if (!c) GTEST_SKIP() << "../shared/scenes absent";
    const HrResult& r = c->result;
    const double reflected = c->reflected;
    const double none = 1114.80;  // cluster.model = none, ff 0.1, reflected power, green
    std::cout << "ff 0.1, reflected power (green): oriented " << reflected << ", none " << none
              << " (" << 100 * (reflected / none - 1) << " %), stand-in share "
              << r.standInPowerShare << "\n";
    EXPECT_GT(reflected, 0.95 * none);
    EXPECT_LT(reflected, 1.01 * none);
    EXPECT_LT(r.standInPowerShare, 0.02);
}

// No leaks: light does not reach surfaces that no path from an emitter
// reaches. A lit room holds (a) a box whose outside is lit and whose inside
// is a second, closed cavity (inward faces: a box inside a box), (b) a slab
// 1 cm thick whose inside is a closed cavity, and (c) a face stacked 1 mm
// behind a wall (facing into the wall's back, the room's outside). Every
// cavity face must stay exactly at its emission (0), with and without
// clusters and for every adaptive oracle. The bottoms of the box and the
// slab lie on the floor, facing into it: nothing reaches them either.
class NoLeaks : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(NoLeaks, ClosedCavitiesStayDark) {
    auto [model, oracle] = GetParam();
    scene::Scene s;
    uint32_t wall = s.addMaterial({"wall", RGB(0.7), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.5), RGB(10.0)});
    uint32_t cavity = s.addMaterial({"cavity", RGB(0.7), RGB(0.0)});
    Vec3 lo(0), hi(4, 3, 2.5);
    test::addBox(s, lo, hi, {wall, wall, wall, wall, wall, wall}, true);
    test::addQuadFacing(s, Vec3(1.5, 1, 2.49), Vec3(2.5, 1, 2.49), Vec3(2.5, 2, 2.49),
                        Vec3(1.5, 2, 2.49), light, Vec3(2, 1.5, 0));
    // (a) a lit box, and inside it a cavity box with inward faces.
    test::addBox(s, Vec3(0.5, 0.5, 0), Vec3(1.5, 1.5, 1), {wall, wall, wall, wall, wall, wall},
                 false);
    // addBox: the face at z = lo.z is the fifth.
    const uint32_t boxBottom = uint32_t(s.patches.size()) - 2;
    test::addBox(s, Vec3(0.6, 0.6, 0.1), Vec3(1.4, 1.4, 0.9),
                 {cavity, cavity, cavity, cavity, cavity, cavity}, true);
    // (b) a slab 1 cm thick standing in the room, lit on both sides, with a
    // closed cavity inside.
    test::addBox(s, Vec3(2.5, 0.5, 0), Vec3(3.5, 0.51, 1.5), {wall, wall, wall, wall, wall, wall},
                 false);
    const uint32_t slabBottom = uint32_t(s.patches.size()) - 2;
    test::addBox(s, Vec3(2.6, 0.502, 0.1), Vec3(3.4, 0.508, 1.4),
                 {cavity, cavity, cavity, cavity, cavity, cavity}, true);
    // (c) a face 1 mm outside the wall x = 4, facing away from the room.
    test::addQuadFacing(s, Vec3(4.001, 1, 0.5), Vec3(4.001, 2, 0.5), Vec3(4.001, 2, 1.5),
                        Vec3(4.001, 1, 1.5), cavity, Vec3(5, 1.5, 1));
    transport::Visibility vis(s);
    HrSolver solver(s, vis, clustered(model, oracle, 1e-3));
    HrResult r = solver.solve();
    const Hierarchy& h = *r.hierarchy;
    double lit = 0.0, leaked = 0.0;
    for (uint32_t e = 0; e < h.numElements(); ++e) {
        if (!h.isLeaf(e)) continue;
        const auto& P = s.patches[h.patch(e)];
        double p = h.area(e) * maxComponent(h.B(e) - P.emission);
        const bool dark =
            P.material == cavity || h.patch(e) == boxBottom || h.patch(e) == slabBottom;
        (dark ? leaked : lit) += p;
    }
    std::cout << model << " " << oracle << ": reflected power " << lit << ", in cavities " << leaked
              << "\n";
    EXPECT_GT(lit, 0.0);
    // The 13 cavity faces (6 + 6 inward faces, one face behind the wall) and
    // the two bottoms on the floor see nothing lit: the reachability pass
    // (hr.reach_rays, transport/reachability.h) leaves them out of the
    // transport, so no cluster link spreads light over them. Before it,
    // clustered bfa put 0.12 % of the reflected power in the cavities.
    EXPECT_EQ(r.unreachablePatches, 15u);
    EXPECT_EQ(leaked, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Oracles, NoLeaks,
                         ::testing::Combine(::testing::Values("none", "oriented"),
                                            ::testing::Values("bfa", "error", "kv")));

// Links into an oriented cluster from a surface element of another root
// patch: push-pull read that element's B while another thread rewrote it, so
// office:2 gave a different solution for 1 and 2 threads (residual 1.5e-5
// against 1.0e-5 from run to run). The cluster contributions are now taken
// from the B of before the push.
TEST(ClusterTransfer, BitwiseIdenticalForOneAndTwoThreads) {
    scene::Scene s = scene::loadScene("office:2");
    transport::Visibility vis(s);
    HrSettings settings = clustered("oriented", "bfa", 1e-3);
    auto run = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
        HrSolver solver(s, vis, settings);
        return solver.solve();
    };
    HrResult a = run(1), b = run(2), c = run(2);
    for (const HrResult* other : {&b, &c}) ASSERT_TRUE(sameSolution(a, *other));
}

// hr.seed: 0 is the fixed seeding (bit for bit what a solve without the
// setting gives), any other seed repeats itself and draws other rays (surface
// visibility, cluster links, the hand-over's openness), so its solution
// differs, by the solver's own noise only.
TEST(ClusterTransfer, SeedZeroIsTheFixedSeedingOtherSeedsDrawAnew) {
    scene::Scene s = scene::loadScene("office:2");
    transport::Visibility vis(s);
    auto run = [&](int64_t seed) {
        Params p;
        p.set("hr.oracle", std::string("bfa"));
        p.set("oracle.eps", 1e-3);
        p.set("cluster.model", std::string("oriented"));
        if (seed >= 0) p.set("hr.seed", seed);
        HrSettings hs = HrSettings::fromParams(p);
        EXPECT_EQ(hs.seed, uint64_t(std::max<int64_t>(seed, 0)));
        HrSolver solver(s, vis, hs);
        return solver.solve();
    };
    HrResult unset = run(-1), zero = run(0), one = run(1), oneAgain = run(1), two = run(2);
    EXPECT_TRUE(sameSolution(unset, zero));
    EXPECT_TRUE(sameSolution(one, oneAgain));
    EXPECT_FALSE(sameSolution(zero, one));
    EXPECT_FALSE(sameSolution(one, two));
    const double e = s.emittedPower().g;
    const double r0 = zero.hierarchy->radiosityPower().g - e;
    for (const HrResult* other : {&one, &two}) {
        const double r = other->hierarchy->radiosityPower().g - e;
        EXPECT_NE(r, r0);
        EXPECT_NEAR(r / r0, 1.0, 0.01);
    }
}

// Where refinement spends (HrResult::linkCost): every link evaluation is
// counted once under its kind, and its rays add up to the solve's rays (the
// constant basis casts no other rays); without clusters every evaluation is
// between surfaces.
TEST(LinkCost, AccountsForEveryEvaluationByKind) {
    scene::Scene s = scene::loadScene("office:1");
    transport::Visibility vis(s);
    for (const char* model : {"oriented", "none"}) {
        HrSettings st = test::hrSettings("bfa", 1e-3);
        st.clusterModel = cluster::parseClusterModel(model);
        HrResult r = HrSolver(s, vis, st).solve();
        const auto& c = r.linkCost;
        uint64_t ev = 0, rays = 0;
        for (int k = 0; k < 4; ++k) {
            ev += c.evaluations[k];
            rays += c.rays[k];
            EXPECT_GE(c.seconds[k], 0.0);
            if (c.evaluations[k] == 0) {
                EXPECT_EQ(c.seconds[k], 0.0) << model << " kind " << k;
            }
        }
        // The judged stand-ins' estimates of near pairs are counted apart.
        EXPECT_EQ(rays + r.nearStandInRays, r.totalRays) << model;
        EXPECT_LE(ev, r.totalFormFactors) << model;  // self-links are skipped, not evaluated
        EXPECT_GE(ev, r.totalFormFactors * 9 / 10) << model;
        if (std::string(model) == "none") {
            EXPECT_EQ(ev, c.evaluations[0]);
        } else {
            for (int k = 0; k < 4; ++k) EXPECT_GT(c.evaluations[k], 0u) << "kind " << k;
        }
    }
}

// The receiver aggregate's kernel samples are kept only for links between two
// surface elements whose receiver can subdivide, in link order
// (Hierarchy::storesKernelSamples): after a clustered solve, one entry per
// such link, each equal to the samples of its own pair computed afresh (a
// misaligned entry belongs to another pair). The error estimate computes the
// samples it lacks: it is the same with the stored samples as with none.
TEST(KernelSampleCache, HeldForSubdividableSurfaceLinksOnlyAndInTheirOrder) {
    scene::Scene s = scene::loadScene("office:1");
    transport::Visibility vis(s);
    HrSettings settings = clustered("oriented", "bfa", 1e-3);
    // A smallest area that stops some receivers (the furniture's faces).
    settings.minAreaRel = 2e-4;
    HrSolver solver(s, vis, settings);
    HrResult res = solver.solve();
    Hierarchy& h = *res.hierarchy;
    ASSERT_TRUE(h.hasKernelSamples());
    transport::FormFactorEngine engine(s, &vis, settings.ff);
    const std::vector<KernelSamples>& samples = h.kernelSamples();
    uint64_t storing = 0, unstored = 0, other = 0, compared = 0;
    for (uint32_t r = 0; r < h.numElements(); ++r)
        for (uint64_t i = h.linkBegin(r); i < h.linkEnd(r); ++i) {
            const Link& l = h.link(i);
            if (!h.carriesKernelSamples(r, l)) {
                ++other;
                continue;
            }
            EXPECT_EQ(h.storesKernelSamples(r, l), h.canSubdivide(r));
            if (!h.storesKernelSamples(r, l)) {
                ++unstored;
                continue;
            }
            ASSERT_LT(storing, samples.size());
            const KernelSamples& got = samples[storing++];
            // Links kept without light (K = 0) were given no samples.
            if (!(l.K > 0)) continue;
            const KernelSamples want = linkKernelSamples(h, engine, r, l.sender);
            for (size_t k = 0; k < want.size(); ++k)
                ASSERT_EQ(got[k], want[k]) << "receiver " << r << " link " << i << " sample " << k;
            ++compared;
        }
    EXPECT_EQ(storing, samples.size());
    // Every kind occurs, so the layout is exercised.
    EXPECT_GT(other, 1000u);
    EXPECT_GT(compared, 1000u);
    EXPECT_GT(unstored, 1000u);
    std::cout << "[ stats    ] " << storing << " links with samples (" << compared << " compared), "
              << unstored << " surface links without, " << other << " other links\n";
    const double stored = solver.estimateError(h);
    EXPECT_DOUBLE_EQ(stored, res.errorEstimate);
    h.takeKernelSamples();
    ASSERT_FALSE(h.hasKernelSamples());
    EXPECT_DOUBLE_EQ(solver.estimateError(h), stored);
}
