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

#include "core/rng.h"
#include "hr/solver.h"
#include "scene/element.h"
#include "scene/loader.h"
#include "tests/hr/settings.h"
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
    const uint32_t k = h.numPatches();
    auto point = [&](uint32_t e, Pcg32& rng, uint32_t& patch) {
        double a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
        if (h.isCluster(e)) return t.samplePoint(h.clusterIndex(e), a, b, c, patch);
        patch = h.patch(e);
        const auto& P = s.patches[patch];
        if (P.kind == scene::PatchKind::Triangle && a + b > 1) a = 1 - a, b = 1 - b;
        return scene::elementPoint(P, h.domain(e), a, b);
    };
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
        Vec3 u = h.center(r) - h.center(sd);
        double dist = glm::length(u);
        u /= dist;
        // What the model moves: an oriented receiving cluster's surfaces get
        // K cos_k+(u) w_k each (w_k their openness towards the sender,
        // cluster/openness.h, for links handed over by openness; 1 by cosine
        // alone), from the sender's radiosity towards them (the exact sum over
        // its patches, as the push hands it; the cluster's projectedArea is a
        // Cauchy-Schwarz bound above it).
        double recvArea = h.area(r);
        if (rc) {
            const auto& nd = t.node(h.clusterIndex(r));
            const bool byOpenness = res.openness && (l.flags & hr::Link::kOpenHandOver);
            recvArea = 0;
            for (uint32_t q = nd.patchBegin; q < nd.patchEnd; ++q) {
                const uint32_t p = t.patchAt(q);
                const auto& P = s.patches[p];
                double cosine = std::max(0.0, glm::dot(P.normal, -u));
                double w = 1.0;
                if (byOpenness) {
                    auto v = res.openness->view(p);
                    w = res.openness->openness(v, res.openness->inside(v, nd.centroid, nd.radius),
                                               -u, cosine);
                }
                recvArea += P.area * cosine * w;
            }
        }
        double Bs = sc ? h.directionalB(sd, u).g : h.B(sd).g;
        double model = l.K * recvArea * Bs;
        Pcg32 rng(hashIds(i, 77));
        transport::Segment seg[kPairs];
        double w[kPairs];
        for (int j = 0; j < kPairs; ++j) {
            seg[j].a = point(r, rng, seg[j].patchA);
            seg[j].b = point(sd, rng, seg[j].patchB);
            Vec3 d = seg[j].b - seg[j].a;
            double d2 = glm::dot(d, d);
            double ca = glm::dot(s.patches[seg[j].patchA].normal, d);
            double cb = -glm::dot(s.patches[seg[j].patchB].normal, d);
            w[j] = ca > 0 && cb > 0 && d2 > 0 ? ca * cb / (kPi * d2 * d2) : 0.0;
            // The sender's solved radiosity at that point (its root patch).
            w[j] *= h.B(seg[j].patchB < k ? seg[j].patchB : 0).g;
        }
        uint8_t occ[kPairs];
        vis.occluded(seg, kPairs, occ);
        double sum = 0;
        for (int j = 0; j < kPairs; ++j)
            if (!occ[j]) sum += w[j];
        double mc = h.area(r) * h.area(sd) * sum / kPairs;
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
