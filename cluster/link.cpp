#include "cluster/link.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/rng.h"
#include "core/sampling.h"
#include "scene/element.h"
#include "transport/formfactor.h"

namespace hrad::cluster {

namespace {

/// Below this solid angle (sr) a stand-in draws a point on a sender polygon
/// by area instead of a direction over its solid angle: Arvo's construction
/// loses its precision on triangles of a few 1e-4 rad across.
constexpr double kMinSolidAngle = 1e-7;

/// A sender polygon (a patch, or a surface element's domain) seen from x:
/// its corners, the unit directions to them, the solid angles of its fan
/// triangles (0, 1, 2) and (0, 2, 3), and their sum;
/// count 0 when x is not in front of its plane.
struct PolygonView {
    Vec3 dir[4];
    Vec3 corner[4];
    double tri[2] = {0.0, 0.0};
    double omega = 0.0;
    int count = 0;
};

PolygonView viewPolygon(const scene::Patch& P, const scene::Domain& d, const Vec3& x) {
    PolygonView v;
    const int count = scene::elementCorners(P, d, v.corner);
    if (!(glm::dot(P.normal, x - v.corner[0]) > 0)) return v;
    for (int i = 0; i < count; ++i) {
        const Vec3 e = v.corner[i] - x;
        const double l = glm::length(e);
        if (!(l > 0)) return v;
        v.dir[i] = e / l;
    }
    v.tri[0] = sphericalTriangleArea(v.dir[0], v.dir[1], v.dir[2]);
    if (count == 4) v.tri[1] = sphericalTriangleArea(v.dir[0], v.dir[2], v.dir[3]);
    v.omega = v.tri[0] + v.tri[1];
    v.count = count;
    return v;
}

/// A direction w uniform over the solid angle of pv (seen from x; Arvo
/// 1995) and the point y where it meets the polygon's plane (normal n).
/// False when, by rounding at an edge, it does not meet it in front of x.
bool pointOverSolidAngle(const PolygonView& pv, const Vec3& n, const Vec3& x, Pcg32& rng, Vec3& w,
                         Vec3& y) {
    const double pick = rng.nextDouble() * pv.omega;
    const int tri = pv.count == 4 && pick >= pv.tri[0] ? 1 : 0;
    w = sphericalTriangleDirection(pv.dir[0], pv.dir[1 + tri], pv.dir[2 + tri], pv.tri[tri],
                                   rng.nextDouble(), rng.nextDouble());
    const double dn = glm::dot(n, w);
    const double tp = dn < 0 ? glm::dot(n, pv.corner[0] - x) / dn : -1.0;
    y = x + tp * w;
    return tp > 0;
}

}  // namespace

ClusterLinkSettings ClusterLinkSettings::fromParams(const Params& p) {
    ClusterLinkSettings s;
    s.visRays = int(p.getInt(
        {"cluster.vis_rays",
         "visibility rays for links touching clusters (cast twice: one set judges, one transfers)"},
        s.visRays, 0, 1024));
    s.separation =
        p.getDouble({"cluster.separation",
                     "clusters closer than this many bounding-sphere radii are opened, not linked"},
                    s.separation, 1.0, 100.0);
    s.surfaceSeparation = p.getDouble(
        {"cluster.surface_separation", "the same for links between a surface and a cluster"},
        s.surfaceSeparation, 1.0, 100.0);
    const std::string near = p.getEnum({"cluster.near",
                                        "clusters too close to link: open (always opened), sample "
                                        "(Monte Carlo transfer) or stand_in (a sampled stand-in)"},
                                       "stand_in", {"open", "sample", "stand_in"});
    s.sampleNear = near == "sample";
    s.standInNear = near == "stand_in";
    s.nearOverlapping =
        p.getBool({"cluster.near_overlapping", "apply cluster.near to overlapping clusters too"},
                  s.nearOverlapping);
    s.nearOpenPairs = uint64_t(p.getInt(
        {"cluster.near_open_pairs", "near cluster pairs opened at most before stand-ins take over"},
        int64_t(s.nearOpenPairs), 0, int64_t(1) << 40));
    s.nearRays = int(p.getInt({"cluster.near_rays", "rays per near cluster pair (sample)"},
                              s.nearRays, 2, 4096));
    s.deferDark = p.getBool({"cluster.defer_dark", "defer linking clusters that send no light yet"},
                            s.deferDark);
    s.ambient =
        p.getBool({"cluster.ambient",
                   "add an ambient term for light not yet transported through cluster links"},
                  s.ambient);
    s.faceSeparation = p.getDouble(
        {"cluster.face_separation", "separation (in radii) for links between face clusters"},
        s.faceSeparation, 1.0, 100.0);
    s.faceDisc = p.getEnum({"cluster.face_kernel", "face-cluster transfer kernel: point or disc"},
                           "point", {"point", "disc"}) == "disc";
    s.visibleHandover = p.getEnum({"cluster.handover",
                                   "how an oriented receiving cluster hands light to its surfaces: "
                                   "visible (cosine and openness) or cosine"},
                                  "visible", {"visible", "cosine"}) == "visible";
    s.standIn = p.getBool(
        {"cluster.stand_in", "near cluster pairs get a sampled stand-in transfer"}, s.standIn);
    s.standInSeen = p.getEnum({"cluster.stand_in_handover",
                               "how a stand-in's light is handed to surfaces: area or seen"},
                              "area", {"area", "seen"}) == "seen";
    s.standInRays =
        int(p.getInt({"cluster.stand_in_rays", "rays per stand-in pair"}, s.standInRays, 2, 4096));
    s.standInPairs = uint64_t(p.getInt({"cluster.stand_in_pairs", "stand-in pairs at most"},
                                       int64_t(s.standInPairs), 0, int64_t(1) << 40));
    return s;
}

std::string ClusterLinkSettings::describe() const {
    return fmt::format(
        "cluster_vis_rays={}, cluster_separation={}, "
        "cluster_surface_separation={}, cluster_near={}, cluster_near_overlapping={}, "
        "cluster_near_open_pairs={}, "
        "cluster_near_rays={}, "
        "cluster_face_separation={}, cluster_face_kernel={}, cluster_defer_dark={}, "
        "cluster_ambient={}, cluster_handover={}, cluster_stand_in={}, "
        "cluster_stand_in_rays={}, cluster_stand_in_handover={}, cluster_stand_in_pairs={}",
        visRays, separation, surfaceSeparation,
        sampleNear ? "sample" : (standInNear ? "stand_in" : "open"), nearOverlapping, nearOpenPairs,
        nearRays,
        faceSeparation, faceDisc ? "disc" : "point", deferDark, ambient,
        visibleHandover ? "visible" : "cosine", standIn, standInRays, standInSeen ? "seen" : "area",
        standInPairs);
}

ClusterLinker::ClusterLinker(const scene::Scene& scene, const ClusterTree* tree, ClusterModel model,
                             const transport::Visibility* visibility, ClusterLinkSettings settings)
    : scene_(&scene), tree_(tree), model_(model), vis_(visibility), s_(settings) {}

double ClusterLinker::projectedFraction(const LinkEnd& e, const Vec3& d) const {
    if (!e.isCluster) return std::max(0.0, glm::dot(scene_->patches[e.patch].normal, d));
    if (model_ == ClusterModel::Isotropic) return 0.25;
    return e.area > 0 ? tree_->projectedArea(e.cluster, d) / e.area : 0.0;
}

double ClusterLinker::kernel(const LinkEnd& r, const LinkEnd& s) const {
    Vec3 d = r.center - s.center;
    double dist2 = glm::dot(d, d);
    if (!(dist2 > 0)) return 0.0;
    Vec3 u = d / std::sqrt(dist2);
    double gs = projectedFraction(s, u);
    bool orientedReceiver = r.isCluster && model_ == ClusterModel::Oriented;
    double gr = orientedReceiver ? 1.0 : projectedFraction(r, -u);
    if (orientedReceiver && projectedFraction(r, -u) <= 0) return 0.0;
    double denom = kPi * dist2;
    if (s_.faceDisc && faceLink(r, s)) denom += r.area + s.area;
    return s.area * gs * gr / denom;
}

bool ClusterLinker::faceLink(const LinkEnd& r, const LinkEnd& s) const {
    if (!tree_) return false;
    bool rf = r.isCluster && tree_->planarFace(r.cluster);
    bool sf = s.isCluster && tree_->planarFace(s.cluster);
    return (rf || sf) && (!r.isCluster || rf) && (!s.isCluster || sf);
}

Opening ClusterLinker::opening(const LinkEnd& r, const LinkEnd& s) const {
    bool rc = r.isCluster, sc = s.isCluster;
    if (!rc && !sc) return Opening::None;
    // A cluster holding a single surface is that surface: open it at once
    // rather than approximate the surface by a cluster model.
    bool r1 = rc && r.singleSurface, s1 = sc && s.singleSurface;
    if (r1 || s1) return r1 && s1 ? Opening::Both : r1 ? Opening::Receiver : Opening::Sender;
    // `separation` times further apart than touching for cluster-cluster
    // links (measured per link against a Monte Carlo integral of the
    // unoccluded kernel, accepted cluster pairs closer than 2 (rr + rs)
    // carried 15-19 % too little on office:3), `surface_separation` times
    // (default 1: spheres apart) for surface-cluster links.
    // Planar face clusters link like surfaces (see the header).
    bool rv = rc && !(tree_ && tree_->planarFace(r.cluster));
    bool sv = sc && !(tree_ && tree_->planarFace(s.cluster));
    double dist = glm::length(r.center - s.center);
    double sep = rv && sv ? s_.separation : rv || sv ? s_.surfaceSeparation : s_.faceSeparation;
    if (dist > sep * (r.radius + s.radius)) {
        // A face link whose centroids do not face may still exchange light
        // where one end straddles the other's plane: opened, not dropped.
        bool face = (rc && !rv) || (sc && !sv);
        if (face && !(kernel(r, s) > 0) && straddles(r, s)) return openLarger(r, s);
        return Opening::None;
    }
    if (rc && sc)
        return r.radius >= 2 * s.radius   ? Opening::Receiver
               : s.radius >= 2 * r.radius ? Opening::Sender
                                          : Opening::Both;
    return rc ? Opening::Receiver : Opening::Sender;
}

double ClusterLinker::blockedVisibilityBound(int rays) {
    // (1 - v)^n = 0.05: 0.31 for 8 rays, 0.046 for 64.
    return 1.0 - std::pow(0.05, 1.0 / std::max(1, rays));
}

bool ClusterLinker::straddles(const LinkEnd& r, const LinkEnd& s) const {
    // Plane of a flat end: a surface element's, or a face cluster's cone axis
    // through its centroid (its surfaces lie within planarity * radius of it).
    auto front = [&](const LinkEnd& e, const LinkEnd& other) {
        if (e.isCluster && !tree_->planarFace(e.cluster)) return true;  // a volume: no plane
        Vec3 n =
            e.isCluster ? tree_->faceShape(e.cluster).coneAxis : scene_->patches[e.patch].normal;
        double slack = e.isCluster ? tree_->faceShape(e.cluster).planarity * e.radius : 0.0;
        return glm::dot(n, other.center - e.center) > -(other.radius + slack);
    };
    return front(r, s) && front(s, r);
}

Opening ClusterLinker::openLarger(const LinkEnd& r, const LinkEnd& s) const {
    if (r.isCluster && (!s.isCluster || r.radius >= s.radius)) return Opening::Receiver;
    return s.isCluster ? Opening::Sender : Opening::Receiver;
}

bool ClusterLinker::coplanar(const LinkEnd& r, const LinkEnd& s) const {
    auto plane = [&](const LinkEnd& e, Vec3& n, Vec3& x) {
        if (!e.isCluster) {
            const auto& p = scene_->patches[e.patch];
            n = p.normal;
            x = p.v[0];
            return true;
        }
        if (!tree_ || !tree_->flatFace(e.cluster)) return false;
        n = tree_->faceShape(e.cluster).coneAxis;
        x = tree_->node(e.cluster).centroid;
        return true;
    };
    Vec3 nr, xr, ns, xs;
    if (!plane(r, nr, xr) || !plane(s, ns, xs)) return false;
    double tol = 1e-9 * (r.radius + s.radius);
    return std::abs(glm::dot(nr, ns)) >= 1.0 - 1e-12 && std::abs(glm::dot(nr, xs - xr)) <= tol &&
           std::abs(glm::dot(ns, xr - xs)) <= tol;
}

ClusterLink ClusterLinker::link(const LinkEnd& r, const LinkEnd& s,
                                std::span<const RGB> rootB) const {
    ClusterLink out;
    // Coplanar flat ends exchange nothing: no link, no rays.
    if (coplanar(r, s)) return out;
    // A sending cluster that carries no light sends nothing: where its
    // validity allows a link, the link is made without rays and computed
    // when the cluster carries light (cluster.defer_dark).
    const bool dark = s_.deferDark && s.isCluster && !(s.maxB > 0);
    out.open = opening(r, s);
    if (out.open != Opening::None) {
        // Two clusters whose spheres are apart but that are too close for the
        // point approximation: estimated by sampling when so set.
        bool near = s_.sampleNear && r.isCluster && s.isCluster && !r.singleSurface &&
                    !s.singleSurface && glm::length(r.center - s.center) > r.radius + s.radius;
        // cluster.near = stand_in: the solver makes the stand-in (once the
        // sender carries light).
        if (dark && standInNear(r, s)) {
            out.open = Opening::None;
            out.deferred = true;
            return out;
        }
        if (near && dark) {
            out.open = Opening::None;
            out.deferred = true;
            return out;
        }
        if (near) {
            ClusterLink sampled = sampledLink(r, s, rootB);
            if (sampled.open == Opening::None) return sampled;
        }
        return out;  // opened next round, nothing computed
    }
    double K = kernel(r, s);
    if (!(K > 0)) return out;
    if (dark) {
        out.deferred = true;
        return out;
    }
    Vec3 cr = r.center, cs = s.center;
    double dist = glm::length(cr - cs);
    // Upper bound: all cosines <= 1 and the nearest points of the spheres.
    double gap = dist - r.radius - s.radius;
    double iso = model_ == ClusterModel::Isotropic ? 0.25 : 1.0;
    out.Fupper =
        gap > 0 ? s.area * (s.isCluster ? iso : 1.0) * (r.isCluster ? iso : 1.0) / (kPi * gap * gap)
                : 3.0e38;
    double judged = 1.0, carried = 1.0;
    const int n = s_.visRays;
    if (n > 0 && vis_) {
        Pcg32 rng(hashIds(r.stableId, s.stableId));
        transport::Segment seg[64];
        uint8_t occ[64];
        // A point on node e for a ray towards the other node's centroid
        // `towards`, drawn with the density the transfer gives the node's
        // surfaces: on a receiving cluster proportional to A_k cos_k, on a
        // sending cluster to A_k B_k cos_k (B_k its root patch's radiosity).
        // Senders are drawn by A_k B_k (prepareSenders) and accepted by
        // cos_k; otherwise drawn by area and accepted by cos_k B_k / max B
        // (cos_k alone for a receiver, or a sender that carries nothing
        // yet). After 32 rejections the best candidate is used. `cosine` is
        // the sampled surface's cosine towards `towards` (1 for a surface
        // element, sampled uniformly).
        //
        // A patch is planar, so n_k . (towards - x) is the same at every
        // point x of it and the sign of cos_k is known before the point is
        // drawn: a patch facing away (cos_k <= 0, never accepted) is not a
        // candidate at all. A cluster of up to kFacingMax patches lists its
        // facing patches once per link (`Facing`) and draws among them only;
        // a larger one skips the ones it draws that face away. The margin
        // covers the rounding of the two forms of the product.
        constexpr uint32_t kFacingMax = 32;
        struct Facing {
            bool listed = false;  // false: a larger cluster, drawn by rejection
            uint32_t count = 0;
            uint32_t patch[kFacingMax];
            double cum[kFacingMax];  // running sum of the draw weights
            uint32_t leastAway = 0;  // the patch nearest to facing, where none faces
        };
        auto facesAway = [&](const LinkEnd& e, const scene::Patch& P, const Vec3& towards,
                             double& side) {
            const Vec3 t0 = towards - P.v[0];
            side = glm::dot(P.normal, t0);
            return side < -1e-9 * (e.radius + std::abs(t0.x) + std::abs(t0.y) + std::abs(t0.z));
        };
        auto isWeighted = [&](const ClusterNode& nd, bool sender) {
            return sender && !senderPrefix_.empty() &&
                   senderPrefix_[nd.patchEnd] > senderPrefix_[nd.patchBegin];
        };
        auto listFacing = [&](const LinkEnd& e, const Vec3& towards, bool sender, Facing& f) {
            if (!e.isCluster) return;
            const ClusterNode& nd = tree_->node(e.cluster);
            if (nd.patchEnd - nd.patchBegin > kFacingMax) return;
            f.listed = true;
            const bool weighted = isWeighted(nd, sender);
            double sum = 0.0, bestSide = -3.0e38;
            for (uint32_t i = nd.patchBegin; i < nd.patchEnd; ++i) {
                const uint32_t p = tree_->patchAt(i);
                const scene::Patch& P = scene_->patches[p];
                double side = 0.0;
                const bool away = facesAway(e, P, towards, side);
                if (side > bestSide) bestSide = side, f.leastAway = p;
                const double w = weighted ? senderPrefix_[i + 1] - senderPrefix_[i] : P.area;
                if (away || !(w > 0)) continue;
                sum += w;
                f.patch[f.count] = p;
                f.cum[f.count++] = sum;
            }
        };
        Facing facingR, facingS;
        listFacing(r, cs, false, facingR);
        listFacing(s, cr, true, facingS);
        // The cosine at x on `patch` towards `towards`.
        auto cosineAt = [&](uint32_t patch, const Vec3& x, const Vec3& towards) {
            const Vec3 dd = towards - x;
            const double len = glm::length(dd);
            return len > 0 ? glm::dot(scene_->patches[patch].normal, dd) / len : 0.0;
        };
        auto samplePoint = [&](const LinkEnd& e, const Vec3& towards, uint32_t& patch, bool sender,
                               double& cosine) {
            double a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
            cosine = 1.0;
            if (!e.isCluster) {
                patch = e.patch;
                return scene::elementSamplePoint(scene_->patches[patch], e.domain, a, b);
            }
            const Facing& f = sender ? facingS : facingR;
            if (f.listed && f.count == 0) {
                // Nothing faces `towards`: a point on the patch nearest to
                // facing, whose cosine (<= 0) gives the sample no weight.
                patch = f.leastAway;
                const Vec3 x = tree_->pointOnPatch(patch, b, c);
                cosine = cosineAt(patch, x, towards);
                return x;
            }
            const ClusterNode& nd = tree_->node(e.cluster);
            const bool weighted = isWeighted(nd, sender);
            const double bmax = sender && !weighted ? e.maxB : 0.0;
            Vec3 x, best(0.0);
            uint32_t bestPatch = 0, awayPatch = 0;
            double bestW = -2.0, bestCos = 0.0, awayB = 0.0, awayC = 0.0;
            bool anyAway = false;
            for (int t = 0; t < 32; ++t) {
                if (f.listed) {
                    const double u = a * f.cum[f.count - 1];
                    uint32_t k = 0;
                    while (k + 1 < f.count && f.cum[k] <= u) ++k;
                    patch = f.patch[k];
                } else {
                    patch = weighted ? senderPatch(nd, a) : tree_->samplePatch(e.cluster, a);
                }
                const scene::Patch& P = scene_->patches[patch];
                double side = 0.0;
                if (!f.listed && facesAway(e, P, towards, side)) {
                    if (!anyAway) anyAway = true, awayPatch = patch, awayB = b, awayC = c;
                    a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
                    continue;
                }
                x = tree_->pointOnPatch(patch, b, c);
                const double cosx = cosineAt(patch, x, towards);
                double w = weighted ? cosx : std::max(0.0, cosx);
                if (bmax > 0) w *= maxComponent(rootB[patch]) / bmax;
                if (rng.nextDouble() < w) {
                    cosine = cosx;
                    return x;
                }
                if (w > bestW) bestW = w, best = x, bestPatch = patch, bestCos = cosx;
                a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
            }
            if (bestW < -1.5 && anyAway) {
                // Every candidate faced away: the first of them, with no weight.
                bestPatch = awayPatch;
                best = tree_->pointOnPatch(bestPatch, awayB, awayC);
                bestCos = cosineAt(bestPatch, best, towards);
            }
            patch = bestPatch;
            cosine = bestCos;
            return best;
        };
        // One estimate of the visibility fraction from n rays: the
        // kernel-weighted fraction of unblocked rays, sum w_i V_i / sum w_i
        // with w_i = cos_a cos_b / r^2 of the segment over the cosines towards
        // the centroids that the sampling density already holds. Returns the
        // number of blocked rays.
        auto estimate = [&](double& fraction) {
            int blocked = 0, done = 0;
            double wsum = 0.0, wvis = 0.0;
            double cosA[64], cosB[64];
            while (done < n) {
                int m = std::min(64, n - done);
                for (int i = 0; i < m; ++i) {
                    seg[i].a = samplePoint(r, cs, seg[i].patchA, false, cosA[i]);
                    seg[i].b = samplePoint(s, cr, seg[i].patchB, true, cosB[i]);
                }
                vis_->occluded(seg, size_t(m), occ);
                for (int i = 0; i < m; ++i) {
                    blocked += occ[i];
                    Vec3 dd = seg[i].b - seg[i].a;
                    double d2 = glm::dot(dd, dd);
                    double ca = glm::dot(scene_->patches[seg[i].patchA].normal, dd);
                    double cb = -glm::dot(scene_->patches[seg[i].patchB].normal, dd);
                    double w = ca > 0 && cb > 0 && d2 > 0 && cosA[i] > 0 && cosB[i] > 0
                                   ? ca * cb / (d2 * d2 * cosA[i] * cosB[i])
                                   : 0.0;
                    wsum += w;
                    if (!occ[i]) wvis += w;
                }
                done += m;
            }
            fraction = wsum > 0 ? wvis / wsum : double(n - blocked) / n;
            return blocked;
        };
        int blockedJudged = estimate(judged);
        estimate(carried);  // independent: its blocked count sets no flag
        out.rays = uint32_t(2 * n);
        out.partial = blockedJudged > 0 && blockedJudged < n;
        out.uncertain = blockedJudged == n;
    }
    out.K = K * carried;
    out.judged = judged;
    return out;
}

void ClusterLinker::prepareSenders(std::span<const RGB> rootB) {
    if (!tree_) return;  // no clusters: nothing sends as a cluster
    ambient_ = RGB(0.0);
    if (s_.ambient) {
        // The light still to be reflected, spread evenly over the surfaces
        // (the ambient term of Cohen, Chen, Wallace & Greenberg 1988): a
        // closed room of mean reflectance rho reflects P_e rho / (1 - rho)
        // in all; less what the surfaces reflect now, per unit area.
        RGB areaRho(0.0), reflected(0.0);
        double area = 0.0;
        for (size_t p = 0; p < scene_->patches.size() && p < rootB.size(); ++p) {
            const scene::Patch& P = scene_->patches[p];
            area += P.area;
            areaRho += P.area * P.rho;
            reflected += P.area * (rootB[p] - P.emission);
        }
        const RGB pe = scene_->emittedPower();
        for (int c = 0; c < 3 && area > 0; ++c) {
            double rho = std::min(areaRho[c] / area, 0.99);
            ambient_[c] = std::max(0.0, pe[c] * rho / (1.0 - rho) - reflected[c]) / area;
        }
    }
    const uint32_t n = tree_->orderSize();
    senderPrefix_.assign(size_t(n) + 1, 0.0);
    senderM_.assign(scene_->patches.size(), 0.0f);
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t p = tree_->patchAt(i);
        const float m = float(std::max(0.0, maxComponent(senderRadiosity(p, rootB[p]))));
        senderM_[p] = m;
        senderPrefix_[i + 1] = senderPrefix_[i] + scene_->patches[p].area * double(m);
    }
}

