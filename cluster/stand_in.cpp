// Stand-ins: Monte Carlo transfers of links that would have to be opened
// (cluster.stand_in, cluster.near = stand_in; cluster/link.h "Stand-ins"):
// sampled with multiple importance sampling (Veach & Guibas 1995; Arvo 1995
// for directions over a polygon's solid angle), or summed over surface pairs.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "cluster/link.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "scene/element.h"
#include "transport/formfactor.h"
#include "transport/solid_angle.h"

namespace hrad::cluster {

namespace {

using transport::kMinSolidAngle;
using transport::PolygonView;
using transport::viewPolygon;

/// pointOverSolidAngle with rng's next three numbers, drawn in order.
bool pointOverSolidAngle(const PolygonView& pv, const Vec3& n, const Vec3& x, Pcg32& rng, Vec3& w,
                         Vec3& y) {
    const double u0 = rng.nextDouble(), u1 = rng.nextDouble(), u2 = rng.nextDouble();
    return transport::pointOverSolidAngle(pv, n, x, u0, u1, u2, w, y);
}

}  // namespace

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
    if (s_.nearOpenPairs > 0 && surfaceCount(r) * surfaceCount(s) <= s_.nearOpenPairs) return false;
    return s_.nearOverlapping || glm::length(r.center - s.center) > r.radius + s.radius;
}

// The sampling of one stand-in (ClusterLinker::standIn; the header's
// "Stand-ins"): sender surfaces drawn by area, or, for a sending cluster
// whose surfaces carry light (prepareSenders), half by area and half by
// A_k m_k (a defensive mixture, Hesterberg 1995).
class ClusterLinker::StandInSampler {
  public:
    /// One estimate of `points` samples of the transfer per unit receiver
    /// area: their sum and sum of squares, the unoccluded sum (point pairs),
    /// the part on surfaces facing away from the sender, the rays cast and
    /// the samples that found s.
    struct Estimate {
        double sum = 0.0, sum2 = 0.0, unoccluded = 0.0, away = 0.0;
        int cast = 0, found = 0;
    };

    StandInSampler(const ClusterLinker& L, const LinkEnd& r, const LinkEnd& s, int n, bool apart,
                   bool towardsCentroid, const Vec3& u)
        : L_(L), r_(r), s_(s), n_(n), apart_(apart), towardsCentroid_(towardsCentroid), u_(u) {
        sn_ = s.isCluster && L.tree_ ? &L.tree_->node(s.cluster) : nullptr;
        M_ = sn_ && L.senderM_.size() == L.scene_->patches.size()
                 ? L.senderPrefix_[sn_->patchEnd] - L.senderPrefix_[sn_->patchBegin]
                 : 0.0;
        weighted_ = M_ > 0 && s.area > 0;
        // Estimates per receiver point: n point pairs when the spheres are
        // apart, n / 2 points of two rays each when they overlap.
        points_ = apart ? n : std::max(2, n / 2);
    }
    int points() const { return points_; }
    /// The contributions that found s go to `kept` when given.
    Estimate estimate(Pcg32& rng, std::vector<StandInSample>* kept) const {
        return apart_ ? estimateApart(rng, kept) : estimateOverlapping(rng, kept);
    }

