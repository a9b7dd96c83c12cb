// Hand-over of the light links bring into oriented receiving clusters: by
// cosine and openness (handOverNewLinks), stand-ins by what each surface
// sees of the sender (handOverStandIns), and the directions the push uses.
// The sums over surfaces are the oriented model's (cluster/oriented_model.h).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <unordered_map>

#include "cluster/openness.h"
#include "cluster/oriented_model.h"
#include "core/rng.h"
#include "hr/hierarchy.h"

namespace hrad::hr {

void Hierarchy::handOverNewLinks() {
    if (!openness_ || clusterLinkDir_.empty()) return;
    const uint32_t np = numPatches();
    std::atomic<uint64_t> byOpenness{0}, byCosine{0}, capped{0};
    tbb::parallel_for(tbb::blocked_range<uint32_t>(np, np + numClusters_, 1), [&](const auto& r) {
        std::vector<uint64_t> fresh;
        std::vector<glm::vec3> dirs;
        std::vector<double> num, den;
        for (uint32_t c = r.begin(); c != r.end(); ++c) {
            fresh.clear();
            for (uint64_t i = linkOffsets_[c]; i < linkOffsets_[c + 1]; ++i)
                if (!(links_[i].flags & (Link::kHandedOver | Link::kStandIn)) && links_[i].K > 0)
                    fresh.push_back(i);
            if (fresh.empty()) continue;
            // W = sum A cos w / sum A cos over every surface below the
            // cluster, exactly as the push will hand it (clusterIrradianceAt).
            dirs.resize(fresh.size());
            for (size_t f = 0; f < fresh.size(); ++f)
                dirs[f] = clusterLinkDir_[fresh[f] - clusterLinkBase_];
            num.assign(fresh.size(), 0.0);
            den.assign(fresh.size(), 0.0);
            cluster::OrientedModel::opennessSums(*scene_, *tree_, *openness_, c - np, dirs,
                                                 num.data(), den.data());
            const uint64_t open = divideByOpenness(fresh, num, den, capped);
            byOpenness += open;
            byCosine += fresh.size() - open;
        }
    });
    handOverByOpenness_ += byOpenness.load();
    handOverByCosine_ += byCosine.load();
    handOverCapped_ += capped.load();
}

// handOverNewLinks for one cluster's fresh links: K / W (held to the bound),
// flags; returns how many were handed over by openness.
uint64_t Hierarchy::divideByOpenness(const std::vector<uint64_t>& fresh,
                                     const std::vector<double>& num, const std::vector<double>& den,
                                     std::atomic<uint64_t>& capped) {
    uint64_t open = 0;
    for (size_t f = 0; f < fresh.size(); ++f) {
        Link& l = links_[fresh[f]];
        l.flags |= Link::kHandedOver;
        if (num[f] > 0 && den[f] > 0) {
            // Held to the unoccluded bound (header); Fupper of a
            // sampled link is its judged estimate, not a bound, and
            // 0 means none is known.
            double k = double(l.K) * (den[f] / num[f]);
            const double bound = std::max(double(l.K), double(l.upperF()));
            if (!(l.flags & Link::kSampled) && l.upperF() > 0.f && k > bound) {
                k = bound;
                ++capped;
            }
            l.K = float(k);
            l.flags |= Link::kOpenHandOver;
            ++open;
        }
    }
    return open;
}

// A stand-in's hand-over: decided once, when the link is first seen (kept by
// receiver and sender across setLinks, as the weights are geometry and the
// sender's light at that time).
struct Hierarchy::SeenDecision {
    uint64_t key = 0, link = 0;
    float scale = 0.f;  // 0: by area
    std::vector<uint8_t> w;
};

// Per-thread scratch of handOverStandIns: the links of one cluster still to
// weigh (`fresh`, indices into its decisions) and their sending surfaces.
struct Hierarchy::SeenScratch {
    std::vector<size_t> fresh;
    std::vector<uint32_t> sourceBegin;
    std::vector<cluster::OrientedModel::Source> sources, lit;
    std::vector<double> seen, cdf;
};

void Hierarchy::handOverStandIns() {
    if (!openness_ || !seenVis_ || !hasStandIns_ || clusterLinkDir_.empty()) {
        seen_.clear();
        seenWeights_.clear();
        seenOffsets_.clear();
        seenCache_.clear();
        return;
    }
    const uint32_t np = numPatches();
    if (orderPos_.empty()) {
        orderPos_.assign(np, kNone);
        for (uint32_t q = 0; q < tree_->orderSize(); ++q) orderPos_[tree_->patchAt(q)] = q;
    }
    std::vector<std::vector<SeenDecision>> made(numClusters_);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, numClusters_, 1), [&](const auto& range) {
        SeenScratch scratch;
        for (uint32_t c = range.begin(); c != range.end(); ++c) {
            seenCandidates(c, made[c], scratch);
            if (scratch.fresh.empty()) continue;
            cluster::OrientedModel::seenWeights(*scene_, *tree_, *openness_, *seenVis_, seed_, c,
                                                scratch.sourceBegin, scratch.sources, scratch.seen);
            scaleSeenWeights(c, scratch, made[c]);
        }
    });
    storeSeen(made);
}

