// The hand-over by openness and by what each surface sees
// (hr/openness_handover.h); the sums over a cluster's surfaces are the
// oriented model's (cluster/oriented_model.h).
#include "hr/openness_handover.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "cluster/link.h"
#include "cluster/openness.h"
#include "core/phase_progress.h"
#include "core/rng.h"

namespace hrad::hr {

OpennessHandOver::OpennessHandOver(const scene::Scene& scene, const cluster::ClusterTree& tree,
                                   const cluster::SurfaceOpenness& table,
                                   const transport::Visibility* seenVisibility)
    : scene_(&scene),
      tree_(&tree),
      numPatches_(uint32_t(scene.patches.size())),
      openness_(&table),
      seenVis_(seenVisibility) {}

OpennessHandOver::OpennessHandOver(const scene::Scene& scene, const cluster::ClusterTree& tree,
                                   std::unique_ptr<cluster::SurfaceOpenness> table,
                                   const transport::Visibility* seenVisibility)
    : OpennessHandOver(scene, tree, *table, seenVisibility) {
    owned_ = std::move(table);
}

OpennessHandOver::~OpennessHandOver() = default;

std::unique_ptr<HandOver> makeOpennessHandOver(const HandOverContext& ctx) {
    HRAD_CHECK(ctx.scene && ctx.tree && ctx.visibility && ctx.settings);
    PhaseProgress phase("hand-over openness", ctx.progress);  // core/phase_progress.h
    auto table =
        std::make_unique<cluster::SurfaceOpenness>(*ctx.scene, *ctx.tree, *ctx.visibility, ctx.seed);
    phase.done();
    return std::make_unique<OpennessHandOver>(*ctx.scene, *ctx.tree, std::move(table),
                                              ctx.settings->standInSeen ? ctx.visibility : nullptr);
}

void OpennessHandOver::newLinks(const HandOverLinks& h) {
    if (h.dirs.empty()) return;
    const uint32_t np = h.numPatches;
    std::atomic<uint64_t> byOpenness{0}, byCosine{0}, capped{0};
    tbb::parallel_for(tbb::blocked_range<uint32_t>(np, np + h.numClusters, 1), [&](const auto& r) {
        std::vector<uint64_t> fresh;
        std::vector<glm::vec3> dirs;
        std::vector<double> num, den;
        for (uint32_t c = r.begin(); c != r.end(); ++c) {
            fresh.clear();
            for (uint64_t i = h.offsets[c]; i < h.offsets[c + 1]; ++i)
                if (!(h.links[i].flags & (Link::kHandedOver | Link::kStandIn)) && h.links[i].K > 0)
                    fresh.push_back(i);
            if (fresh.empty()) continue;
            // W = sum A cos w / sum A cos over every surface below the
            // cluster, exactly as the push will hand it (openShares).
            dirs.resize(fresh.size());
            for (size_t f = 0; f < fresh.size(); ++f) dirs[f] = h.dirs[fresh[f] - h.dirBase];
            num.assign(fresh.size(), 0.0);
            den.assign(fresh.size(), 0.0);
            cluster::OrientedModel::opennessSums(*scene_, *tree_, *openness_, c - np, dirs,
                                                 num.data(), den.data());
            const uint64_t open = divideByOpenness(h.links, fresh, num, den, capped);
            byOpenness += open;
            byCosine += fresh.size() - open;
        }
    });
    byOpenness_ += byOpenness.load();
    byCosine_ += byCosine.load();
    capped_ += capped.load();
}

uint64_t OpennessHandOver::divideByOpenness(std::span<Link> links,
                                            const std::vector<uint64_t>& fresh,
                                            const std::vector<double>& num,
                                            const std::vector<double>& den,
                                            std::atomic<uint64_t>& capped) const {
    uint64_t open = 0;
    for (size_t f = 0; f < fresh.size(); ++f) {
        Link& l = links[fresh[f]];
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

void OpennessHandOver::openShares(uint32_t c, uint32_t root, std::span<const glm::vec3> dirs,
                                  std::span<double> w) const {
    // Each surface takes its share by cosine and by how open it is towards
    // the sender within the receiving cluster (cluster/openness.h).
    const cluster::SurfaceOpenness::View view = openness_->view(root);
    const cluster::ClusterNode& node = tree_->node(c - numPatches_);
    const cluster::SurfaceOpenness::Inside inside =
        openness_->inside(view, node.centroid, node.radius);
    for (size_t f = 0; f < dirs.size(); ++f)
        w[f] *= openness_->openness(view, inside, Vec3(dirs[f]), w[f]);
}

void OpennessHandOver::forEachSurfaceShare(uint32_t c, uint32_t root, ShareFn f) const {
    if (seenOffsets_.empty()) return;
    const uint32_t ci = c - numPatches_;
    const cluster::ClusterNode& node = tree_->node(ci);
    for (uint64_t e = seenOffsets_[ci]; e < seenOffsets_[ci + 1]; ++e) {
        const SeenEntry& s = seen_[e];
        const uint8_t b = seenWeights_[s.weights + (orderPos_[root] - node.patchBegin)];
        if (b) f(s.link, double(b) * double(s.scale));
    }
}

std::optional<RGB> OpennessHandOver::surfaceReflected(uint32_t c, uint64_t i) const {
    if (seenOffsets_.empty()) return std::nullopt;
    // As the push hands it (forEachSurfaceShare): w_k / W per surface.
    const uint32_t ci = c - numPatches_;
    const cluster::ClusterNode& node = tree_->node(ci);
    for (uint64_t e = seenOffsets_[ci]; e < seenOffsets_[ci + 1]; ++e) {
        if (seen_[e].link != i) continue;
        RGB sum(0.0);
        for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
            const scene::Patch& P = scene_->patches[tree_->patchAt(q)];
            const double w = seenWeights_[seen_[e].weights + (q - node.patchBegin)];
            sum += (P.area * w * double(seen_[e].scale)) * P.rho;
        }
        return sum;
    }
    return std::nullopt;
}

HandOver::Counts OpennessHandOver::counts() const {
    return {byOpenness_, byCosine_, capped_, seen_.size()};
}

void OpennessHandOver::reportMemory(MemoryCounters& m) const {
    m.set("handover_openness", openness_->memoryBytes());
    if (!seen_.empty())
        m.set("stand_in_handover", seen_.capacity() * sizeof(SeenEntry) +
                                       seenOffsets_.capacity() * sizeof(uint64_t) +
                                       seenWeights_.capacity() + orderPos_.capacity() * 4 +
                                       seenCache_.size() * (2 * sizeof(uint64_t) + sizeof(void*)) +
                                       seenCache_.bucket_count() * sizeof(void*));
}

// ---- stand-ins by what each surface sees ------------------------------------

// A stand-in's hand-over: decided once, when the link is first seen (kept by
// receiver and sender across setLinks, as the weights are geometry and the
// sender's light at that time).
struct OpennessHandOver::SeenDecision {
    uint64_t key = 0, link = 0;
    float scale = 0.f;  // 0: by area
    std::vector<uint8_t> w;
};

// Per-thread scratch of standIns: the links of one cluster still to weigh
// (`fresh`, indices into its decisions) and their sending surfaces.
struct OpennessHandOver::SeenScratch {
    std::vector<size_t> fresh;
    std::vector<uint32_t> sourceBegin;
    std::vector<cluster::OrientedModel::Source> sources, lit;
    std::vector<double> seen, cdf;
};

void OpennessHandOver::clearSeen() {
    seen_.clear();
    seenWeights_.clear();
    seenOffsets_.clear();
    seenCache_.clear();
}

void OpennessHandOver::standIns(const HandOverLinks& h) {
    if (!seenVis_ || !h.hasStandIns || h.dirs.empty()) {
        clearSeen();
        return;
    }
    if (orderPos_.empty()) {
        orderPos_.assign(numPatches_, kNone);
        for (uint32_t q = 0; q < tree_->orderSize(); ++q) orderPos_[tree_->patchAt(q)] = q;
    }
    std::vector<std::vector<SeenDecision>> made(h.numClusters);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, h.numClusters, 1), [&](const auto& range) {
        SeenScratch scratch;
        for (uint32_t c = range.begin(); c != range.end(); ++c) {
            seenCandidates(h, c, made[c], scratch);
            if (scratch.fresh.empty()) continue;
            cluster::OrientedModel::seenWeights(*scene_, *tree_, *openness_, *seenVis_, h.seed, c,
                                                scratch.sourceBegin, scratch.sources, scratch.seen);
            scaleSeenWeights(c, scratch, made[c]);
        }
    });
    storeSeen(h, made);
}