  private:
    /// The probability of drawing sender patch k (1 for a surface element).
    double patchProbability(uint32_t k) const {
        if (!s_.isCluster) return 1.0;
        const double A = L_.scene_->patches[k].area, uniform = s_.area > 0 ? A / s_.area : 0.0;
        return weighted_ ? 0.5 * uniform + 0.5 * A * double(L_.senderM_[k]) / M_ : uniform;
    }
    uint32_t senderPatchDrawn(Pcg32& rng) const {
        if (!s_.isCluster) return s_.patch;
        uint32_t k = 0;
        if (!weighted_ || rng.nextDouble() < 0.5) {
            const double a = rng.nextDouble();
            L_.tree_->samplePoint(s_.cluster, a, 0.5, 0.5, k);
        } else {
            k = L_.senderPatch(*sn_, rng.nextDouble());
        }
        return k;
    }
    /// A point uniform by area on the drawn patch k (on the element's
    /// domain for a surface element).
    Vec3 pointOn(Pcg32& rng, uint32_t k) const {
        if (!s_.isCluster) {
            uint32_t unused = 0;
            return L_.uniformPoint(s_, rng, unused);
        }
        const double a = rng.nextDouble(), b = rng.nextDouble();
        return L_.tree_->pointOnPatch(k, a, b);
    }
    /// The sender point density per unit area (apart spheres: points drawn
    /// by patch, then by area on it).
    double areaDensity(uint32_t k) const {
        const double A = s_.isCluster ? L_.scene_->patches[k].area : s_.area;
        return A > 0 ? patchProbability(k) / A : 0.0;
    }
    /// A sender polygon seen from x: patch k's, or the surface element's.
    PolygonView polygonFrom(uint32_t k, const Vec3& x) const {
        return viewPolygon(L_.scene_->patches[k], s_.isCluster ? scene::Domain{} : s_.domain, x);
    }
    /// The density per unit sender area, at a point of patch k (seen as pv)
    /// at squared distance d2 under the sender-side cosine cy, of the polygon
    /// draw: patch k with its probability, then a direction uniform over its
    /// solid angle (or a point by area on a polygon too small).
    double polygonDensity(const PolygonView& pv, uint32_t k, double cy, double d2) const {
        if (pv.count == 0) return 0.0;
        return pv.omega >= kMinSolidAngle ? patchProbability(k) * cy / (d2 * pv.omega)
                                          : areaDensity(k);
    }
    Estimate estimateApart(Pcg32& rng, std::vector<StandInSample>* kept) const;
    Estimate estimateOverlapping(Pcg32& rng, std::vector<StandInSample>* kept) const;
    /// Overlapping spheres, the cosine-distributed ray from x (on patch pa,
    /// normal nx): its balance-heuristic weight where it finds s.
    double cosineRay(Pcg32& rng, const Vec3& x, uint32_t pa, const Vec3& nx, Estimate& e,
                     std::vector<StandInSample>* kept) const;
    /// Overlapping spheres, the ray towards a drawn sender polygon.
    double polygonRay(Pcg32& rng, const Vec3& x, uint32_t pa, const Vec3& nx, Estimate& e,
                      std::vector<StandInSample>* kept) const;

    const ClusterLinker& L_;
    const LinkEnd& r_;
    const LinkEnd& s_;
    int n_;
    bool apart_, towardsCentroid_;
    Vec3 u_;
    const ClusterNode* sn_ = nullptr;
    double M_ = 0.0;
    bool weighted_ = false;
    int points_ = 0;
};

ClusterLinker::StandInSampler::Estimate ClusterLinker::StandInSampler::estimateApart(
    Pcg32& rng, std::vector<StandInSample>* kept) const {
    // Spheres apart: point pairs (the kernel is bounded by 1 / gap^2).
    // One pair at a time, to keep each found sender patch.
    Estimate e;
    const int n = n_;
    for (int i = 0; i < n; ++i) {
        transport::Segment t;
        t.a = L_.uniformPoint(r_, rng, t.patchA);
        t.patchB = senderPatchDrawn(rng);
        t.b = pointOn(rng, t.patchB);
        const Vec3& na = L_.scene_->patches[t.patchA].normal;
        const Vec3& nb = L_.scene_->patches[t.patchB].normal;
        Vec3 dv = t.b - t.a;
        double d2 = glm::dot(dv, dv);
        double ca = glm::dot(na, dv), cb = -glm::dot(nb, dv);
        if (!(ca > 0 && cb > 0 && d2 > 0)) continue;
        ++e.cast;
        // The sender at one radiosity: the gather weighs the samples
        // by their patches' radiosities itself.
        double v = ca * cb / (kPi * d2 * d2 * areaDensity(t.patchB));
        e.unoccluded += v;
        if (L_.vis_ && L_.vis_->occluded(t)) continue;
        ++e.found;
        if (towardsCentroid_ && !(glm::dot(na, u_) > 0)) e.away += v;
        e.sum += v;
        e.sum2 += v * v;
        if (kept) kept->push_back({t.patchB, float(v / n)});
    }
    return e;
}

