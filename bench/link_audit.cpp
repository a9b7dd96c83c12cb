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
// "Clustering accuracy"); links into surfaces of rho 0 are left out (their
// light changes no radiosity). Also printed: what the receivers hold,
// sum A (B - E) / rho, against the links' total (light lost between a link
// and a radiosity), and with audit.coverage=N the share of N gathered rays'
// radiosity that no link carries (coverage() below). Findings:
// papers/notes/2026-12-02-modern-hall-light.md, section 10.
#include "tests/link_audit.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <unordered_set>
#include <vector>
#include <string>

#include "core/error.h"
#include "core/params.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "hr/solver.h"
#include "scene/element.h"
#include "scene/loader.h"
#include "transport/formfactor.h"
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

/// Light that no link carries: `samples` receiver points drawn by area
/// over the patches that reflect, one cosine-distributed ray each; the hit's
/// radiosity is light the receiver should gather, and it is covered when
/// some link joins an ancestor-or-self of the receiver's leaf with an
/// ancestor-or-self of the hit's leaf (elements, then clusters). Prints the
/// uncovered share of the gathered radiosity (green) and its standard error.
/// A pair whose link was estimated to carry nothing (all its rays blocked)
/// is uncovered too: that is an estimate of 0, not necessarily lost light.
void coverage(const scene::Scene& s, const transport::Visibility& vis, const hr::Hierarchy& h,
              const std::vector<uint32_t>& recv, uint64_t samples) {
    std::unordered_set<uint64_t> linked;
    linked.reserve(size_t(h.numLinks()) * 2);
    for (uint64_t i = 0; i < h.numLinks(); ++i)
        linked.insert(uint64_t(recv[i]) << 32 | h.link(i).sender);
    std::vector<double> cdf;
    double area = 0.0;
    for (const auto& P : s.patches) cdf.push_back(area += P.rho.g > 0 ? P.area : 0.0);
    auto leafAt = [&](uint32_t p, Vec2 uv) {
        uint32_t e = p;
        while (h.firstChild(e) != hr::kNone)
            e = h.child(e, uint32_t(scene::childContaining(s.patches[p].kind, h.domain(e), uv.x, uv.y)));
        return e;
    };
    auto chain = [&](uint32_t e, std::vector<uint32_t>& out) {
        out.clear();
        for (; e != hr::kNone; e = h.parent(e)) out.push_back(e);
    };
    Pcg32 rng(777);
    std::vector<uint32_t> cx, cy;
    double all = 0.0, lost = 0.0, lost2 = 0.0;
    uint64_t lostRays = 0;
    double inPlane = 0.0;
    for (uint64_t n = 0; n < samples; ++n) {
        const double u = rng.nextDouble() * area;
        const uint32_t p = uint32_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
        const scene::Patch& P = s.patches[std::min<size_t>(p, s.patches.size() - 1)];
        const Vec3 x = scene::elementSamplePoint(P, scene::Domain{}, rng.nextDouble(), rng.nextDouble());
        const Vec3 dir = cosineDirection(P.normal, rng.nextDouble(), rng.nextDouble());
        const transport::RayHit hit = vis.intersect(x, dir, 0.0, 1e300, p);
        if (!hit.hit || glm::dot(s.patches[hit.patch].normal, dir) >= 0) continue;
        const scene::Patch& Q = s.patches[hit.patch];
        const uint32_t ly = leafAt(hit.patch, scene::clampToPatchDomain(Q.kind, scene::patchInverse(Q, hit.point)));
        const double b = h.B(ly).g;
        all += b;
        chain(leafAt(p, scene::clampToPatchDomain(P.kind, scene::patchInverse(P, x))), cx);
        chain(ly, cy);
        const bool covered = std::any_of(cx.begin(), cx.end(), [&](uint32_t r) {
            return std::any_of(cy.begin(), cy.end(),
                               [&](uint32_t q) { return linked.count(uint64_t(r) << 32 | q) > 0; });
        });
        if (!covered) lost += b, lost2 += b * b, ++lostRays;
        // A hit on a face in the receiver's own plane (at t ~ 0: a face
        // stacked back to back with it) is light no physical path carries.
        if (std::abs(glm::dot(Q.normal, x - Q.v[0])) < 1e-6 && std::abs(glm::dot(P.normal, Q.normal)) > 0.999)
            inPlane += b;
    }
    const double share = all > 0 ? lost / all : 0.0;
    const double se = all > 0 ? std::sqrt(std::max(0.0, lost2 - lost * lost / double(samples))) / all : 0.0;
    fmt::print("light no link carries: {:.4f} +- {:.4f} of the gathered radiosity ({} of {} rays); "
               "hits in the receiver's own plane: {:.4f}\n",
               share, se, lostRays, samples, all > 0 ? inPlane / all : 0.0);
}


