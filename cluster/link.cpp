#include "cluster/link.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/rng.h"
#include "core/sampling.h"
#include "scene/element.h"
#include "transport/formfactor.h"

namespace hrad::cluster {

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
    s.polygonSender =
        p.getEnum({"cluster.sender_kernel",
                   "kernel of links from a surface element into a cluster: point (A_s cos_s / "
                   "(pi d^2) at the centres) or polygon (the exact form factor from the "
                   "receiver's centre to the sender's polygon)"},
                  "point", {"point", "polygon"}) == "polygon";
    const std::string kernel =
        p.getEnum({"cluster.kernel",
                   "point links' geometric kernel: point (the centres' 1/r^2), sampled (times "
                   "r^2 mean 1/d^2 over the visibility rays' point pairs) or pairs (times the "
                   "mean cos cos/d^2 over area-uniform point pairs, relative to the model's)"},
                  "point", {"point", "sampled", "pairs"});
    s.kernel = kernel == "sampled" ? Kernel::Sampled
               : kernel == "pairs" ? Kernel::Pairs
                                   : Kernel::Point;
    s.kernelPairs = int(p.getInt(
        {"cluster.kernel_pairs", "with cluster.kernel = pairs: area-uniform point pairs per link"},
        s.kernelPairs, 1, 4096));
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
        "cluster_stand_in_rays={}, cluster_stand_in_handover={}, cluster_stand_in_pairs={}, "
        "cluster_kernel={}, cluster_kernel_pairs={}{}",
        visRays, separation, surfaceSeparation,
        sampleNear ? "sample" : (standInNear ? "stand_in" : "open"), nearOverlapping, nearOpenPairs,
        nearRays, faceSeparation, faceDisc ? "disc" : "point", deferDark, ambient,
        visibleHandover ? "visible" : "cosine", standIn, standInRays, standInSeen ? "seen" : "area",
        standInPairs,
        kernel == Kernel::Sampled ? "sampled" : (kernel == Kernel::Pairs ? "pairs" : "point"),
        kernelPairs, polygonSender ? ", cluster_sender_kernel=polygon" : "");
}

ClusterLinker::ClusterLinker(const scene::Scene& scene, const ClusterTree* tree, ClusterModel model,
                             const transport::Visibility* visibility, ClusterLinkSettings settings)
    : scene_(&scene),
      tree_(tree),
      model_(model),
      transfer_(&transferModel(model)),
      vis_(visibility),
      s_(settings) {}

double ClusterLinker::projectedFraction(const LinkEnd& e, const Vec3& d) const {
    if (!e.isCluster) return std::max(0.0, glm::dot(scene_->patches[e.patch].normal, d));
    return transfer_->projectedFraction(*tree_, e.cluster, e.area, d);
}

