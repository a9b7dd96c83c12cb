// hrad_link_audit SCENE [KEY=VALUE ...]: where does a solve lose light?
//
// Solves SCENE with the given settings (the hr solver's keys, as with
// `hrad solve --set`), then compares, per kind of final link, the power the
// links move (the model) with a Monte Carlo integral of what they really
// carry (tests/link_audit.h: area-uniform point pairs of the two ends,
// cos cos V / (pi d^2), the solved root-patch radiosities as the sender's B).
// Links are audited with probability p_i = min(1, c P_i / P + floor), P_i the
// link's model power, and the totals are Horvitz-Thompson estimates
// (sum over audited links of x_i / p_i), so links that move nothing but
// really carry light (visibility judged 0, sampled links that found nothing)
// are counted too. The ratio model / Monte Carlo below 1 is light the kind
// loses. Green channel, as the audits in tests/ (papers/README.md
// "Clustering accuracy").
#include "tests/link_audit.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "core/error.h"
#include "core/params.h"
#include "hr/solver.h"
#include "scene/loader.h"
#include "transport/visibility.h"

using namespace hrad;

namespace {

enum Kind {
    kFromEmitter,
    kSurfaceFull,
    kSurfacePartial,
    kSurfaceBlocked,
    kClusterToSurface,
    kSurfaceToCluster,
    kClusterToCluster,
    kSampledNothing,
    kStandIn,
    kKinds
};
const char* kKindNames[kKinds] = {
    "surface, from an emitter", "surface, visible",       "surface, partly visible",
    "surface, judged blocked",  "cluster -> surface",     "surface -> cluster",
    "cluster -> cluster",       "sampled, found nothing", "stand-in"};

struct Total {
    double model = 0, modelAudited = 0, mc = 0, var = 0, mcOpen = 0;
    uint64_t links = 0, audited = 0;
};

Kind kindOf(const scene::Scene& s, const hr::Hierarchy& h, const hr::Link& l, uint32_t r) {
    if (l.flags & hr::Link::kStandIn) return kStandIn;
    const bool rc = h.isCluster(r), sc = h.isCluster(l.sender);
    if ((rc || sc) && (l.flags & hr::Link::kSampled) && !(l.K > 0)) return kSampledNothing;
    if (rc && sc) return kClusterToCluster;
    if (rc) return kSurfaceToCluster;
    if (sc) return kClusterToSurface;
    if (s.patches[h.patch(l.sender)].isEmitter()) return kFromEmitter;
    if (!(l.K > 0)) return kSurfaceBlocked;
    if (l.flags & hr::Link::kPartial) return kSurfacePartial;
    return kSurfaceFull;
}

Params parseArgs(int argc, char** argv) {
    Params p;
    for (int i = 2; i < argc; ++i) {
        std::string a = argv[i];
        auto eq = a.find('=');
        if (eq == std::string::npos) throw InputError({}, "expected KEY=VALUE, got '" + a + "'");
        p.setFromText(a.substr(0, eq), a.substr(eq + 1), {"command line", 0, 0});
    }
    return p;
}

}  // namespace

int main(int argc, char** argv) try {
    if (argc < 2) {
        std::fprintf(stderr,
                     "usage: hrad_link_audit SCENE [KEY=VALUE ...] (audit.pairs, audit.links)\n");
        return 2;
    }
    Params p = parseArgs(argc, argv);
    const int pairs =
        int(p.getInt({"audit.pairs", "point pairs per audited link"}, 64, 2, 1 << 20));
    const double want =
        p.getDouble({"audit.links", "links audited (expected count)"}, 20000, 1, 1e9);
    scene::Scene s = scene::loadScene(argv[1], p);
    transport::Visibility vis(s);
    hr::HrSolver solver(s, vis, hr::HrSettings::fromParams(p));
    hr::HrResult res = solver.solve();
    const hr::Hierarchy& h = *res.hierarchy;
    const std::vector<uint32_t> recv = h.linkReceivers();
    // The model power of every link, then the audit probabilities.
    std::vector<double> power(h.numLinks());
    double total = 0;
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        test::LinkPower m = test::auditLink(s, vis, res, recv, i, 0);
        power[i] = std::max(0.0, m.model);
        total += power[i];
    }
    const double floorP = 0.25 * want / double(std::max<uint64_t>(1, h.numLinks()));
    const double c = 0.75 * want;
    Total t[kKinds];
    Pcg32 pick(12345);
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        const Kind k = kindOf(s, h, h.link(i), recv[i]);
        Total& g = t[k];
        g.model += power[i];
        ++g.links;
        const double pi = std::min(1.0, c * power[i] / std::max(total, 1e-300) + floorP);
        if (pick.nextDouble() >= pi) continue;
        test::LinkPower a = test::auditLink(s, vis, res, recv, i, pairs);
        g.modelAudited += a.model / pi;
        g.mc += a.mc / pi;
        g.mcOpen += a.mcOpen / pi;
        g.var += a.mcVar / (pi * pi) + (pi < 1 ? (1 - pi) * a.mc * a.mc / (pi * pi) : 0.0);
        ++g.audited;
    }
    fmt::print("{}: {} links, model power {:.6g} (green)\n", argv[1], h.numLinks(), total);
    fmt::print("{:<26} {:>10} {:>8} {:>12} {:>12} {:>12} {:>8} {:>8} {:>12}\n", "kind", "links",
               "audited", "model", "model (HT)", "MC (HT)", "ratio", "+-", "MC, V = 1");
    for (int k = 0; k < kKinds; ++k) {
        const Total& g = t[k];
        const double ratio = g.mc > 0 ? g.model / g.mc : 1.0;
        const double se = g.mc > 0 ? ratio * std::sqrt(g.var) / g.mc : 0.0;
        fmt::print(
            "{:<26} {:>10} {:>8} {:>12.5g} {:>12.5g} {:>12.5g} {:>8.4f} {:>8.4f} {:>12.5g}\n",
            kKindNames[k], g.links, g.audited, g.model, g.modelAudited, g.mc, ratio, se, g.mcOpen);
    }
    return 0;
} catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
}