/// The links that light root patch `patch` (audit.patch): every final link
/// whose receiver is one of its elements or a cluster above it, with its
/// kind, sender, model power and Monte Carlo power (`pairs` point pairs),
/// and a gathered estimate of the patch's irradiance from each emitter
/// (cosine rays from area-uniform points, counting E at emitting hits),
/// against what the links from emitters deliver.
void patchReport(const scene::Scene& s, const transport::Visibility& vis, const hr::HrResult& res,
                 const std::vector<uint32_t>& recv, uint32_t patch, int pairs) {
    const hr::Hierarchy& h = *res.hierarchy;
    const scene::Patch& P = s.patches[patch];
    std::unordered_set<uint32_t> mine;  // the patch's elements and the clusters above it
    std::vector<uint32_t> stack{patch};
    while (!stack.empty()) {
        const uint32_t e = stack.back();
        stack.pop_back();
        mine.insert(e);
        for (uint32_t c = 0; c < h.numChildren(e); ++c) stack.push_back(h.child(e, c));
    }
    for (uint32_t e = h.parent(patch); e != hr::kNone; e = h.parent(e)) mine.insert(e);
    fmt::print("patch {}: area {:.4g}, B (green) {:.5g}, rho {:.3g}\n", patch, P.area, h.B(patch).g,
               P.rho.g);
    for (uint32_t e = h.parent(patch); e != hr::kNone; e = h.parent(e)) {
        const Vec3 c = h.center(e);
        fmt::print("  above: cluster {} (area {:.4g}, centre {:.3f} {:.3f} {:.3f}, radius {:.3f})\n",
                   h.clusterIndex(e), h.area(e), c.x, c.y, c.z, h.radius(e));
    }
    double fromEmitters = 0.0;
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        if (!mine.count(recv[i])) continue;
        const hr::Link& l = h.link(i);
        const test::LinkPower a = test::auditLink(s, vis, res, recv, i, pairs);
        const bool rc = h.isCluster(recv[i]), sc = h.isCluster(l.sender);
        const uint32_t sp = sc ? 0 : h.patch(l.sender);
        if (!rc && !sc && s.patches[sp].isEmitter()) fromEmitters += a.model;
        fmt::print("  link {}: {} {} (area {:.4g}) <- {} {} (area {:.4g}), K {:.4g}, flags {}, "
                   "model {:.5g}, MC {:.5g} +- {:.2g}\n",
                   i, rc ? "cluster" : "element", rc ? h.clusterIndex(recv[i]) : recv[i],
                   h.area(recv[i]), sc ? "cluster" : (s.patches[sp].isEmitter() ? "emitter" : "element"),
                   sc ? h.clusterIndex(l.sender) : sp, h.area(l.sender), double(l.K), int(l.flags),
                   a.model, a.mc, std::sqrt(a.mcVar));
    }
    // Irradiance power from emitters, gathered.
    Pcg32 rng(4242);
    const int n = 1 << 16;
    double sum = 0.0, sum2 = 0.0;
    for (int j = 0; j < n; ++j) {
        const Vec3 x = scene::elementSamplePoint(P, scene::Domain{}, rng.nextDouble(), rng.nextDouble());
        const Vec3 dir = cosineDirection(P.normal, rng.nextDouble(), rng.nextDouble());
        const transport::RayHit hit = vis.intersect(x, dir, 0.0, 1e300, patch);
        double e = 0.0;
        if (hit.hit && glm::dot(s.patches[hit.patch].normal, dir) < 0) e = s.patches[hit.patch].emission.g;
        sum += e, sum2 += e * e;
    }
    const double mean = sum / n;
    fmt::print("  from emitters: surface links {:.5g}; gathered {:.5g} +- {:.2g} (A E[E(hit)])\n",
               fromEmitters, P.area * mean,
               P.area * std::sqrt(std::max(0.0, sum2 / n - mean * mean) / (n - 1)));
}