// The by-area stand-ins of cluster c (tree index): decisions kept from
// before, and those still to weigh with their sending surfaces.
void Hierarchy::seenCandidates(uint32_t c, std::vector<SeenDecision>& out, SeenScratch& s) {
    const uint32_t r = numPatches() + c;
    const cluster::ClusterNode& node = tree_->node(c);
    const uint32_t count = node.patchEnd - node.patchBegin;
    s.fresh.clear();
    s.sources.clear();
    s.sourceBegin.assign(1, 0);
    for (uint64_t i = linkOffsets_[r]; i < linkOffsets_[r + 1]; ++i) {
        Link& l = links_[i];
        if (!l.byArea()) continue;
        l.flags &= uint8_t(~Link::kOpenHandOver);
        if (l.sender == r) continue;
        const uint64_t key = (uint64_t(r) << 32) | l.sender;
        if (auto it = seenCache_.find(key); it != seenCache_.end()) {
            SeenDecision m{key, i, 0.f, {}};
            if (it->second != UINT64_MAX) {
                const SeenEntry& e = seen_[it->second];
                m.scale = e.scale;
                m.w.assign(seenWeights_.begin() + ptrdiff_t(e.weights),
                           seenWeights_.begin() + ptrdiff_t(e.weights + count));
            }
            out.push_back(std::move(m));
            continue;
        }
        const size_t first = s.sources.size();
        if (!(seenSources(r, l.sender, s) > 0)) {
            // Nothing to weigh by (a dark sender): by area, decided
            // again when the link is next set.
            s.sources.resize(first);
            continue;
        }
        if (uint64_t(s.sources.size() - first) * count > kSeenMaxPairs) {
            // Too many surface pairs to weigh: by area, for good.
            s.sources.resize(first);
            out.push_back({key, i, 0.f, {}});
            continue;
        }
        s.fresh.push_back(out.size());
        out.push_back({key, i, 0.f, {}});
        s.sourceBegin.push_back(uint32_t(s.sources.size()));
    }
}

// Appends the surfaces of `sender` weighted by their light (at most
// kSeenMaxSources, drawn by light beyond); returns their total weight.
double Hierarchy::seenSources(uint32_t r, uint32_t sender, SeenScratch& s) const {
    if (!isCluster(sender)) {
        s.sources.push_back({patch_[sender], 1.0});
        return 1.0;
    }
    double total = 0.0;
    const cluster::ClusterNode& sn = tree_->node(clusterIndex(sender));
    s.lit.clear();
    for (uint32_t q = sn.patchBegin; q < sn.patchEnd; ++q) {
        const uint32_t p = tree_->patchAt(q);
        const double b = maxComponent(B_[p]);
        if (!(b > 0)) continue;
        s.lit.push_back({p, b});
        total += b;
    }
    if (s.lit.size() <= kSeenMaxSources) {
        s.sources.insert(s.sources.end(), s.lit.begin(), s.lit.end());
        return total;
    }
    // Too many to take all: kSeenMaxSources drawn with probability
    // A_k b_k / sum A b, each weighted b_k over M times that probability,
    // so the weights' expectation is the sum over every lit surface.
    s.cdf.resize(s.lit.size());
    double run = 0.0;
    for (size_t k = 0; k < s.lit.size(); ++k)
        s.cdf[k] = run += s.lit[k].weight * scene_->patches[s.lit[k].patch].area;
    Pcg32 rng(reseed(hashIds(r, sender), seed_));
    for (uint32_t m = 0; m < kSeenMaxSources; ++m) {
        const double u = rng.nextDouble() * run;
        const size_t k = std::min<size_t>(
            size_t(std::upper_bound(s.cdf.begin(), s.cdf.end(), u) - s.cdf.begin()),
            s.lit.size() - 1);
        // run is sum_k A_k b_k.
        s.sources.push_back(
            {s.lit[k].patch, run / (kSeenMaxSources * scene_->patches[s.lit[k].patch].area)});
    }
    return total;
}