ClusterLinker::StandInSampler::Estimate ClusterLinker::StandInSampler::estimateOverlapping(
    Pcg32& rng, std::vector<StandInSample>* kept) const {
    // Overlapping spheres: each receiver point x gathers along one
    // cosine-distributed direction and along one direction drawn over the
    // solid angle of a sender polygon, the two combined by the balance
    // heuristic (Veach & Guibas 1995, see the header); each contribution
    // lies in [0, 1].
    Estimate e;
    for (int i = 0; i < points_; ++i) {
        uint32_t pa = 0;
        const Vec3 x = L_.uniformPoint(r_, rng, pa);
        const Vec3& nx = L_.scene_->patches[pa].normal;
        double v = 0.0;
        v += cosineRay(rng, x, pa, nx, e, kept);
        v += polygonRay(rng, x, pa, nx, e, kept);
        if (v > 0) ++e.found;
        e.sum += v;
        e.sum2 += v * v;
    }
    return e;
}

double ClusterLinker::StandInSampler::cosineRay(Pcg32& rng, const Vec3& x, uint32_t pa,
                                                const Vec3& nx, Estimate& e,
                                                std::vector<StandInSample>* kept) const {
    const double u1 = rng.nextDouble(), u2 = rng.nextDouble();
    const Vec3 dir = cosineDirection(nx, u1, u2);
    // Only a ray that enters s's bounding sphere can find s, and only
    // before it leaves it.
    const Vec3 oc = x - s_.center;
    const double bq = glm::dot(dir, oc);
    const double R = s_.radius * (1.0 + 1e-6) + 1e-12;
    const double disc = bq * bq - (glm::dot(oc, oc) - R * R);
    const double tExit = disc > 0 ? -bq + std::sqrt(disc) : 0.0;
    if (!(tExit > 0)) return 0.0;
    transport::RayHit hit = L_.vis_->intersect(x, dir, 0.0, tExit, pa);
    ++e.cast;
    const double cy = hit.hit ? -glm::dot(L_.scene_->patches[hit.patch].normal, dir) : 0.0;
    if (!(cy > 0 && hit.t > 0 && L_.holds(s_, hit.patch, hit.point))) return 0.0;
    // Both densities per unit sender area at the hit: the cosine
    // direction's, cos_x cos_y / (pi d^2), and the polygon draw's.
    const double d2 = hit.t * hit.t;
    const double pc = glm::dot(nx, dir) * cy / (kPi * d2);
    const double p = polygonDensity(polygonFrom(hit.patch, x), hit.patch, cy, d2);
    const double w = pc / (pc + p);
    if (kept) kept->push_back({hit.patch, float(w / points_)});
    return w;
}

double ClusterLinker::StandInSampler::polygonRay(Pcg32& rng, const Vec3& x, uint32_t pa,
                                                 const Vec3& nx, Estimate& e,
                                                 std::vector<StandInSample>* kept) const {
    const uint32_t k = senderPatchDrawn(rng);
    const PolygonView pv = polygonFrom(k, x);
    if (pv.count == 0) return 0.0;
    // The polygon in front of x: a direction over its solid angle, or, for
    // a polygon too small to subtend one reliably, a point by area.
    transport::Segment t;
    t.a = x;
    t.patchA = pa;
    t.patchB = k;
    const Vec3& nk = L_.scene_->patches[k].normal;
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
    if (!(ok && ca > 0 && cb > 0 && d2 > 0)) return 0.0;
    ++e.cast;
    if (L_.vis_->occluded(t)) return 0.0;
    const double g = ca * cb / (kPi * d2 * d2);
    const double p = polygonDensity(pv, k, cb / std::sqrt(d2), d2);
    const double w = g / (g + p);
    if (kept) kept->push_back({k, float(w / points_)});
    return w;
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
        gap > 0 && dist > 0 && r.isCluster && !r.singleSurface && transfer_->receivesByCosine();
    const Vec3 u = dist > 0 ? between / dist : Vec3(0.0);
    const StandInSampler sampler(*this, r, s, n, apart, towardsCentroid, u);
    const int points = sampler.points();
    std::vector<StandInSample> local;
    if (samples) local.reserve(size_t(2 * n));
    Pcg32 rng(hashIds(r.stableId, s.stableId, 0x7374616eULL));
    const StandInSampler::Estimate carried = sampler.estimate(rng, samples ? &local : nullptr);
    // The judged estimate: an independent one when asked (a stand-in kept
    // only when its own estimate is small would carry less than the true
    // transfer on average; judged by an independent estimate it carries the
    // true transfer), else the carried one.
    StandInSampler::Estimate judged = carried;
    if (judge) {
        Pcg32 rngJudge(hashIds(r.stableId, s.stableId, 0x6a756467ULL));
        judged = sampler.estimate(rngJudge, nullptr);
    }
    out.rays = uint32_t(carried.cast + (judge ? judged.cast : 0));
    // r cannot take more than s radiates (K <= A_s / A_r) and no receiver
    // point sees a form factor above 1: bounds of the true transfer that
    // keep a noisy estimate from amplifying light.
    const double bound = std::min(1.0, r.area > 0 ? s.area / r.area : 0.0);
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
    out.judgedF = std::min(bound, judged.sum / points);
    judgeStandIn(out, judged.sum, judged.sum2, judged.cast, judged.found, judged.unoccluded, points,
                 n, apart);
    out.Fupper = gap > 0 ? s.area / (kPi * gap * gap) : 3.0e38;
    if (samples) mergeStandInSamples(local, scale, *samples);
    return out;
}