/// One audited link, for audit.worst.
struct Audited {
    uint64_t link;
    Kind kind;
    test::LinkPower power;
};

/// The `count` audited links that lose the most light (Monte Carlo - model).
void printWorst(const hr::Hierarchy& h, const std::vector<uint32_t>& recv,
                std::vector<Audited>& worst, size_t count) {
    const size_t nw = std::min<size_t>(count, worst.size());
    std::partial_sort(worst.begin(), worst.begin() + nw, worst.end(), [](const Audited& a, const Audited& b) {
        return a.power.mc - a.power.model > b.power.mc - b.power.model;
    });
    for (size_t j = 0; j < nw; ++j) {
        const Audited& w = worst[j];
        const hr::Link& l = h.link(w.link);
        const uint32_t r = recv[w.link];
        auto name = [&](uint32_t e) {
            return h.isCluster(e) ? fmt::format("cluster {} ({:.3g} m^2, r {:.3g})", h.clusterIndex(e), h.area(e), h.radius(e))
                                  : fmt::format("patch {} ({:.3g} m^2)", h.patch(e), h.area(e));
        };
        const Vec3 d = h.center(l.sender) - h.center(r);
        fmt::print("  lost {:.4g}: {} {} <- {}, distance {:.3g}, K {:.4g}, flags {}, model {:.4g}, MC {:.4g} +- {:.2g}, MC with V = 1 {:.4g}\n",
                   w.power.mc - w.power.model, kKindNames[w.kind], name(r), name(l.sender), glm::length(d),
                   double(l.K), int(l.flags), w.power.model, w.power.mc, std::sqrt(w.power.mcVar), w.power.mcOpen);
    }
}

