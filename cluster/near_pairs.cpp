// Near cluster pairs estimated by Monte Carlo integration of the kernel
// (cluster.near = sample; cluster/link.h "Near cluster pairs").
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "cluster/link.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "scene/element.h"
#include "transport/formfactor.h"

namespace hrad::cluster {

// The point pairs of one sampled near link (ClusterLinker::sampledLink).
// Sender points by radiosity (see the header): drawn by A_k m_k (m_k the
// largest channel of B_k, prepareSenders), each weighted by c_k / m_k (c_k
// the mean of the channels), so that M E[k V c / m], M = sum A_k m_k,
// estimates the power per unit receiver area with the sender's current
// radiosities; divided by the mean channel of what the gather multiplies K
// by (s.sent), K is that power per unit of it. A sender that carries nothing
// yet, or whose gather radiosity is unknown, is drawn by area.
class ClusterLinker::NearSampler {
  public:
    /// One estimate from n point pairs: sums of the kernel k_i (times the
    /// sender point's weight), of k_i V_i and of its square, and the rays
    /// cast and blocked (pairs with a zero kernel cast none).
    struct Estimate {
        double k = 0.0, kv = 0.0, kv2 = 0.0, kvAway = 0.0;
        int cast = 0, blocked = 0;
    };
    NearSampler(const ClusterLinker& L, const LinkEnd& r, const LinkEnd& s,
                std::span<const RGB> rootB, const Vec3& u, int n)
        : L_(L),
          r_(r),
          s_(s),
          rootB_(rootB),
          u_(u),
          n_(n),
          rng_(hashIds(r.stableId, s.stableId, 0x6e656172ULL)) {
        sn_ = s.isCluster ? &L.tree_->node(s.cluster) : nullptr;
        weighted_ = sn_ && s.sent > 0 && !L.senderPrefix_.empty() && !rootB.empty() &&
                    L.senderPrefix_[sn_->patchEnd] > L.senderPrefix_[sn_->patchBegin];
        scale_ = weighted_
                     ? (L.senderPrefix_[sn_->patchEnd] - L.senderPrefix_[sn_->patchBegin]) / s.sent
                     : s.area;
    }
    /// What the mean kernel is multiplied by to give K (before the receiver factor).
    double scale() const { return scale_; }
    void estimate(Estimate& e);

  private:
    Vec3 senderPoint(uint32_t& patch, double& w) {
        if (!weighted_) {
            w = 1.0;
            return L_.uniformPoint(s_, rng_, patch);
        }
        double a = rng_.nextDouble(), b = rng_.nextDouble(), c = rng_.nextDouble();
        patch = L_.senderPatch(*sn_, a);
        const RGB B = L_.senderRadiosity(patch, rootB_[patch]);
        double m = maxComponent(B);
        w = m > 0 ? (B.r + B.g + B.b) / (3.0 * m) : 0.0;
        return L_.tree_->pointOnPatch(patch, b, c);
    }

    const ClusterLinker& L_;
    const LinkEnd& r_;
    const LinkEnd& s_;
    std::span<const RGB> rootB_;
    Vec3 u_;
    int n_;
    Pcg32 rng_;
    const ClusterNode* sn_ = nullptr;
    bool weighted_ = false;
    double scale_ = 0.0;
};

void ClusterLinker::NearSampler::estimate(Estimate& e) {
    transport::Segment seg[64];
    uint8_t occ[64];
    double kern[64];
    bool away[64];
    int done = 0;
    const int n = n_;
    while (done < n) {
        int m = std::min(64, n - done), cast = 0;
        for (int i = 0; i < m; ++i) {
            transport::Segment t;
            t.a = L_.uniformPoint(r_, rng_, t.patchA);
            double w = 1.0;
            t.b = senderPoint(t.patchB, w);
            const Vec3& na = L_.scene_->patches[t.patchA].normal;
            const Vec3& nb = L_.scene_->patches[t.patchB].normal;
            double cu = glm::dot(na, u_);
            Vec3 d = t.b - t.a;
            double d2 = glm::dot(d, d);
            double ca = glm::dot(na, d), cb = -glm::dot(nb, d);
            if (!(ca > 0 && cb > 0 && d2 > 0)) continue;
            away[cast] = cu <= 0;
            kern[cast] = w * ca * cb / (kPi * d2 * d2);
            seg[cast++] = t;
        }
        if (cast > 0 && L_.vis_) L_.vis_->occluded(seg, size_t(cast), occ);
        for (int i = 0; i < cast; ++i) {
            bool blocked = L_.vis_ && occ[i];
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
}

ClusterLink ClusterLinker::sampledLink(const LinkEnd& r, const LinkEnd& s,
                                       std::span<const RGB> rootB) const {
    ClusterLink out;
    out.sampled = true;
    Vec3 u = s.center - r.center;
    double dist = glm::length(u);
    u /= dist;
    double gap = dist - r.radius - s.radius;
    const bool orientedReceiver = r.isCluster && transfer_->receivesByCosine();
    const int n = std::max(2, s_.nearRays);
    NearSampler sampler(*this, r, s, rootB, u, n);
    const double scale = sampler.scale();
    NearSampler::Estimate judged, carried;
    sampler.estimate(judged);
    sampler.estimate(carried);
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

}  // namespace hrad::cluster