// Turns the weights the oriented model summed into bytes and a scale.
void Hierarchy::scaleSeenWeights(uint32_t c, const SeenScratch& s,
                                 std::vector<SeenDecision>& out) const {
    const cluster::ClusterNode& node = tree_->node(c);
    const uint32_t count = node.patchEnd - node.patchBegin;
    for (size_t f = 0; f < s.fresh.size(); ++f) {
        SeenDecision& m = out[s.fresh[f]];
        double top = 0.0, num = 0.0, den = 0.0;
        for (uint32_t k = 0; k < count; ++k) top = std::max(top, s.seen[f * count + k]);
        if (!(top > 0)) continue;  // no surface sees the sender: by area
        // Bytes scaled to the link's largest surface value.
        m.w.resize(count);
        for (uint32_t k = 0; k < count; ++k) {
            m.w[k] = uint8_t(std::lround(255.0 * s.seen[f * count + k] / top));
            const double a = scene_->patches[tree_->patchAt(node.patchBegin + k)].area;
            num += a * m.w[k];
            den += a;
        }
        // Surface k takes b_k den / num of the irradiance: the power
        // sum_k A_k b_k den / num equals sum_k A_k, as by area.
        if (num > 0)
            m.scale = float(den / num);
        else
            m.w.clear();
    }
}

// Stores the decisions in seen_, seenWeights_, seenOffsets_, seenCache_.
void Hierarchy::storeSeen(std::vector<std::vector<SeenDecision>>& made) {
    seen_.clear();
    seenWeights_.clear();
    seenCache_.clear();
    seenOffsets_.assign(size_t(numClusters_) + 1, 0);
    for (uint32_t c = 0; c < numClusters_; ++c) {
        for (SeenDecision& m : made[c]) {
            if (m.scale > 0.f) {
                links_[m.link].flags |= Link::kOpenHandOver;
                seenCache_.emplace(m.key, seen_.size());
                seen_.push_back({m.link, seenWeights_.size(), m.scale});
                seenWeights_.insert(seenWeights_.end(), m.w.begin(), m.w.end());
            } else {
                seenCache_.emplace(m.key, UINT64_MAX);
            }
        }
        seenOffsets_[c + 1] = seen_.size();
    }
    if (seen_.empty()) seenOffsets_.clear();
}

void Hierarchy::prepareOrientedDirections() {
    clusterLinkDir_.clear();
    clusterLinkBase_ = 0;
    if (!transfer_->receivesByCosine() || numClusters_ == 0) return;
    uint32_t k = numPatches();
    clusterLinkBase_ = linkOffsets_[k];
    uint64_t end = linkOffsets_[k + numClusters_];
    clusterLinkDir_.resize(end - clusterLinkBase_);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(k, k + numClusters_, 64), [&](const auto& r) {
        for (uint32_t c = r.begin(); c != r.end(); ++c) {
            Vec3 cc = center(c);
            for (uint64_t i = linkOffsets_[c]; i < linkOffsets_[c + 1]; ++i) {
                Vec3 d = center(links_[i].sender) - cc;
                double len = glm::length(d);
                // A stand-in by area lights the cluster in gatherRow, not
                // by cosine: no direction, so the push skips it.
                clusterLinkDir_[i - clusterLinkBase_] =
                    len > 0 && !links_[i].byArea() ? glm::vec3(d / len) : glm::vec3(0);
            }
        }
    });
}

}  // namespace hrad::hr