double ClusterLinker::kernel(const LinkEnd& r, const LinkEnd& s) const {
    Vec3 d = r.center - s.center;
    double dist2 = glm::dot(d, d);
    if (!(dist2 > 0)) return 0.0;
    Vec3 u = d / std::sqrt(dist2);
    double gs = projectedFraction(s, u);
    bool orientedReceiver = r.isCluster && transfer_->receivesByCosine();
    double gr = orientedReceiver ? 1.0 : projectedFraction(r, -u);
    if (orientedReceiver && projectedFraction(r, -u) <= 0) return 0.0;
    if (s_.polygonSender && r.isCluster && !s.isCluster) {
        // The sender's polygon seen from the receiver's centre (facing the
        // sender's centroid), exact where the point model is not.
        if (!(gs > 0)) return 0.0;
        Vec3 corner[4];
        const int count = scene::elementCorners(scene_->patches[s.patch], s.domain, corner);
        return transport::pointToPolygon(r.center, -u, corner, count) * gr;
    }
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

// The rays of one point-approximation link (ClusterLinker::link). A point
// on node e for a ray towards the other node's centroid `towards` is drawn
// with the density the transfer gives the node's surfaces: on a receiving
// cluster proportional to A_k cos_k, on a sending cluster to A_k B_k cos_k
// (B_k its root patch's radiosity). Senders are drawn by A_k B_k
// (prepareSenders) and accepted by cos_k; otherwise drawn by area and
// accepted by cos_k B_k / max B (cos_k alone for a receiver, or a sender that
// carries nothing yet). After 32 rejections the best candidate is used.
//
// A patch is planar, so n_k . (towards - x) is the same at every point x of
// it and the sign of cos_k is known before the point is drawn: a patch
// facing away (cos_k <= 0, never accepted) is not a candidate at all. A
// cluster of up to kFacingMax patches lists its facing patches once per link
// (`Facing`) and draws among them only; a larger one skips the ones it draws
// that face away. The margin covers the rounding of the two forms of the
// product.
class ClusterLinker::LinkRays {
  public:
    LinkRays(const ClusterLinker& L, const LinkEnd& r, const LinkEnd& s, std::span<const RGB> rootB)
        : L_(L), receiver_(r), sender_(s), rootB_(rootB), rng_(hashIds(r.stableId, s.stableId)) {
        listFacing(r, s.center, false, facingR_);
        listFacing(s, r.center, true, facingS_);
    }
    /// One estimate of the visibility fraction from n rays: the
    /// kernel-weighted fraction of unblocked rays, sum w_i V_i / sum w_i
    /// with w_i = cos_a cos_b / r^2 of the segment over the cosines towards
    /// the centroids that the sampling density already holds. Returns the
    /// number of blocked rays. `kernel`, where given, gets r^2 times the
    /// mean of 1 / d_i^2 over the n rays (0 for a pair facing away; 1 where
    /// every pair does): the distance part of the mean kernel over the point
    /// pairs relative to the centres' 1 / r^2, which underestimates it where
    /// the ends are large against their distance (E[1 / d^2] > 1 / E[d]^2).
    int estimate(double& fraction, double* kernel = nullptr);
    /// cluster.kernel = pairs: the ratio of the unoccluded transfer between
    /// the two ends, A_r A_s mean(cos_a+ cos_b+ / d^2) / pi over m
    /// area-uniform point pairs (no rays: the kernel only), to what the point
    /// model delivers, A_r g_r A_s g_s / (pi r^2) (g the model's projected
    /// fractions towards the other centre; an oriented receiver's g_r is the
    /// cosine sum its push applies, exact up to kFacingMax surfaces). Area sampling bounds every
    /// term by 1 / gap^2, where the projected-area sampling of the rays, divided by its cosines, is
    /// unbounded (papers/notes/2026-12-02-modern-hall-light.md, sections 3 and 5). `K` is the
    /// link's point kernel (0: factor 1).
    double pairKernel(int m, double K);

  private:
    static constexpr uint32_t kFacingMax = 32;
    struct Facing {
        bool listed = false;  // false: a larger cluster, drawn by rejection
        uint32_t count = 0;
        uint32_t patch[kFacingMax];
        double cum[kFacingMax];  // running sum of the draw weights
        uint32_t leastAway = 0;  // the patch nearest to facing, where none faces
    };
    bool facesAway(const LinkEnd& e, const scene::Patch& P, const Vec3& towards,
                   double& side) const {
        const Vec3 t0 = towards - P.v[0];
        side = glm::dot(P.normal, t0);
        return side < -1e-9 * (e.radius + std::abs(t0.x) + std::abs(t0.y) + std::abs(t0.z));
    }
    bool isWeighted(const ClusterNode& nd, bool sender) const {
        return sender && !L_.senderPrefix_.empty() &&
               L_.senderPrefix_[nd.patchEnd] > L_.senderPrefix_[nd.patchBegin];
    }
    void listFacing(const LinkEnd& e, const Vec3& towards, bool sender, Facing& f) const;
    /// The cosine at x on `patch` towards `towards`.
    double cosineAt(uint32_t patch, const Vec3& x, const Vec3& towards) const {
        const Vec3 dd = towards - x;
        const double len = glm::length(dd);
        return len > 0 ? glm::dot(L_.scene_->patches[patch].normal, dd) / len : 0.0;
    }
    /// A point on e; `cosine` the sampled surface's cosine towards `towards`
    /// (1 for a surface element, sampled uniformly).
    Vec3 samplePoint(const LinkEnd& e, const Vec3& towards, uint32_t& patch, bool sender,
                     double& cosine);
    /// samplePoint on a cluster by rejection, at most kTries candidates.
    /// An accepted point has exactly the target density whatever the cap;
    /// when none is accepted the point gets cosine 0 (no weight in the
    /// ratio estimate) rather than the best candidate's, whose density is
    /// not the target's: taking the best of 32 made the visibility of links
    /// from sending clusters 4 % low on Modern Hall
    /// (papers/notes/2026-12-02-modern-hall-light.md, section 10).
    static constexpr int kTries = 256;
    Vec3 clusterPoint(const LinkEnd& e, const Facing& f, const Vec3& towards, uint32_t& patch,
                      bool sender, double& cosine, double a, double b, double c);

    const ClusterLinker& L_;
    const LinkEnd& receiver_;
    const LinkEnd& sender_;
    std::span<const RGB> rootB_;
    Pcg32 rng_;
    Facing facingR_, facingS_;
    transport::Segment seg_[64];
    uint8_t occ_[64];
};

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
    if (out.open != Opening::None) return nearOrOpen(r, s, rootB, dark, out);
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
    const double iso = transfer_->maxProjectedFraction();
    out.Fupper =
        gap > 0 ? s.area * (s.isCluster ? iso : 1.0) * (r.isCluster ? iso : 1.0) / (kPi * gap * gap)
                : 3.0e38;
    double judged = 1.0, carried = 1.0;
    const int n = s_.visRays;
    if (n > 0 && vis_) {
        LinkRays rays(*this, r, s, rootB);
        int blockedJudged = rays.estimate(judged);
        double factor = 1.0;  // independent: its blocked count sets no flag
        rays.estimate(carried,
                      s_.kernel == ClusterLinkSettings::Kernel::Sampled ? &factor : nullptr);
        carried *= factor;
        if (s_.kernel == ClusterLinkSettings::Kernel::Pairs)
            carried *= rays.pairKernel(s_.kernelPairs, K);
        out.rays = uint32_t(2 * n);
        out.partial = blockedJudged > 0 && blockedJudged < n;
        out.uncertain = blockedJudged == n;
    } else if (s_.kernel == ClusterLinkSettings::Kernel::Pairs) {
        // No visibility rays (cluster.vis_rays = 0): the unoccluded kernel.
        LinkRays rays(*this, r, s, rootB);
        carried = rays.pairKernel(s_.kernelPairs, K);
    }
    out.K = K * carried;
    out.judged = judged;
    return out;
}