/// Root patches `patch` <- `sender` as one surface link (audit.sender): its
/// form factor, visibility with 16 and 4,096 rays, and which patches block
/// area-uniform segments whose ends face each other.
void pairReport(const scene::Scene& s, const transport::Visibility& vis,
                const transport::FormFactorSettings& ff, uint32_t patch, uint32_t sender) {
    // The two root patches as one surface link (the hr solver's form factor settings).
    const transport::FormFactorEngine engine(s, &vis, ff);
    const transport::ElementRef er{patch, scene::Domain{}, 1}, es{sender, scene::Domain{}, 2};
    const transport::FormFactorResult f = engine.compute(er, es);
    fmt::print("root {} <- root {}: facing {}, F {:.5g}, unoccluded {:.5g}, visibility {:.4g} ({} rays), "
               "visibility with 4096 rays {:.4g}\n",
               patch, sender, engine.facing(er, es), f.F, f.unoccludedF, f.visibility, f.rays,
               engine.visibilityFraction(er, es, 4096));
    // Which patches block area-uniform segments whose ends face each other.
    std::map<uint32_t, int> blockers;
    Pcg32 rng(99);
    int tried = 0, blocked = 0;
    const scene::Patch& R = s.patches[patch];
    const scene::Patch& S = s.patches[sender];
    for (int j = 0; j < 20000 && tried < 4000; ++j) {
        transport::Segment seg;
        seg.a = scene::elementSamplePoint(R, scene::Domain{}, rng.nextDouble(), rng.nextDouble());
        seg.b = scene::elementSamplePoint(S, scene::Domain{}, rng.nextDouble(), rng.nextDouble());
        seg.patchA = patch;
        seg.patchB = sender;
        const Vec3 d = seg.b - seg.a;
        if (!(glm::dot(R.normal, d) > 0 && -glm::dot(S.normal, d) > 0)) continue;
        ++tried;
        uint8_t occ = 0;
        vis.occluded(&seg, 1, &occ);
        if (!occ) continue;
        ++blocked;
        const transport::RayHit hit = vis.intersect(seg.a, d, 0.0, 1.0, patch);
        ++blockers[hit.hit ? hit.patch : UINT32_MAX];
    }
    fmt::print("  {} facing segments, {} blocked; blockers:", tried, blocked);
    for (const auto& [q, n] : blockers) fmt::print(" {}x{}", q, n);
    fmt::print("\n");
}

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
    const uint64_t coverageRays = uint64_t(
        p.getInt({"audit.coverage", "rays of the check for light no link carries (0: none)"}, 0, 0, 1 << 30));
    const int64_t worstCount =
        p.getInt({"audit.worst", "audited links listed that lose the most light (0: none)"}, 0, 0, 100000);
    const int64_t reportPatch =
        p.getInt({"audit.patch", "root patch whose links are listed (-1: none)"}, -1, -1, INT32_MAX);
    const int64_t reportSender =
        p.getInt({"audit.sender", "with audit.patch: a root patch taken as the sender of one surface link (-1: none)"}, -1, -1, INT32_MAX);
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
    std::vector<Audited> worst;
    Pcg32 pick(12345);
    uint64_t black = 0;
    for (uint64_t i = 0; i < h.numLinks(); ++i) {
        // Light into a surface that reflects nothing (rho 0: the emitters
        // here) changes no radiosity: left out of the table.
        if (!h.isCluster(recv[i]) && !(s.patches[h.patch(recv[i])].rho.g > 0)) {
            ++black;
            continue;
        }
        const Kind k = kindOf(s, h, h.link(i), recv[i]);
        Total& g = t[k];
        g.model += power[i];
        ++g.links;
        const double pi = std::min(1.0, c * power[i] / std::max(total, 1e-300) + floorP);
        if (pick.nextDouble() >= pi) continue;
        test::LinkPower a = test::auditLink(s, vis, res, recv, i, pairs);
        if (worstCount > 0) worst.push_back({i, k, a});
        g.modelAudited += a.model / pi;
        g.mc += a.mc / pi;
        g.mcOpen += a.mcOpen / pi;
        g.var += a.mcVar / (pi * pi) + (pi < 1 ? (1 - pi) * a.mc * a.mc / (pi * pi) : 0.0);
        ++g.audited;
    }
    // What the receivers hold: sum over root patches of A (B - E) / rho
    // (green), the irradiance power the solution's radiosities imply; below
    // the links' model power, light is lost between a link and the
    // receiver's radiosity (push-pull, hand-over).
    double held = 0.0, dark = 0.0;
    for (uint32_t q = 0; q < h.numPatches(); ++q) {
        const scene::Patch& P = s.patches[q];
        if (P.rho.g > 0) held += P.area * (h.B(q).g - P.emission.g) / P.rho.g;
        else ++dark;
    }
    fmt::print("{}: {} links, model power {:.6g}, held by the receivers {:.6g} (green; {} "
               "patches of rho 0 left out)\n",
               argv[1], h.numLinks(), total, held, dark);
    fmt::print("{} links into surfaces of rho 0 left out\n", black);
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
    if (coverageRays) coverage(s, vis, h, recv, coverageRays);
    printWorst(h, recv, worst, size_t(worstCount));
    if (reportPatch >= 0 && uint64_t(reportPatch) < s.patches.size())
        patchReport(s, vis, res, recv, uint32_t(reportPatch), pairs);
    if (reportPatch >= 0 && reportSender >= 0 &&
        uint64_t(std::max(reportPatch, reportSender)) < s.patches.size())
        pairReport(s, vis, hr::HrSettings::fromParams(p).ff, uint32_t(reportPatch),
                   uint32_t(reportSender));
    return 0;
} catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
}