RGB ClusterLinker::senderRadiosity(uint32_t patch, const RGB& B) const {
    return B + scene_->patches[patch].rho * ambient_;
}

uint32_t ClusterLinker::senderPatch(const ClusterNode& nd, double u) const {
    const double lo = senderPrefix_[nd.patchBegin], hi = senderPrefix_[nd.patchEnd];
    auto it = std::upper_bound(senderPrefix_.begin() + nd.patchBegin + 1,
                               senderPrefix_.begin() + nd.patchEnd + 1, lo + u * (hi - lo));
    size_t idx = size_t(it - senderPrefix_.begin()) - 1;
    idx = std::min<size_t>(std::max<size_t>(idx, nd.patchBegin), nd.patchEnd - 1);
    return tree_->patchAt(uint32_t(idx));
}

double ClusterLinker::receiverCosine(const LinkEnd& r, const Vec3& u) const {
    // Exact over up to 256 patches; above, the mean over 256 patches drawn
    // by area (a stream of its own).
    const ClusterNode& nd = tree_->node(r.cluster);
    const uint32_t count = nd.patchEnd - nd.patchBegin;
    if (count <= 256) {
        double sum = 0.0, area = 0.0;
        for (uint32_t i = nd.patchBegin; i < nd.patchEnd; ++i) {
            const auto& P = scene_->patches[tree_->patchAt(i)];
            sum += P.area * std::max(0.0, glm::dot(P.normal, u));
            area += P.area;
        }
        return area > 0 ? sum / area : 0.0;
    }
    Pcg32 rng(hashIds(r.stableId, 0x636f73ULL));
    double sum = 0.0;
    for (int i = 0; i < 256; ++i) {
        uint32_t patch = 0;
        double a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
        tree_->samplePoint(r.cluster, a, b, c, patch);
        sum += std::max(0.0, glm::dot(scene_->patches[patch].normal, u));
    }
    return sum / 256.0;
}