ClusterLink ClusterLinker::nearOrOpen(const LinkEnd& r, const LinkEnd& s,
                                      std::span<const RGB> rootB, bool dark,
                                      ClusterLink& out) const {
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

void ClusterLinker::LinkRays::listFacing(const LinkEnd& e, const Vec3& towards, bool sender,
                                         Facing& f) const {
    if (!e.isCluster) return;
    const ClusterNode& nd = L_.tree_->node(e.cluster);
    if (nd.patchEnd - nd.patchBegin > kFacingMax) return;
    f.listed = true;
    const bool weighted = isWeighted(nd, sender);
    double sum = 0.0, bestSide = -3.0e38;
    for (uint32_t i = nd.patchBegin; i < nd.patchEnd; ++i) {
        const uint32_t p = L_.tree_->patchAt(i);
        const scene::Patch& P = L_.scene_->patches[p];
        double side = 0.0;
        const bool away = facesAway(e, P, towards, side);
        if (side > bestSide) bestSide = side, f.leastAway = p;
        const double w = weighted ? L_.senderPrefix_[i + 1] - L_.senderPrefix_[i] : P.area;
        if (away || !(w > 0)) continue;
        sum += w;
        f.patch[f.count] = p;
        f.cum[f.count++] = sum;
    }
}

Vec3 ClusterLinker::LinkRays::samplePoint(const LinkEnd& e, const Vec3& towards, uint32_t& patch,
                                          bool sender, double& cosine) {
    double a = rng_.nextDouble(), b = rng_.nextDouble(), c = rng_.nextDouble();
    cosine = 1.0;
    if (!e.isCluster) {
        patch = e.patch;
        return scene::elementSamplePoint(L_.scene_->patches[patch], e.domain, a, b);
    }
    const Facing& f = sender ? facingS_ : facingR_;
    if (f.listed && f.count == 0) {
        // Nothing faces `towards`: a point on the patch nearest to
        // facing, whose cosine (<= 0) gives the sample no weight.
        patch = f.leastAway;
        const Vec3 x = L_.tree_->pointOnPatch(patch, b, c);
        cosine = cosineAt(patch, x, towards);
        return x;
    }
    return clusterPoint(e, f, towards, patch, sender, cosine, a, b, c);
}

Vec3 ClusterLinker::LinkRays::clusterPoint(const LinkEnd& e, const Facing& f, const Vec3& towards,
                                           uint32_t& patch, bool sender, double& cosine, double a,
                                           double b, double c) {
    const ClusterNode& nd = L_.tree_->node(e.cluster);
    const bool weighted = isWeighted(nd, sender);
    const double bmax = sender && !weighted ? e.maxB : 0.0;
    Vec3 x, best(0.0);
    uint32_t bestPatch = 0, awayPatch = 0;
    double bestW = -2.0, awayB = 0.0, awayC = 0.0;
    bool anyAway = false;
    for (int t = 0; t < kTries; ++t) {
        if (f.listed) {
            const double u = a * f.cum[f.count - 1];
            uint32_t k = 0;
            while (k + 1 < f.count && f.cum[k] <= u) ++k;
            patch = f.patch[k];
        } else {
            patch = weighted ? L_.senderPatch(nd, a) : L_.tree_->samplePatch(e.cluster, a);
        }
        const scene::Patch& P = L_.scene_->patches[patch];
        double side = 0.0;
        if (!f.listed && facesAway(e, P, towards, side)) {
            if (!anyAway) anyAway = true, awayPatch = patch, awayB = b, awayC = c;
            a = rng_.nextDouble(), b = rng_.nextDouble(), c = rng_.nextDouble();
            continue;
        }
        x = L_.tree_->pointOnPatch(patch, b, c);
        const double cosx = cosineAt(patch, x, towards);
        double w = weighted ? cosx : std::max(0.0, cosx);
        if (bmax > 0) w *= maxComponent(rootB_[patch]) / bmax;
        if (rng_.nextDouble() < w) {
            cosine = cosx;
            return x;
        }
        if (w > bestW) bestW = w, best = x, bestPatch = patch;
        a = rng_.nextDouble(), b = rng_.nextDouble(), c = rng_.nextDouble();
    }
    if (bestW < -1.5 && anyAway) {
        // Every candidate faced away: the first of them.
        bestPatch = awayPatch;
        best = L_.tree_->pointOnPatch(bestPatch, awayB, awayC);
    }
    // None accepted: a point for the ray, with no weight.
    patch = bestPatch;
    cosine = 0.0;
    return best;
}

int ClusterLinker::LinkRays::estimate(double& fraction, double* kernel) {
    const int n = L_.s_.visRays;
    const Vec3 cr = receiver_.center, cs = sender_.center;
    int blocked = 0, done = 0;
    double wsum = 0.0, wvis = 0.0, invd2 = 0.0;
    double cosA[64], cosB[64];
    while (done < n) {
        int m = std::min(64, n - done);
        for (int i = 0; i < m; ++i) {
            seg_[i].a = samplePoint(receiver_, cs, seg_[i].patchA, false, cosA[i]);
            seg_[i].b = samplePoint(sender_, cr, seg_[i].patchB, true, cosB[i]);
        }
        L_.vis_->occluded(seg_, size_t(m), occ_);
        for (int i = 0; i < m; ++i) {
            blocked += occ_[i];
            Vec3 dd = seg_[i].b - seg_[i].a;
            double d2 = glm::dot(dd, dd);
            double ca = glm::dot(L_.scene_->patches[seg_[i].patchA].normal, dd);
            double cb = -glm::dot(L_.scene_->patches[seg_[i].patchB].normal, dd);
            double w = ca > 0 && cb > 0 && d2 > 0 && cosA[i] > 0 && cosB[i] > 0
                           ? ca * cb / (d2 * d2 * cosA[i] * cosB[i])
                           : 0.0;
            wsum += w;
            if (kernel && w > 0) invd2 += 1.0 / d2;
            if (!occ_[i]) wvis += w;
        }
        done += m;
    }
    fraction = wsum > 0 ? wvis / wsum : double(n - blocked) / n;
    if (kernel) *kernel = wsum > 0 ? glm::dot(cr - cs, cr - cs) * invd2 / n : 1.0;
    return blocked;
}

double ClusterLinker::LinkRays::pairKernel(int m, double K) {
    const Vec3 d = receiver_.center - sender_.center;
    const double r2 = glm::dot(d, d);
    if (!(K > 0) || !(r2 > 0)) return 1.0;
    const Vec3 u = d / std::sqrt(r2);
    const double gr = L_.projectedFraction(receiver_, -u), gs = L_.projectedFraction(sender_, u);
    if (!(gr > 0) || !(gs > 0)) return 1.0;
    auto areaPoint = [&](const LinkEnd& e, uint32_t& patch) {
        const double a = rng_.nextDouble(), b = rng_.nextDouble(), c = rng_.nextDouble();
        if (!e.isCluster) {
            patch = e.patch;
            return scene::elementSamplePoint(L_.scene_->patches[patch], e.domain, a, b);
        }
        return L_.tree_->samplePoint(e.cluster, a, b, c, patch);
    };
    // A receiver that takes its light by cosine (ByCosine) gets
    // sum_k A_k cos_k from the push, exactly, where the model's g_r is the
    // upper bound of ClusterTree::projectedArea: a cluster of at most
    // kFacingMax surfaces divides by the exact sum (a larger one by the
    // bound). Estimating the sum from the pairs' own receiver points made K
    // unbounded where few of them face the sender (the classroom ran away).
    double pushed = gr;
    if (receiver_.isCluster && L_.transfer_->receivesByCosine()) {
        const ClusterNode& nd = L_.tree_->node(receiver_.cluster);
        if (nd.patchEnd - nd.patchBegin <= kFacingMax && receiver_.area > 0) {
            double exact = 0.0;
            for (uint32_t i = nd.patchBegin; i < nd.patchEnd; ++i) {
                const scene::Patch& P = L_.scene_->patches[L_.tree_->patchAt(i)];
                exact += P.area * std::max(0.0, -glm::dot(P.normal, u));
            }
            if (exact > 0) pushed = exact / receiver_.area;
        }
    }
    double sum = 0.0;
    for (int i = 0; i < m; ++i) {
        uint32_t pr = 0, ps = 0;
        const Vec3 xr = areaPoint(receiver_, pr), xs = areaPoint(sender_, ps);
        const Vec3 dd = xs - xr;
        const double d2 = glm::dot(dd, dd);
        const double ca = glm::dot(L_.scene_->patches[pr].normal, dd);
        const double cb = -glm::dot(L_.scene_->patches[ps].normal, dd);
        if (ca > 0 && cb > 0 && d2 > 0) sum += ca * cb / (d2 * d2);
    }
    return r2 * (sum / m) / (pushed * gs);
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

}  // namespace hrad::cluster