// The by-area stand-ins of cluster c (tree index): decisions kept from
// before, and those still to weigh with their sending surfaces.
void OpennessHandOver::seenCandidates(const HandOverLinks& h, uint32_t c,
                                      std::vector<SeenDecision>& out, SeenScratch& s) const {
    const uint32_t r = h.numPatches + c;
    const cluster::ClusterNode& node = tree_->node(c);
    const uint32_t count = node.patchEnd - node.patchBegin;
    s.fresh.clear();
    s.sources.clear();
    s.sourceBegin.assign(1, 0);
    for (uint64_t i = h.offsets[r]; i < h.offsets[r + 1]; ++i) {
        Link& l = h.links[i];
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
        if (!(seenSources(h, r, l.sender, s) > 0)) {
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
double OpennessHandOver::seenSources(const HandOverLinks& h, uint32_t r, uint32_t sender,
                                     SeenScratch& s) const {
    if (!h.isCluster(sender)) {
        s.sources.push_back({h.patchOf[sender], 1.0});
        return 1.0;
    }
    double total = 0.0;
    const cluster::ClusterNode& sn = tree_->node(sender - h.numPatches);
    s.lit.clear();
    for (uint32_t q = sn.patchBegin; q < sn.patchEnd; ++q) {
        const uint32_t p = tree_->patchAt(q);
        const double b = maxComponent(h.B[p]);
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
    Pcg32 rng(reseed(hashIds(r, sender), h.seed));
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
void OpennessHandOver::scaleSeenWeights(uint32_t c, const SeenScratch& s,
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
void OpennessHandOver::storeSeen(const HandOverLinks& h,
                                 std::vector<std::vector<SeenDecision>>& made) {
    clearSeen();
    seenOffsets_.assign(size_t(h.numClusters) + 1, 0);
    for (uint32_t c = 0; c < h.numClusters; ++c) {
        for (SeenDecision& m : made[c]) {
            if (m.scale > 0.f) {
                h.links[m.link].flags |= Link::kOpenHandOver;
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

}  // namespace hrad::hr