Vec3 ClusterLinker::uniformPoint(const LinkEnd& e, Pcg32& rng, uint32_t& patch) const {
    double a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
    if (e.isCluster) return tree_->samplePoint(e.cluster, a, b, c, patch);
    patch = e.patch;
    return scene::elementSamplePoint(scene_->patches[patch], e.domain, a, b);
}

ClusterLink ClusterLinker::sampledLink(const LinkEnd& r, const LinkEnd& s,
                                       std::span<const RGB> rootB) const {
    ClusterLink out;
    out.sampled = true;
    Vec3 u = s.center - r.center;
    double dist = glm::length(u);
    u /= dist;
    double gap = dist - r.radius - s.radius;
    const bool orientedReceiver = r.isCluster && model_ == ClusterModel::Oriented;
    const int n = std::max(2, s_.nearRays);
    Pcg32 rng(hashIds(r.stableId, s.stableId, 0x6e656172ULL));
    // Sender points by radiosity (see the header): drawn by A_k m_k (m_k the
    // largest channel of B_k, prepareSenders), each weighted by c_k / m_k
    // (c_k the mean of the channels), so that M E[k V c / m], M = sum A_k m_k,
    // estimates the power per unit receiver area with the sender's current
    // radiosities; divided by the mean channel of what the gather multiplies
    // K by (s.sent), K is that power per unit of it. A sender that carries
    // nothing yet, or whose gather radiosity is unknown, is drawn by area.
    const ClusterNode* sn = s.isCluster ? &tree_->node(s.cluster) : nullptr;
    const bool weighted = sn && s.sent > 0 && !senderPrefix_.empty() && !rootB.empty() &&
                          senderPrefix_[sn->patchEnd] > senderPrefix_[sn->patchBegin];
    const double scale =
        weighted ? (senderPrefix_[sn->patchEnd] - senderPrefix_[sn->patchBegin]) / s.sent : s.area;
    auto senderPoint = [&](uint32_t& patch, double& w) {
        if (!weighted) {
            w = 1.0;
            return uniformPoint(s, rng, patch);
        }
        double a = rng.nextDouble(), b = rng.nextDouble(), c = rng.nextDouble();
        patch = senderPatch(*sn, a);
        const RGB B = senderRadiosity(patch, rootB[patch]);
        double m = maxComponent(B);
        w = m > 0 ? (B.r + B.g + B.b) / (3.0 * m) : 0.0;
        return tree_->pointOnPatch(patch, b, c);
    };
    // One estimate from n point pairs: sums of the kernel k_i (times the
    // sender point's weight), of k_i V_i and of its square, and the rays cast
    // and blocked (pairs with a zero kernel cast none).
    struct Estimate {
        double k = 0.0, kv = 0.0, kv2 = 0.0, kvAway = 0.0;
        int cast = 0, blocked = 0;
    };
    auto estimate = [&](Estimate& e) {
        transport::Segment seg[64];
        uint8_t occ[64];
        double kern[64];
        bool away[64];
        int done = 0;
        while (done < n) {
            int m = std::min(64, n - done), cast = 0;
            for (int i = 0; i < m; ++i) {
                transport::Segment t;
                t.a = uniformPoint(r, rng, t.patchA);
                double w = 1.0;
                t.b = senderPoint(t.patchB, w);
                const Vec3& na = scene_->patches[t.patchA].normal;
                const Vec3& nb = scene_->patches[t.patchB].normal;
                double cu = glm::dot(na, u);
                Vec3 d = t.b - t.a;
                double d2 = glm::dot(d, d);
                double ca = glm::dot(na, d), cb = -glm::dot(nb, d);
                if (!(ca > 0 && cb > 0 && d2 > 0)) continue;
                away[cast] = cu <= 0;
                kern[cast] = w * ca * cb / (kPi * d2 * d2);
                seg[cast++] = t;
            }
            if (cast > 0 && vis_) vis_->occluded(seg, size_t(cast), occ);
            for (int i = 0; i < cast; ++i) {
                bool blocked = vis_ && occ[i];
                e.k += kern[i];
                e.blocked += blocked;
                if (!blocked) {
                    e.kv += kern[i];
                    e.kv2 += kern[i] * kern[i];
                    if (away[i]) e.kvAway += kern[i];
                }
            }
            e.cast += cast;
            done += m;
        }
    };
    Estimate judged, carried;
    estimate(judged);
    estimate(carried);
    out.rays = uint32_t(judged.cast + carried.cast);
    // Receiver factor: the model hands an oriented receiving cluster's
    // surfaces K cos_k+(u), i.e. K A_r E[cos+] in all.
    // It is computed apart from the estimates' points: E[cos+] from the same
    // points as the kernel would make K a ratio estimate, E[X / Y], biased
    // at small n since the points facing the sender carry both.
    const double rf = orientedReceiver ? receiverCosine(r, u) : 1.0;
    // Estimates the model cannot use; the pair is opened instead:
    //  - an oriented receiver hands the light to its surfaces facing the
    //    sender's centroid; when more than 10 % of the sampled transfer
    //    arrives on surfaces facing away from it (or none faces it), that
    //    hand-over misplaces it;
    //  - a transfer above what any receiver point can take (a point-to-area
    //    form factor is at most 1: K cos <= 1) is sampling noise of a
    //    near-singular kernel;
    //  - an estimate whose error bound (two standard errors) exceeds itself.
    double meanJudged = judged.kv / n, meanCarried = carried.kv / n;
    bool unusable = false;
    if (orientedReceiver) {
        unusable =
            !(rf > 0) || judged.kvAway > 0.1 * judged.kv || carried.kvAway > 0.1 * carried.kv;
    }
    double K = unusable ? 0.0 : scale * meanCarried / rf;
    double judgedK = unusable ? 0.0 : scale * meanJudged / rf;
    if (!unusable && (K > 1.0 || judgedK > 1.0)) unusable = true;
    if (!unusable && meanJudged > 0) {
        double var = std::max(0.0, judged.kv2 / n - meanJudged * meanJudged);
        out.relativeError = 2.0 * std::sqrt(var / (n - 1)) / meanJudged;
        if (out.relativeError > 1.0) unusable = true;
    }
    if (unusable) {
        out.sampled = false;
        out.open = opening(r, s);
        return out;
    }
    out.K = K;
    out.judgedF = scale * meanJudged;
    out.judged = judged.k > 0 ? judged.kv / judged.k : 0.0;
    out.partial = judged.blocked > 0 && judged.blocked < judged.cast;
    if (judged.k > 0 && judged.kv == 0) {
        // Every judged ray with a kernel was blocked: judged with the 95 %
        // bound on the visibility, like a point-approximation link.
        out.uncertain = true;
        double bound = 1.0 - std::pow(0.05, 1.0 / std::max(1, judged.cast));
        out.judgedF = scale * bound * judged.k / n;
        out.judged = bound;
        out.relativeError = 1.0;
    }
    out.Fupper = gap > 0 ? s.area / (kPi * gap * gap) : 3.0e38;
    return out;
}