void ClusterLinker::judgeStandIn(ClusterLink& out, double sum, double sum2, int cast, int found,
                                 double unoccluded, int points, int n, bool apart) {
    if (apart) {
        out.judged = cast > 0 ? double(found) / cast : 0.0;
        out.partial = found > 0 && found < cast;
    } else {
        out.judged = 1.0;
    }
    const double jmean = sum / points;
    if (jmean > 0) {
        double var = std::max(0.0, sum2 / points - jmean * jmean);
        out.relativeError = 2.0 * std::sqrt(var / (points - 1)) / jmean;
    } else if (found == 0 && (cast > 0 || !apart)) {
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
        const double p95 = 1.0 - std::pow(0.05, 1.0 / (apart ? cast : points));
        out.judgedF = apart ? p95 * unoccluded / n : p95;
    }
}

void ClusterLinker::mergeStandInSamples(std::vector<StandInSample>& local, double scale,
                                        std::vector<StandInSample>& samples) {
    // Merged by patch, in patch order.
    std::sort(local.begin(), local.end(),
              [](const StandInSample& a, const StandInSample& b) { return a.patch < b.patch; });
    samples.clear();
    for (const StandInSample& x : local) {
        if (!samples.empty() && samples.back().patch == x.patch)
            samples.back().weight += float(x.weight * scale);
        else
            samples.push_back({x.patch, float(x.weight * scale)});
    }
}

uint64_t ClusterLinker::surfaceCount(const LinkEnd& e) const {
    if (!e.isCluster) return 1;
    const ClusterNode& nd = tree_->node(e.cluster);
    return nd.patchEnd - nd.patchBegin;
}

