// Per-link audit of cluster links (the house habit, papers/README.md
// "Clustering accuracy"): every final link that touches a cluster, on a
// solved office scene, against a Monte Carlo integral of the power it
// really carries, sum over point pairs of B_s(y) cos cos V / (pi d^2), with
// the solved root-patch radiosities as B_s. Links are grouped by whether an
// end is a planar face cluster (cluster.faces) or not; the sums and the
// worst links are printed (bench/results/face_clusters.md). Not a fast test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "hr/solver.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
#include "tests/link_audit.h"
#include "transport/visibility.h"

using namespace hrad;

namespace {

struct Audit {
    double model = 0, mc = 0, absDiff = 0;
    uint64_t links = 0;
};

void auditScene(const std::string& name, bool faces, double& faceRatio, double& volumeRatio) {
    scene::Scene s = scene::loadScene(name);
    transport::Visibility vis(s);
    hr::HrSettings hs = test::hrSettings("bfa", 1e-3, "oriented");
    hs.cluster.faces = faces;
    hr::HrSolver solver(s, vis, hs);
    hr::HrResult res = solver.solve();
    const hr::Hierarchy& h = *res.hierarchy;
    const cluster::ClusterTree& t = *res.clusterTree;
    std::vector<uint32_t> recv = h.linkReceivers();
    Audit groups[2];
    struct Worst {
        double diff, model, mc, sepRatio;
        bool rc, sc;
    };
    std::vector<Worst> worst;
    constexpr int kPairs = 256;
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        const hr::Link& l = h.link(i);
        uint32_t r = recv[i], sd = l.sender;
        bool rc = h.isCluster(r), sc = h.isCluster(sd);
        if (!rc && !sc) continue;
        if (!(l.K > 0)) continue;
        bool face =
            (rc && t.planarFace(h.clusterIndex(r))) || (sc && t.planarFace(h.clusterIndex(sd)));
        const double dist = glm::length(h.center(r) - h.center(sd));
        const test::LinkPower p = test::auditLink(s, vis, res, recv, i, kPairs);
        const double model = p.model, mc = p.mc;
        Audit& g = groups[face ? 0 : 1];
        g.model += model;
        g.mc += mc;
        g.absDiff += std::fabs(model - mc);
        ++g.links;
        if (face)
            worst.push_back({model - mc, model, mc, dist / (h.radius(r) + h.radius(sd)), rc, sc});
    }
    std::sort(worst.begin(), worst.end(),
              [](const Worst& a, const Worst& b) { return std::fabs(a.diff) > std::fabs(b.diff); });
    const char* names[2] = {"face-cluster links", "other cluster links"};
    for (int g = 0; g < 2; ++g) {
        std::cout << name << (faces ? " faces" : " volume") << ", " << names[g] << ": "
                  << groups[g].links << " links, model " << groups[g].model << ", Monte Carlo "
                  << groups[g].mc << ", ratio " << groups[g].model / groups[g].mc << ", sum |diff| "
                  << groups[g].absDiff << "\n";
    }
    // Signed difference by distance class (centroid distance over the sum of radii).
    const double edges[] = {1.0, 1.5, 2.0, 3.0, 1e300};
    for (int c = 0; c < 4; ++c) {
        double m = 0, q = 0;
        int n = 0;
        for (const Worst& x : worst)
            if (x.sepRatio >= edges[c] && x.sepRatio < edges[c + 1]) m += x.model, q += x.mc, ++n;
        if (n)
            std::cout << "  face links at distance/(r_r+r_s) in [" << edges[c] << ", "
                      << edges[c + 1] << "): " << n << " links, model " << m << ", Monte Carlo "
                      << q << "\n";
    }
    for (size_t j = 0; j < std::min<size_t>(5, worst.size()); ++j)
        std::cout << "  worst face link: model " << worst[j].model << ", Monte Carlo "
                  << worst[j].mc << ", distance/(r_r+r_s) " << worst[j].sepRatio << ", receiver "
                  << (worst[j].rc ? "cluster" : "surface") << ", sender "
                  << (worst[j].sc ? "cluster" : "surface") << "\n";
    faceRatio = groups[0].mc > 0 ? groups[0].model / groups[0].mc : 1.0;
    volumeRatio = groups[1].mc > 0 ? groups[1].model / groups[1].mc : 1.0;
}

}  // namespace

TEST(FaceLinkAudit, FaceLinksCarryTheirMonteCarloPower) {
    double f = 1, v = 1, f0 = 1, v0 = 1;
    auditScene("office:4", false, f0, v0);
    auditScene("office:4", true, f, v);
    // Summed over all face-cluster links, the model's power within 5 % of
    // Monte Carlo (256 pairs per link; the volume links' ratio is printed
    // for comparison).
    EXPECT_NEAR(f, 1.0, 0.05);
}