bool ClusterLinker::holds(const LinkEnd& e, uint32_t patch, const Vec3& x) const {
    if (e.isCluster) {
        const auto& leaf = tree_->patchCluster();
        if (patch >= leaf.size()) return false;
        const auto& parent = tree_->parents();
        for (uint32_t c = leaf[patch]; c != UINT32_MAX; c = parent[c])
            if (c == e.cluster) return true;
        return false;
    }
    if (patch != e.patch) return false;
    if (std::fabs(e.domain.h) >= 1.0) return true;
    const scene::Patch& P = scene_->patches[patch];
    const Vec2 uv = scene::patchInverse(P, x);
    const int level = int(std::lround(-std::log2(std::fabs(e.domain.h))));
    const scene::Domain d = scene::keyDomain(P.kind, scene::keyAt(P.kind, uv.x, uv.y, level));
    const double tol = 1e-9;
    return std::fabs(d.u0 - e.domain.u0) < tol && std::fabs(d.v0 - e.domain.v0) < tol &&
           std::fabs(d.h - e.domain.h) < tol;
}

bool ClusterLinker::standInNear(const LinkEnd& r, const LinkEnd& s) const {
    if (!s_.standInNear || !(r.isCluster || s.isCluster)) return false;
    if ((r.isCluster && r.singleSurface) || (s.isCluster && s.singleSurface)) return false;
    if (s_.nearOpenPairs > 0 && surfaceCount(r) * surfaceCount(s) <= s_.nearOpenPairs)
        return false;
    return s_.nearOverlapping || glm::length(r.center - s.center) > r.radius + s.radius;
}