namespace {

/// A surface of a link end: a cluster's root patch, or the surface element.
struct Surface {
    uint32_t patch;
    scene::Domain domain;
    double area;
};

std::vector<Surface> surfacesOf(const ClusterTree* tree, const scene::Scene& scene,
                                const LinkEnd& e) {
    std::vector<Surface> v;
    if (!e.isCluster) {
        v.push_back({e.patch, e.domain, e.area});
        return v;
    }
    const ClusterNode& nd = tree->node(e.cluster);
    v.reserve(nd.patchEnd - nd.patchBegin);
    for (uint32_t q = nd.patchBegin; q < nd.patchEnd; ++q) {
        const uint32_t k = tree->patchAt(q);
        v.push_back({k, scene::Domain{}, scene.patches[k].area});
    }
    return v;
}

/// Per traced ray: its sender surface, whether it is the judged estimate's,
/// and F(x -> j).
struct SurfaceTerm {
    uint32_t surface;
    bool judged;
    double F;
};

/// The sums of standInBySurfaces: per sender surface, the carried transfer
/// sum_k A_k F_kj / P (its weight in the gather, before the division by
/// A_r); the judged total, its variance, the unoccluded total, the judged
/// rays and every ray traced.
struct SurfaceSums {
    std::vector<double> carried;
    double judgedSum = 0.0, unoccluded = 0.0, var = 0.0;
    int cast = 0;
    uint64_t traced = 0;
};

/// Two directions from x (on P) drawn in proportion to the kernel over the
/// sender polygon j (Q, seen as pv): uniform over its solid angle (Arvo
/// 1995; d omega = cos_y dA / d^2) and accepted with probability cos_x, so
/// the rays weigh the visibility as F does (uniform directions alone
/// overweight grazing ones, which furniture blocks more often). One ray for
/// the carried transfer, one for the judged.
void pairRays(const scene::Patch& P, const Surface& R, const scene::Patch& Q, const Surface& S,
              uint32_t j, const PolygonView& pv, const Vec3& x, double F, Pcg32& rng,
              std::vector<transport::Segment>& seg, std::vector<SurfaceTerm>& term, int& cast) {
    for (int t = 0; t < 2; ++t) {
        Vec3 y(0.0);
        bool ok = false, accepted = false;
        if (!(pv.omega >= kMinSolidAngle)) {
            // A polygon too small to subtend a solid angle reliably: a point
            // on it by area (the kernel is nearly constant over it).
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
            // The last direction in front stands in if none is accepted.
            ok = true;
            y = z;
            accepted = rng.nextDouble() < cx;
        }
        if (t == 1) ++cast;
        // A sliver in front that 32 draws missed: no ray, and for the judged
        // estimate a blocked one.
        if (!ok) continue;
        seg.push_back({x, y, R.patch, S.patch});
        term.push_back({j, t == 1, F});
    }
}

/// Every receiver surface against every sender surface at `per` jittered
/// points (a side x side grid) per receiver surface.
SurfaceSums sumSurfacePairs(const scene::Scene& scene, const transport::Visibility& vis,
                            const std::vector<Surface>& rs, const std::vector<Surface>& ss,
                            int side, Pcg32& rng) {
    const int per = side * side;
    SurfaceSums out;
    out.carried.assign(ss.size(), 0.0);
    std::vector<transport::Segment> seg;
    std::vector<SurfaceTerm> term;
    std::vector<uint8_t> occ;
    for (const Surface& R : rs) {
        const scene::Patch& P = scene.patches[R.patch];
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
                const scene::Patch& Q = scene.patches[S.patch];
                const PolygonView pv = viewPolygon(Q, S.domain, x);
                if (pv.count == 0) continue;
                const double F = transport::pointToPolygon(x, P.normal, pv.corner, pv.count);
                if (!(F > 0)) continue;
                pairRays(P, R, Q, S, j, pv, x, F, rng, seg, term, out.cast);
                out.unoccluded += R.area * F / per;
            }
            occ.resize(seg.size());
            if (!seg.empty()) vis.occluded(seg.data(), seg.size(), occ.data());
            out.traced += seg.size();
            double point = 0.0;
            for (size_t m = 0; m < seg.size(); ++m) {
                if (occ[m]) continue;
                if (term[m].judged)
                    point += term[m].F;
                else
                    out.carried[term[m].surface] += R.area * term[m].F / per;
            }
            out.judgedSum += R.area * point / per;
            pointSum += point;
            pointSum2 += point * point;
        }
        // The judged total's variance from the spread of its points on this
        // surface (each point's value is an estimate of the surface's mean
        // irradiance from s).
        const double m = pointSum / per;
        const double v = std::max(0.0, pointSum2 / per - m * m);
        out.var += R.area * R.area * v / (per - 1);
    }
    return out;
}

}  // namespace

ClusterLink ClusterLinker::standInBySurfaces(const LinkEnd& r, const LinkEnd& s,
                                             std::vector<StandInSample>* samples,
                                             bool judge) const {
    ClusterLink out;
    out.sampled = true;
    out.standIn = true;
    out.judged = 1.0;
    out.Fupper = 3.0e38;
    const std::vector<Surface> rs = surfacesOf(tree_, *scene_, r),
                               ss = surfacesOf(tree_, *scene_, s);
    // Points per receiver surface, jittered on a side x side grid: at least
    // kSurfacePoints, and at least as many receiver points in all as the
    // sampled estimate's (n / 2).
    const uint64_t want =
        std::max<uint64_t>(kSurfacePoints, uint64_t(std::max(2, s_.standInRays) / 2) / rs.size());
    const int side = int(std::ceil(std::sqrt(double(want)) - 1e-9));
    Pcg32 rng(hashIds(r.stableId, s.stableId, 0x73757266ULL));
    const SurfaceSums sums = sumSurfacePairs(*scene_, *vis_, rs, ss, side, rng);
    const std::vector<double>& carried = sums.carried;
    const double judgedSum = sums.judgedSum, unoccluded = sums.unoccluded, var = sums.var;
    out.rays = uint32_t(std::min<uint64_t>(sums.traced, UINT32_MAX));
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
        const double p95 = 1.0 - std::pow(0.05, 1.0 / std::max(1, sums.cast));
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