ClusterLink ClusterLinker::standIn(const LinkEnd& r, const LinkEnd& s,
                                   std::vector<StandInSample>* samples, bool judge) const {
    ClusterLink out;
    out.sampled = true;
    out.standIn = true;
    const int n = std::max(2, s_.standInRays);
    const Vec3 between = s.center - r.center;
    const double dist = glm::length(between);
    const double gap = dist - r.radius - s.radius;
    const bool apart = gap > 0 || !vis_;
    if (!apart && s_.standInPairs > 0 && surfaceCount(r) * surfaceCount(s) <= s_.standInPairs)
        return standInBySurfaces(r, s, samples, judge);
    // Spheres apart, into an oriented cluster: the part of the estimate that
    // arrived on surfaces facing away from the sender's centroid (a cosine
    // hand-over would put it elsewhere).
    const bool towardsCentroid =
        gap > 0 && dist > 0 && r.isCluster && !r.singleSurface && model_ == ClusterModel::Oriented;
    const Vec3 u = dist > 0 ? between / dist : Vec3(0.0);
    // Sender surfaces: drawn by area, or, for a sending cluster whose
    // surfaces carry light (prepareSenders), half by area and half by A_k m_k
    // (a defensive mixture, Hesterberg 1995; see the header).
    const ClusterNode* sn = s.isCluster && tree_ ? &tree_->node(s.cluster) : nullptr;
    const double M = sn && senderM_.size() == scene_->patches.size()
                         ? senderPrefix_[sn->patchEnd] - senderPrefix_[sn->patchBegin]
                         : 0.0;
    const bool weighted = M > 0 && s.area > 0;
    // The probability of drawing sender patch k (1 for a surface element).
    auto patchProbability = [&](uint32_t k) {
        if (!s.isCluster) return 1.0;
        const double A = scene_->patches[k].area, uniform = s.area > 0 ? A / s.area : 0.0;
        return weighted ? 0.5 * uniform + 0.5 * A * double(senderM_[k]) / M : uniform;
    };
    auto senderPatchDrawn = [&](Pcg32& rng) {
        if (!s.isCluster) return s.patch;
        uint32_t k = 0;
        if (!weighted || rng.nextDouble() < 0.5) {
            const double a = rng.nextDouble();
            tree_->samplePoint(s.cluster, a, 0.5, 0.5, k);
        } else {
            k = senderPatch(*sn, rng.nextDouble());
        }
        return k;
    };
    // A point uniform by area on the drawn patch k (on the element's domain
    // for a surface element).
    auto pointOn = [&](Pcg32& rng, uint32_t k) {
        if (!s.isCluster) {
            uint32_t unused = 0;
            return uniformPoint(s, rng, unused);
        }
        const double a = rng.nextDouble(), b = rng.nextDouble();
        return tree_->pointOnPatch(k, a, b);
    };
    // The sender point density per unit area (apart spheres: points drawn
    // by patch, then by area on it).
    auto areaDensity = [&](uint32_t k) {
        const double A = s.isCluster ? scene_->patches[k].area : s.area;
        return A > 0 ? patchProbability(k) / A : 0.0;
    };
    // A sender polygon seen from x: patch k's, or the surface element's.
    auto polygonFrom = [&](uint32_t k, const Vec3& x) {
        return viewPolygon(scene_->patches[k], s.isCluster ? scene::Domain{} : s.domain, x);
    };
    // The density per unit sender area, at a point of patch k (seen as pv)
    // at squared distance d2 under the sender-side cosine cy, of the polygon
    // draw below: patch k with its probability, then a direction uniform
    // over its solid angle (or a point by area on a polygon too small).
    auto polygonDensity = [&](const PolygonView& pv, uint32_t k, double cy, double d2) {
        if (pv.count == 0) return 0.0;
        return pv.omega >= kMinSolidAngle ? patchProbability(k) * cy / (d2 * pv.omega)
                                          : areaDensity(k);
    };
    // Estimates per receiver point: n point pairs when the spheres are apart,
    // n / 2 points of two rays each when they overlap.
    const int points = apart ? n : std::max(2, n / 2);
    // One estimate of `points` samples of the transfer per unit receiver
    // area: their sum and sum of squares, the unoccluded sum (point pairs),
    // the part on surfaces facing away from the sender, the rays cast and
    // the samples that found s; the contributions that found s go to `kept`
    // when given.
    struct Estimate {
        double sum = 0.0, sum2 = 0.0, unoccluded = 0.0, away = 0.0;
        int cast = 0, found = 0;
    };
    auto estimate = [&](Pcg32& rng, std::vector<StandInSample>* kept) {
        Estimate e;
        if (apart) {
            // Spheres apart: point pairs (the kernel is bounded by 1 / gap^2).
            // One pair at a time, to keep each found sender patch.
            for (int i = 0; i < n; ++i) {
                transport::Segment t;
                t.a = uniformPoint(r, rng, t.patchA);
                t.patchB = senderPatchDrawn(rng);
                t.b = pointOn(rng, t.patchB);
                const Vec3& na = scene_->patches[t.patchA].normal;
                const Vec3& nb = scene_->patches[t.patchB].normal;
                Vec3 dv = t.b - t.a;
                double d2 = glm::dot(dv, dv);
                double ca = glm::dot(na, dv), cb = -glm::dot(nb, dv);
                if (!(ca > 0 && cb > 0 && d2 > 0)) continue;
                ++e.cast;
                // The sender at one radiosity: the gather weighs the samples
                // by their patches' radiosities itself.
                double v = ca * cb / (kPi * d2 * d2 * areaDensity(t.patchB));
                e.unoccluded += v;
                if (vis_ && vis_->occluded(t)) continue;
                ++e.found;
                if (towardsCentroid && !(glm::dot(na, u) > 0)) e.away += v;
                e.sum += v;
                e.sum2 += v * v;
                if (kept) kept->push_back({t.patchB, float(v / n)});
            }
        } else {
            // Overlapping spheres: each receiver point x gathers along one
            // cosine-distributed direction and along one direction drawn
            // over the solid angle of a sender polygon, the two combined by
            // the balance heuristic (Veach & Guibas 1995, see the header);
            // each contribution lies in [0, 1].
            for (int i = 0; i < points; ++i) {
                uint32_t pa = 0;
                const Vec3 x = uniformPoint(r, rng, pa);
                const Vec3& nx = scene_->patches[pa].normal;
                double v = 0.0;
                const double u1 = rng.nextDouble(), u2 = rng.nextDouble();
                const Vec3 dir = cosineDirection(nx, u1, u2);
                // Only a ray that enters s's bounding sphere can find s, and
                // only before it leaves it.
                const Vec3 oc = x - s.center;
                const double bq = glm::dot(dir, oc);
                const double R = s.radius * (1.0 + 1e-6) + 1e-12;
                const double disc = bq * bq - (glm::dot(oc, oc) - R * R);
                const double tExit = disc > 0 ? -bq + std::sqrt(disc) : 0.0;
                if (tExit > 0) {
                    transport::RayHit hit = vis_->intersect(x, dir, 0.0, tExit, pa);
                    ++e.cast;
                    const double cy =
                        hit.hit ? -glm::dot(scene_->patches[hit.patch].normal, dir) : 0.0;
                    if (cy > 0 && hit.t > 0 && holds(s, hit.patch, hit.point)) {
                        // Both densities per unit sender area at the hit:
                        // the cosine direction's, cos_x cos_y / (pi d^2),
                        // and the polygon draw's.
                        const double d2 = hit.t * hit.t;
                        const double pc = glm::dot(nx, dir) * cy / (kPi * d2);
                        const double p =
                            polygonDensity(polygonFrom(hit.patch, x), hit.patch, cy, d2);
                        const double w = pc / (pc + p);
                        v += w;
                        if (kept) kept->push_back({hit.patch, float(w / points)});
                    }
                }
                const uint32_t k = senderPatchDrawn(rng);
                const PolygonView pv = polygonFrom(k, x);
                if (pv.count > 0) {
                    // The polygon in front of x: a direction over its solid
                    // angle, or, for a polygon too small to subtend one
                    // reliably, a point by area.
                    transport::Segment t;
                    t.a = x;
                    t.patchA = pa;
                    t.patchB = k;
                    const Vec3& nk = scene_->patches[k].normal;
                    bool ok = true;
                    if (pv.omega >= kMinSolidAngle) {
                        Vec3 w;
                        ok = pointOverSolidAngle(pv, nk, x, rng, w, t.b);
                    } else {
                        t.b = pointOn(rng, k);
                    }
                    const Vec3 dv = t.b - x;
                    const double d2 = glm::dot(dv, dv);
                    const double ca = glm::dot(nx, dv), cb = -glm::dot(nk, dv);
                    if (ok && ca > 0 && cb > 0 && d2 > 0) {
                        ++e.cast;
                        if (!vis_->occluded(t)) {
                            const double g = ca * cb / (kPi * d2 * d2);
                            const double p = polygonDensity(pv, k, cb / std::sqrt(d2), d2);
                            const double w = g / (g + p);
                            v += w;
                            if (kept) kept->push_back({k, float(w / points)});
                        }
                    }
                }
                if (v > 0) ++e.found;
                e.sum += v;
                e.sum2 += v * v;
            }
        }
        return e;
    };
    std::vector<StandInSample> local;
    if (samples) local.reserve(size_t(2 * n));
    Pcg32 rng(hashIds(r.stableId, s.stableId, 0x7374616eULL));
    const Estimate carried = estimate(rng, samples ? &local : nullptr);
    // The judged estimate: an independent one when asked (a stand-in kept
    // only when its own estimate is small would carry less than the true
    // transfer on average; judged by an independent estimate it carries the
    // true transfer), else the carried one.
    Estimate judged = carried;
    if (judge) {
        Pcg32 rngJudge(hashIds(r.stableId, s.stableId, 0x6a756467ULL));
        judged = estimate(rngJudge, nullptr);
    }
    out.rays = uint32_t(carried.cast + (judge ? judged.cast : 0));
    // r cannot take more than s radiates (K <= A_s / A_r) and no receiver
    // point sees a form factor above 1: bounds of the true transfer that
    // keep a noisy estimate from amplifying light.
    const double bound = std::min(1.0, r.area > 0 ? s.area / r.area : 0.0);
    auto clamped = [&](const Estimate& e) { return std::min(bound, e.sum / points); };
    const double mean = carried.sum / points;
    double scale = mean > bound ? bound / mean : 1.0;
    if (towardsCentroid && judged.sum > 0 && judged.away <= 0.05 * judged.sum) {
        // Handed over by cosine (see the header): divided by the receiver's
        // mean cosine towards the sender, so the power is unchanged. Chosen
        // by the judged estimate, like everything that decides whether the
        // link stays (a by-area stand-in faces one more check, HrSolver's
        // misplaced light): decided by the carried one, the stand-ins kept
        // would be those whose carried estimate is low.
        const double c = receiverCosine(r, u);
        if (c > 0) {
            out.byCosine = true;
            scale /= c;
        }
    }
    out.K = mean * scale;
    // The judged transfer per unit receiver area (ClusterLink::judgedF): not
    // divided by the mean cosine like K, since the oracle weighs it by the
    // whole receiver area (a handed-over link delivers K cos_k to each
    // surface, K c A_r in all).
    out.judgedF = clamped(judged);
    if (apart) {
        out.judged = judged.cast > 0 ? double(judged.found) / judged.cast : 0.0;
        out.partial = judged.found > 0 && judged.found < judged.cast;
    } else {
        out.judged = 1.0;
    }
    const double jmean = judged.sum / points;
    if (jmean > 0) {
        double var = std::max(0.0, judged.sum2 / points - jmean * jmean);
        out.relativeError = 2.0 * std::sqrt(var / (points - 1)) / jmean;
    } else if (judged.found == 0 && (judged.cast > 0 || !apart)) {
        // Nothing found: the estimate is 0, but the transfer may not be.
        // judgedF is then a 95 % upper bound. Spheres apart: the
        // Clopper-Pearson bound on the visible fraction (zero successes in
        // `cast`) times the unoccluded estimate. Overlapping spheres: each
        // point's cosine direction finds s with probability its form factor
        // to s (a direction that misses s's sphere is a miss like any
        // other), so the bound for zero successes in `points` trials holds,
        // also when no ray entered the sphere (0 is then no certainty
        // either); the sender points that found nothing only add evidence.
        out.uncertain = true;
        out.relativeError = 1.0;
        const double p95 = 1.0 - std::pow(0.05, 1.0 / (apart ? judged.cast : points));
        out.judgedF = apart ? p95 * judged.unoccluded / n : p95;
    }
    out.Fupper = gap > 0 ? s.area / (kPi * gap * gap) : 3.0e38;
    if (samples) {
        // Merged by patch, in patch order.
        std::sort(local.begin(), local.end(),
                  [](const StandInSample& a, const StandInSample& b) { return a.patch < b.patch; });
        samples->clear();
        for (const StandInSample& x : local) {
            if (!samples->empty() && samples->back().patch == x.patch)
                samples->back().weight += float(x.weight * scale);
            else
                samples->push_back({x.patch, float(x.weight * scale)});
        }
    }
    return out;
}

uint64_t ClusterLinker::surfaceCount(const LinkEnd& e) const {
    if (!e.isCluster) return 1;
    const ClusterNode& nd = tree_->node(e.cluster);
    return nd.patchEnd - nd.patchBegin;
}

ClusterLink ClusterLinker::standInBySurfaces(const LinkEnd& r, const LinkEnd& s,
                                             std::vector<StandInSample>* samples,
                                             bool judge) const {
    ClusterLink out;
    out.sampled = true;
    out.standIn = true;
    out.judged = 1.0;
    out.Fupper = 3.0e38;
    // The surfaces of an end: (patch, domain, area); a cluster's root
    // patches, or the surface element itself.
    struct Surface {
        uint32_t patch;
        scene::Domain domain;
        double area;
    };
    auto surfaces = [&](const LinkEnd& e) {
        std::vector<Surface> v;
        if (!e.isCluster) {
            v.push_back({e.patch, e.domain, e.area});
            return v;
        }
        const ClusterNode& nd = tree_->node(e.cluster);
        v.reserve(nd.patchEnd - nd.patchBegin);
        for (uint32_t q = nd.patchBegin; q < nd.patchEnd; ++q) {
            const uint32_t k = tree_->patchAt(q);
            v.push_back({k, scene::Domain{}, scene_->patches[k].area});
        }
        return v;
    };
    const std::vector<Surface> rs = surfaces(r), ss = surfaces(s);
    // Per sender surface, the carried transfer sum_k A_k F_kj / P (its
    // weight in the gather, before the division by A_r); the judged total
    // and its per-point spread.
    std::vector<double> carried(ss.size(), 0.0);
    double judgedSum = 0.0, unoccluded = 0.0, var = 0.0;
    int cast = 0;
    uint64_t traced = 0;
    // Points per receiver surface, jittered on a side x side grid: at least
    // kSurfacePoints, and at least as many receiver points in all as the
    // sampled estimate's (n / 2).
    const uint64_t want =
        std::max<uint64_t>(kSurfacePoints, uint64_t(std::max(2, s_.standInRays) / 2) / rs.size());
    const int side = int(std::ceil(std::sqrt(double(want)) - 1e-9));
    const int per = side * side;
    Pcg32 rng(hashIds(r.stableId, s.stableId, 0x73757266ULL));
    std::vector<transport::Segment> seg;
    // Per traced ray: its sender surface, whether it is the judged
    // estimate's, and F(x -> j).
    struct Term {
        uint32_t surface;
        bool judged;
        double F;
    };
    std::vector<Term> term;
    std::vector<uint8_t> occ;
    for (const Surface& R : rs) {
        const scene::Patch& P = scene_->patches[R.patch];
        double pointSum = 0.0, pointSum2 = 0.0;
        for (int i = 0; i < per; ++i) {
            const double a = (double(i % side) + rng.nextDouble()) / side;
            const double b = (double(i / side) + rng.nextDouble()) / side;
            const Vec3 x = scene::elementSamplePoint(P, R.domain, a, b);
            seg.clear();
            term.clear();
            for (uint32_t j = 0; j < ss.size(); ++j) {
                const Surface& S = ss[j];
                if (S.patch == R.patch || S.patch == P.twin) continue;
                const scene::Patch& Q = scene_->patches[S.patch];
                const PolygonView pv = viewPolygon(Q, S.domain, x);
                if (pv.count == 0) continue;
                const double F = transport::pointToPolygon(x, P.normal, pv.corner, pv.count);
                if (!(F > 0)) continue;
                // Two directions drawn in proportion to the kernel over the
                // polygon: uniform over its solid angle (Arvo 1995; d omega =
                // cos_y dA / d^2) and accepted with probability cos_x, so the
                // rays weigh the visibility as F does (uniform directions
                // alone overweight grazing ones, which furniture blocks
                // more often). One ray for the carried transfer, one for
                // the judged.
                for (int t = 0; t < 2; ++t) {
                    Vec3 y(0.0);
                    bool ok = false, accepted = false;
                    if (!(pv.omega >= kMinSolidAngle)) {
                        // A polygon too small to subtend a solid angle
                        // reliably: a point on it by area (the kernel is
                        // nearly constant over it).
                        const double ua = rng.nextDouble(), ub = rng.nextDouble();
                        y = scene::elementSamplePoint(Q, S.domain, ua, ub);
                        ok = glm::dot(P.normal, y - x) > 0 && glm::dot(Q.normal, x - y) > 0;
                        accepted = true;
                    }
                    for (int tries = 0; tries < 32 && !accepted; ++tries) {
                        Vec3 w, z;
                        if (!pointOverSolidAngle(pv, Q.normal, x, rng, w, z)) continue;
                        const double cx = glm::dot(P.normal, w);
                        if (!(cx > 0)) continue;
                        // The last direction in front stands in if none is
                        // accepted.
                        ok = true;
                        y = z;
                        accepted = rng.nextDouble() < cx;
                    }
                    if (t == 1) ++cast;
                    // A sliver in front that 32 draws missed: no ray, and
                    // for the judged estimate a blocked one.
                    if (!ok) continue;
                    seg.push_back({x, y, R.patch, S.patch});
                    term.push_back({j, t == 1, F});
                }
                unoccluded += R.area * F / per;
            }
            occ.resize(seg.size());
            if (!seg.empty()) vis_->occluded(seg.data(), seg.size(), occ.data());
            traced += seg.size();
            double point = 0.0;
            for (size_t m = 0; m < seg.size(); ++m) {
                if (occ[m]) continue;
                if (term[m].judged)
                    point += term[m].F;
                else
                    carried[term[m].surface] += R.area * term[m].F / per;
            }
            judgedSum += R.area * point / per;
            pointSum += point;
            pointSum2 += point * point;
        }
        // The judged total's variance from the spread of its points on
        // this surface (each point's value is an estimate of the surface's
        // mean irradiance from s).
        const double m = pointSum / per;
        const double v = std::max(0.0, pointSum2 / per - m * m);
        var += R.area * R.area * v / (per - 1);
    }
    out.rays = uint32_t(std::min<uint64_t>(traced, UINT32_MAX));
    const double Ar = r.area > 0 ? r.area : 1.0;
    double total = 0.0;
    for (double c : carried) total += c;
    // As standIn(): no receiver point sees a form factor above 1 and r
    // cannot take more than s radiates.
    const double bound = std::min(1.0, r.area > 0 ? s.area / r.area : 0.0);
    const double mean = total / Ar;
    const double scale = mean > bound ? bound / mean : 1.0;
    out.K = mean * scale;
    out.judgedF = std::min(bound, (judge ? judgedSum : total) / Ar);
    if (judgedSum > 0) {
        out.relativeError = 2.0 * std::sqrt(var) / judgedSum;
    } else if (unoccluded > 0) {
        // Every ray blocked: the 95 % bound on the visible fraction (zero
        // successes in `cast`) times the unoccluded transfer.
        out.uncertain = true;
        out.relativeError = 1.0;
        const double p95 = 1.0 - std::pow(0.05, 1.0 / std::max(1, cast));
        out.judgedF = std::min(bound, p95 * unoccluded / Ar);
    }
    if (samples) {
        samples->clear();
        if (s.isCluster) {
            std::vector<StandInSample> local;
            for (uint32_t j = 0; j < ss.size(); ++j)
                if (carried[j] > 0) local.push_back({ss[j].patch, float(carried[j] / Ar * scale)});
            std::sort(
                local.begin(), local.end(),
                [](const StandInSample& a, const StandInSample& b) { return a.patch < b.patch; });
            *samples = std::move(local);
        }
    }
    return out;
}

}  // namespace hrad::cluster
