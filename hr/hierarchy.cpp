#include "hr/hierarchy.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <numeric>

#include "cluster/openness.h"
#include "core/error.h"
#include "core/rng.h"
#include "core/timer.h"
#include "transport/formfactor.h"
#include "transport/visibility.h"

namespace hrad::hr {

using scene::ElementKey;

KernelSamples::KernelSamples(const double* v, int m) {
    HRAD_CHECK(m >= 0 && m <= kCount);
    if (m == 0) return;
    double sum = 0.0;
    for (int k = 0; k < m; ++k) sum += v[k];
    mean_ = float(sum / double(m));
    // Deviations from the mean as stored, so its rounding is not lost.
    double largest = 0.0;
    for (int k = 0; k < m; ++k) largest = std::max(largest, std::fabs(v[k] - double(mean_)));
    if (!(largest > 0.0) || !std::isfinite(largest)) return;
    // largest = f 2^e with f in [0.5, 1): one unit is 2^(e - 15), so the
    // largest deviation is 16384..32768 units (32768 is clamped).
    int e = 0;
    std::frexp(largest, &e);
    exp_ = int16_t(e - 15);
    const double inv = std::ldexp(1.0, -int(exp_));
    for (int k = 0; k < m; ++k) {
        double u = std::nearbyint((v[k] - double(mean_)) * inv);
        q_[size_t(k)] = int16_t(std::clamp(u, -32767.0, 32767.0));
    }
}

Hierarchy::Hierarchy(const scene::Scene& scene, const cluster::ClusterTree* tree,
                     cluster::ClusterModel model, int basisDegree)
    : scene_(&scene), tree_(tree), model_(model) {
    HRAD_CHECK(basisDegree >= 0 && basisDegree <= scene::kMaxBasisDegree);
    if (basisDegree > 0) {
        basis_ = std::make_unique<scene::BasisSet>(basisDegree);
        nb_ = basis_->size();
    }
    if (model_ == cluster::ClusterModel::None) tree_ = nullptr;
    if (!tree_) model_ = cluster::ClusterModel::None;
    uint32_t k = uint32_t(scene.patches.size());
    numClusters_ = tree_ ? tree_->size() : 0;
    uint32_t n = k + numClusters_;
    patch_.assign(n, kNone);
    key_.assign(n, 0);
    parent_.assign(n, kNone);
    firstChild_.assign(n, kNone);
    area_.resize(n);
    B_.assign(n, RGB(0.0));
    gathered_.assign(n, RGB(0.0));
    hi_.assign(size_t(n) * size_t(nb_ - 1), RGB(0.0));
    gatheredHi_.assign(size_t(n) * size_t(nb_ - 1), RGB(0.0));
    for (uint32_t i = 0; i < k; ++i) {
        patch_[i] = i;
        key_[i] = scene::kRootKey;
        area_[i] = scene.patches[i].area;
        B_[i] = scene.patches[i].emission;
    }
    if (tree_) {
        // Patches the tree leaves out (light cannot reach them) have no parent.
        for (uint32_t p = 0; p < k; ++p) {
            const uint32_t c = tree_->patchCluster()[p];
            parent_[p] = c == UINT32_MAX ? kNone : k + c;
        }
        for (uint32_t c = 0; c < numClusters_; ++c) {
            uint32_t pc = tree_->parents()[c];
            parent_[k + c] = pc == UINT32_MAX ? kNone : k + pc;
            area_[k + c] = tree_->node(c).area;
        }
        // Clusters start with the area-weighted average emission below them.
        pullClusters();
    }
    linkOffsets_.assign(size_t(n) + 1, 0);
}

void Hierarchy::pullCluster(uint32_t c) {
    const uint32_t np = numPatches();
    const bool oriented = model_ == cluster::ClusterModel::Oriented;
    const uint32_t e = np + c;
    RGB sum(0.0), mx(0.0);
    // The moments are summed in double and stored in float (RadiantMoments).
    RGB ab(0.0);
    std::array<Vec3, 3> ms{};
    std::array<std::array<double, 6>, 3> mm{};
    for (uint32_t i = 0; i < numChildren(e); ++i) {
        uint32_t ch = child(e, i);
        sum += area_[ch] * B_[ch];
        mx = glm::max(mx, isCluster(ch) ? maxB_[ch - np] : B_[ch]);
        if (!oriented) continue;
        if (isCluster(ch)) {
            const RadiantMoments& cm = moments_[ch - np];
            ab += RGB(cm.ab);
            for (int k = 0; k < 3; ++k) {
                ms[k] += Vec3(cm.s[k]);
                for (int j = 0; j < 6; ++j) mm[k][j] += cm.m[k][j];
            }
        } else {
            const Vec3& n = scene_->patches[patch_[ch]].normal;
            RGB w = area_[ch] * B_[ch];
            ab += w;
            double nn[6] = {n.x * n.x, n.x * n.y, n.x * n.z, n.y * n.y, n.y * n.z, n.z * n.z};
            for (int k = 0; k < 3; ++k) {
                ms[k] += w[k] * n;
                for (int j = 0; j < 6; ++j) mm[k][j] += w[k] * nn[j];
            }
        }
    }
    B_[e] = area_[e] > 0 ? sum / area_[e] : RGB(0.0);
    maxB_[c] = mx;
    if (!oriented) return;
    RadiantMoments& mom = moments_[c];
    mom.ab = glm::vec3(ab);
    for (int k = 0; k < 3; ++k) {
        mom.s[k] = glm::vec3(ms[k]);
        for (int j = 0; j < 6; ++j) mom.m[k][j] = float(mm[k][j]);
    }
}

void Hierarchy::pullClusters() {
    const uint32_t nc = numClusters_;
    if (model_ == cluster::ClusterModel::Oriented) moments_.assign(nc, RadiantMoments{});
    maxB_.resize(nc);
    // Children before parents (pre-order indices, so walk backwards).
    for (uint32_t c = nc; c-- > 0;) pullCluster(c);
}

RGB Hierarchy::directionalB(uint32_t e, const Vec3& d) const {
    if (!isCluster(e) || model_ != cluster::ClusterModel::Oriented) return B_[e];
    uint32_t c = clusterIndex(e);
    double proj = tree_->projectedArea(c, d);
    if (!(proj > 0)) return B_[e];
    const RadiantMoments& m = moments_[c];
    RGB out;
    for (int k = 0; k < 3; ++k) {
        const auto& M = m.m[k];
        double q = d.x * (M[0] * d.x + M[1] * d.y + M[2] * d.z) +
                   d.y * (M[1] * d.x + M[3] * d.y + M[4] * d.z) +
                   d.z * (M[2] * d.x + M[4] * d.y + M[5] * d.z);
        // sum A B max(0, n.d) = (sum A B |n.d| + sum A B n.d) / 2, the first
        // sum estimated as sqrt(sum A B * sum A B (n.d)^2) (Cauchy-Schwarz;
        // exact when |n.d| is the same for all surfaces that carry light).
        const double ab = m.ab[k];
        double p = 0.5 * (std::sqrt(std::max(0.0, ab * q)) + glm::dot(Vec3(m.s[k]), d));
        out[k] = std::clamp(p, 0.0, ab) / proj;
    }
    return out;
}

uint32_t Hierarchy::numChildren(uint32_t e) const {
    if (isCluster(e)) {
        const auto& c = tree_->node(clusterIndex(e));
        return c.childCount ? c.childCount : c.ownEnd() - c.ownBegin();
    }
    return firstChild_[e] == kNone ? 0 : 4;
}

uint32_t Hierarchy::child(uint32_t e, uint32_t i) const {
    if (isCluster(e)) {
        uint32_t ci = clusterIndex(e);
        const auto& c = tree_->node(ci);
        if (c.childCount) return numPatches() + tree_->child(ci, i);
        return tree_->patchAt(c.ownBegin() + i);
    }
    return firstChild_[e] + i;
}

Vec3 Hierarchy::center(uint32_t e) const {
    if (isCluster(e)) return tree_->node(clusterIndex(e)).centroid;
    return scene::elementCentroid(scene_->patches[patch_[e]], domain(e));
}

double Hierarchy::radius(uint32_t e) const {
    if (isCluster(e)) return tree_->node(clusterIndex(e)).radius;
    const scene::Patch& p = scene_->patches[patch_[e]];
    scene::Domain d = domain(e);
    Vec3 c[4];
    int n = scene::elementCorners(p, d, c);
    Vec3 m = scene::elementCentroid(p, d);
    double r2 = 0;
    for (int i = 0; i < n; ++i) r2 = std::max(r2, glm::dot(c[i] - m, c[i] - m));
    return std::sqrt(r2);
}

RGB Hierarchy::rho(uint32_t e) const {
    if (isCluster(e)) return tree_->node(clusterIndex(e)).rho;
    return scene_->patches[patch_[e]].rho;
}

scene::Domain Hierarchy::domain(uint32_t e) const {
    HRAD_DCHECK(!isCluster(e));
    return scene::keyDomain(scene_->patches[patch_[e]].kind, key_[e]);
}

uint64_t Hierarchy::stableId(uint32_t e) const {
    if (isCluster(e)) return reseed(hashIds(0xC105E6ULL, clusterIndex(e)), seed_);
    return reseed(hashIds(patch_[e], key_[e]), seed_);
}

void Hierarchy::subdivide(uint32_t e) {
    if (firstChild_[e] != kNone) return;
    HRAD_CHECK(scene::keyLevel(key_[e]) < scene::kMaxLevel);
    const scene::Patch& p = scene_->patches[patch_[e]];
    scene::Domain d = domain(e);
    uint32_t first = numElements();
    firstChild_[e] = first;
    for (int c = 0; c < 4; ++c) {
        patch_.push_back(patch_[e]);
        key_.push_back(scene::childKey(key_[e], c));
        parent_.push_back(e);
        firstChild_.push_back(kNone);
        area_.push_back(scene::elementArea(p, scene::childDomain(p.kind, d, c)));
        B_.push_back(B_[e]);
        gathered_.push_back(RGB(0.0));
    }
    if (nb_ > 1) {
        // Children start with the parent's polynomial restricted to them
        // (exact two-scale push), as constant children inherit B.
        const size_t m = size_t(nb_ - 1);
        hi_.resize(hi_.size() + 4 * m, RGB(0.0));
        gatheredHi_.resize(gatheredHi_.size() + 4 * m, RGB(0.0));
        const scene::Basis& b = basis_->of(p.kind);
        RGB par[scene::kMaxBasisSize];
        par[0] = B_[e];
        for (size_t a = 1; a < size_t(nb_); ++a) par[a] = hi_[size_t(e) * m + a - 1];
        for (int c = 0; c < 4; ++c) {
            const auto& T = b.twoScale(c);
            for (int j = 0; j < nb_; ++j) {
                RGB v(0.0);
                for (int a = 0; a < nb_; ++a) v += T[size_t(a * nb_ + j)] * par[a];
                if (j == 0)
                    B_[first + uint32_t(c)] = v;
                else
                    hi_[size_t(first + uint32_t(c)) * m + size_t(j - 1)] = v;
            }
        }
    }
}

void Hierarchy::reserveElements(size_t more) {
    const size_t n = size_t(numElements()) + more;
    if (n <= patch_.capacity()) return;
    patch_.reserve(n);
    key_.reserve(n);
    parent_.reserve(n);
    firstChild_.reserve(n);
    area_.reserve(n);
    B_.reserve(n);
    gathered_.reserve(n);
    if (nb_ > 1) {
        hi_.reserve(n * size_t(nb_ - 1));
        gatheredHi_.reserve(n * size_t(nb_ - 1));
    }
}

RGB Hierarchy::evaluate(uint32_t e, double a, double b) const {
    if (nb_ == 1) return B_[e];
    double phi[scene::kMaxBasisSize];
    basis_->of(scene_->patches[patch_[e]].kind).eval(a, b, phi);
    RGB v = B_[e];
    const RGB* h = hi(e);
    for (int k = 1; k < nb_; ++k) v += phi[k] * h[k - 1];
    return v;
}

void Hierarchy::setCoupling(std::vector<uint32_t>&& index, std::vector<float>&& data) {
    HRAD_CHECK(index.empty() || index.size() == links_.size());
    couplingIndex_ = std::move(index);
    couplingData_ = std::move(data);
    couplingIndex_.shrink_to_fit();
    couplingData_.shrink_to_fit();
}

uint32_t Hierarchy::numLeaves() const {
    uint32_t n = 0;
    for (uint32_t e = 0; e < numElements(); ++e) n += isLeaf(e) ? 1 : 0;
    return n;
}

std::vector<Link> Hierarchy::takeLinks() {
    std::vector<Link> out = std::move(links_);
    links_ = {};
    linkOffsets_.assign(1, 0);
    linkOffsets_.shrink_to_fit();
    clusterLinkDir_ = {};
    couplingIndex_ = {};
    couplingData_ = {};
    return out;
}

void Hierarchy::setLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links) {
    placeLinks(receivers, std::move(links), nullptr);
}

void Hierarchy::setLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links,
                         std::vector<KernelSamples>&& samples) {
    placeLinks(receivers, std::move(links), &samples);
}

void Hierarchy::placeLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links,
                           std::vector<KernelSamples>* samples) {
    HRAD_CHECK(receivers.size() == links.size());
    if (links.size() > kMaxLinks)
        throw Error(fmt::format("{} links: a hierarchy holds at most {} (hr.max_links)",
                                links.size(), kMaxLinks));
    uint32_t n = numElements();
    // Counting sort by receiver; stable, so each row keeps the given order.
    linkOffsets_.assign(size_t(n) + 1, 0);
    for (uint32_t r : receivers) {
        HRAD_DCHECK(r < n);
        ++linkOffsets_[r + 1];
    }
    for (uint32_t i = 0; i < n; ++i) linkOffsets_[i + 1] += linkOffsets_[i];
    std::vector<Link> sorted(links.size());
    std::vector<uint64_t> fill(linkOffsets_.begin(), linkOffsets_.end() - 1);
    // The samples follow their links into receiver order: per receiver, the
    // offset of its first sample, then a stable scatter.
    samples_.clear();
    samples_.shrink_to_fit();
    hasSamples_ = samples != nullptr;
    if (samples) {
        std::vector<uint64_t> sampleFill(size_t(n) + 1, 0);
        for (size_t i = 0; i < links.size(); ++i)
            if (storesKernelSamples(receivers[i], links[i])) ++sampleFill[receivers[i] + 1];
        for (uint32_t i = 0; i < n; ++i) sampleFill[i + 1] += sampleFill[i];
        HRAD_CHECK(samples->size() == sampleFill[n]);
        samples_.resize(samples->size());
        for (size_t i = 0, k = 0; i < links.size(); ++i)
            if (storesKernelSamples(receivers[i], links[i]))
                samples_[sampleFill[receivers[i]]++] = (*samples)[k++];
        samples->clear();
        samples->shrink_to_fit();
    }
    for (size_t i = 0; i < links.size(); ++i) sorted[fill[receivers[i]]++] = links[i];
    links_ = std::move(sorted);
    links_.shrink_to_fit();
    hasStandIns_ = std::any_of(links_.begin(), links_.end(),
                               [](const Link& l) { return (l.flags & Link::kStandIn) != 0; });
    compactStandIns();
    links.clear();
    links.shrink_to_fit();
    // The coupling matrices belonged to the old links (the solver sets new ones).
    couplingIndex_.clear();
    couplingData_.clear();
    prepareOrientedDirections();
    handOverNewLinks();
    handOverStandIns();
}

void Hierarchy::compactStandIns() {
    // Blocks of stand-ins that refinement replaced are dropped; the others
    // are renumbered in link order.
    if (standInSamples_.empty()) return;
    std::vector<uint64_t> begin{0};
    std::vector<cluster::StandInSample> kept;
    for (Link& l : links_) {
        if (!(l.flags & Link::kStandIn) || !isCluster(l.sender)) continue;
        const uint32_t b = std::bit_cast<uint32_t>(l.Fupper);
        HRAD_DCHECK(size_t(b) + 1 < standInBegin_.size());
        kept.insert(kept.end(), standInSamples_.begin() + ptrdiff_t(standInBegin_[b]),
                    standInSamples_.begin() + ptrdiff_t(standInBegin_[b + 1]));
        begin.push_back(kept.size());
        l.Fupper = std::bit_cast<float>(uint32_t(begin.size() - 2));
    }
    kept.shrink_to_fit();
    standInSamples_ = std::move(kept);
    standInBegin_ = std::move(begin);
}

uint32_t Hierarchy::addStandIn(std::span<const cluster::StandInSample> samples, float judged) {
    // The block starts with the judged transfer (patch kNone), then the samples.
    standInSamples_.push_back({kNone, judged});
    standInSamples_.insert(standInSamples_.end(), samples.begin(), samples.end());
    standInBegin_.push_back(standInSamples_.size());
    return uint32_t(standInBegin_.size() - 2);
}

RGB Hierarchy::standInSent(const Link& l) const {
    if (!isCluster(l.sender)) return double(l.K) * B_[l.sender];
    const uint32_t block = std::bit_cast<uint32_t>(l.Fupper);
    HRAD_DCHECK(size_t(block) + 1 < standInBegin_.size());
    RGB sum(0.0);
    for (uint64_t k = standInBegin_[block] + 1; k < standInBegin_[block + 1]; ++k)
        sum += double(standInSamples_[k].weight) * B_[standInSamples_[k].patch];
    return sum;
}

RGB Hierarchy::standInReflected(uint32_t r, uint64_t i) const {
    const Link& l = links_[i];
    const RGB sent = standInSent(l);
    if (!isCluster(r)) return sent * area(r) * scene_->patches[patch_[r]].rho;
    if (l.bySeen()) {
        // As the push hands it (clusterIrradianceAt): w_k / W per surface.
        const uint32_t c = clusterIndex(r);
        const cluster::ClusterNode& node = tree_->node(c);
        for (uint64_t e = seenOffsets_[c]; e < seenOffsets_[c + 1]; ++e) {
            if (seen_[e].link != i) continue;
            RGB sum(0.0);
            for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
                const scene::Patch& P = scene_->patches[tree_->patchAt(q)];
                const double w = seenWeights_[seen_[e].weights + (q - node.patchBegin)];
                sum += (P.area * w * double(seen_[e].scale)) * P.rho;
            }
            return sent * sum;
        }
    }
    Vec3 d = center(l.sender) - center(r);
    const double len = glm::length(d);
    const bool byCosine = !l.byArea() && model_ == cluster::ClusterModel::Oriented && len > 0;
    if (byCosine) d /= len;
    const glm::vec3 dir(d);
    RGB sum(0.0);
    const cluster::ClusterNode& node = tree_->node(clusterIndex(r));
    for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
        const scene::Patch& P = scene_->patches[tree_->patchAt(q)];
        const double w = byCosine ? std::max(0.0, double(glm::dot(glm::vec3(P.normal), dir))) : 1.0;
        sum += (P.area * w) * P.rho;
    }
    return sent * sum;
}

double Hierarchy::standInJudged(const Link& l) const {
    if (!isCluster(l.sender)) return l.Fupper;
    const uint32_t block = std::bit_cast<uint32_t>(l.Fupper);
    HRAD_DCHECK(size_t(block) + 1 < standInBegin_.size());
    return standInSamples_[standInBegin_[block]].weight;
}

RGB Hierarchy::linkSent(uint64_t i, const glm::vec3& dir) const {
    const Link& l = links_[i];
    if (l.flags & Link::kStandIn) return standInSent(l);
    return double(l.K) * directionalB(l.sender, -Vec3(dir));
}

void Hierarchy::handOverNewLinks() {
    if (!openness_ || clusterLinkDir_.empty()) return;
    const uint32_t np = numPatches();
    std::atomic<uint64_t> byOpenness{0}, byCosine{0}, capped{0};
    tbb::parallel_for(tbb::blocked_range<uint32_t>(np, np + numClusters_, 1), [&](const auto& r) {
        std::vector<uint64_t> fresh;
        std::vector<double> num, den;
        for (uint32_t c = r.begin(); c != r.end(); ++c) {
            fresh.clear();
            for (uint64_t i = linkOffsets_[c]; i < linkOffsets_[c + 1]; ++i)
                if (!(links_[i].flags & (Link::kHandedOver | Link::kStandIn)) && links_[i].K > 0)
                    fresh.push_back(i);
            if (fresh.empty()) continue;
            // W = sum A cos w / sum A cos over every surface below the
            // cluster, exactly as the push will hand it (clusterIrradianceAt).
            num.assign(fresh.size(), 0.0);
            den.assign(fresh.size(), 0.0);
            const cluster::ClusterNode& node = tree_->node(c - np);
            for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
                const uint32_t p = tree_->patchAt(q);
                const glm::vec3 n(scene_->patches[p].normal);
                const double area = scene_->patches[p].area;
                bool haveView = false;
                cluster::SurfaceOpenness::View view;
                cluster::SurfaceOpenness::Inside inside;
                for (size_t f = 0; f < fresh.size(); ++f) {
                    const glm::vec3& dir = clusterLinkDir_[fresh[f] - clusterLinkBase_];
                    double cosine = glm::dot(n, dir);
                    if (!(cosine > 0)) continue;
                    if (!haveView) {
                        view = openness_->view(p);
                        inside = openness_->inside(view, node.centroid, node.radius);
                        haveView = true;
                    }
                    den[f] += area * cosine;
                    num[f] += area * cosine * openness_->openness(view, inside, Vec3(dir), cosine);
                }
            }
            uint64_t open = 0;
            for (size_t f = 0; f < fresh.size(); ++f) {
                Link& l = links_[fresh[f]];
                l.flags |= Link::kHandedOver;
                if (num[f] > 0 && den[f] > 0) {
                    // Held to the unoccluded bound (header); Fupper of a
                    // sampled link is its judged estimate, not a bound, and
                    // 0 means none is known.
                    double k = double(l.K) * (den[f] / num[f]);
                    const double bound = std::max(double(l.K), double(l.Fupper));
                    if (!(l.flags & Link::kSampled) && l.Fupper > 0.f && k > bound) {
                        k = bound;
                        ++capped;
                    }
                    l.K = float(k);
                    l.flags |= Link::kOpenHandOver;
                    ++open;
                }
            }
            byOpenness += open;
            byCosine += fresh.size() - open;
        }
    });
    handOverByOpenness_ += byOpenness.load();
    handOverByCosine_ += byCosine.load();
    handOverCapped_ += capped.load();
}

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
    // The sender's surfaces, each with the weight of the light it sends.
    struct Source {
        uint32_t patch;
        double weight;
    };
    // A stand-in's hand-over: decided once, when the link is first seen
    // (kept by receiver and sender across setLinks, as the weights are
    // geometry and the sender's light at that time).
    struct Made {
        uint64_t key = 0, link = 0;
        float scale = 0.f;  // 0: by area
        std::vector<uint8_t> w;
    };
    std::vector<std::vector<Made>> made(numClusters_);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, numClusters_, 1), [&](const auto& range) {
        std::vector<size_t> fresh;
        std::vector<uint32_t> sourceBegin;
        std::vector<Source> sources, lit;
        std::vector<double> seen, cdf;
        struct Term {
            uint32_t link;
            double w;
        };
        std::vector<transport::Segment> segments;
        std::vector<Term> terms;
        std::vector<uint8_t> blocked;
        for (uint32_t c = range.begin(); c != range.end(); ++c) {
            const uint32_t r = np + c;
            const cluster::ClusterNode& node = tree_->node(c);
            const uint32_t count = node.patchEnd - node.patchBegin;
            std::vector<Made>& out = made[c];
            fresh.clear();
            sources.clear();
            sourceBegin.assign(1, 0);
            for (uint64_t i = linkOffsets_[r]; i < linkOffsets_[r + 1]; ++i) {
                Link& l = links_[i];
                if (!l.byArea()) continue;
                l.flags &= uint8_t(~Link::kOpenHandOver);
                if (l.sender == r) continue;
                const uint64_t key = (uint64_t(r) << 32) | l.sender;
                if (auto it = seenCache_.find(key); it != seenCache_.end()) {
                    Made m{key, i, 0.f, {}};
                    if (it->second != UINT64_MAX) {
                        const SeenEntry& e = seen_[it->second];
                        m.scale = e.scale;
                        m.w.assign(seenWeights_.begin() + ptrdiff_t(e.weights),
                                   seenWeights_.begin() + ptrdiff_t(e.weights + count));
                    }
                    out.push_back(std::move(m));
                    continue;
                }
                const size_t first = sources.size();
                double total = 0.0;
                if (isCluster(l.sender)) {
                    const cluster::ClusterNode& sn = tree_->node(clusterIndex(l.sender));
                    lit.clear();
                    for (uint32_t q = sn.patchBegin; q < sn.patchEnd; ++q) {
                        const uint32_t p = tree_->patchAt(q);
                        const double b = maxComponent(B_[p]);
                        if (!(b > 0)) continue;
                        lit.push_back({p, b});
                        total += b;
                    }
                    if (lit.size() <= kSeenMaxSources) {
                        sources.insert(sources.end(), lit.begin(), lit.end());
                    } else {
                        // Too many to take all: kSeenMaxSources drawn with
                        // probability A_k b_k / sum A b, each weighted b_k
                        // over M times that probability, so the weights'
                        // expectation is the sum over every lit surface.
                        cdf.resize(lit.size());
                        double run = 0.0;
                        for (size_t k = 0; k < lit.size(); ++k)
                            cdf[k] = run += lit[k].weight * scene_->patches[lit[k].patch].area;
                        Pcg32 rng(reseed(hashIds(r, l.sender), seed_));
                        for (uint32_t m = 0; m < kSeenMaxSources; ++m) {
                            const double u = rng.nextDouble() * run;
                            const size_t k = std::min<size_t>(
                                size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()),
                                lit.size() - 1);
                            // run is sum_k A_k b_k.
                            sources.push_back(
                                {lit[k].patch,
                                 run / (kSeenMaxSources * scene_->patches[lit[k].patch].area)});
                        }
                    }
                } else {
                    sources.push_back({patch_[l.sender], 1.0});
                    total = 1.0;
                }
                if (!(total > 0)) {
                    // Nothing to weigh by (a dark sender): by area, decided
                    // again when the link is next set.
                    sources.resize(first);
                    continue;
                }
                if (uint64_t(sources.size() - first) * count > kSeenMaxPairs) {
                    // Too many surface pairs to weigh: by area, for good.
                    sources.resize(first);
                    out.push_back({key, i, 0.f, {}});
                    continue;
                }
                fresh.push_back(out.size());
                out.push_back({key, i, 0.f, {}});
                sourceBegin.push_back(uint32_t(sources.size()));
            }
            if (fresh.empty()) continue;
            seen.assign(fresh.size() * size_t(count), 0.0);
            for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
                const uint32_t p = tree_->patchAt(q);
                const scene::Patch& P = scene_->patches[p];
                const cluster::SurfaceOpenness::View view = openness_->view(p);
                // One shadow ray per receiver point and sender surface, to a
                // point stratified over the sender (a fixed 2x2 pattern,
                // shifted per pair): F(x -> j) counts where it is unblocked.
                segments.clear();
                terms.clear();
                for (size_t f = 0; f < fresh.size(); ++f) {
                    for (uint32_t k = sourceBegin[f]; k < sourceBegin[f + 1]; ++k) {
                        const uint32_t sp = sources[k].patch;
                        const scene::Patch& S = scene_->patches[sp];
                        if (sp == p || sp == P.twin) continue;
                        Pcg32 rng(reseed(hashIds(p, sp), seed_));
                        const double su = rng.nextDouble(), sv = rng.nextDouble();
                        for (int j = 0; j < cluster::SurfaceOpenness::kPoints; ++j) {
                            const Vec3& x = view.x[j];
                            // Only the front of a one-sided sender sends.
                            if (!(glm::dot(x - S.v[0], S.normal) > 0)) continue;
                            const double F =
                                transport::pointToPolygon(x, P.normal, S.v.data(), S.numVertices());
                            if (!(F > 0)) continue;
                            const double u1 = std::fmod(0.25 + 0.5 * (j & 1) + su, 1.0);
                            const double u2 = std::fmod(0.25 + 0.5 * (j >> 1) + sv, 1.0);
                            const Vec3 y = tree_->pointOnPatch(sp, u1, u2);
                            // A point behind either surface's plane is not
                            // seen (the rest of the sender may be: F holds it,
                            // the ray only tells whether the view is blocked).
                            if (!(glm::dot(y - x, P.normal) > 0) ||
                                !(glm::dot(x - y, S.normal) > 0))
                                continue;
                            segments.push_back({x, y, p, sp});
                            terms.push_back({uint32_t(f), sources[k].weight * F});
                        }
                    }
                }
                blocked.resize(segments.size());
                if (!segments.empty())
                    seenVis_->occluded(segments.data(), segments.size(), blocked.data());
                for (size_t i = 0; i < segments.size(); ++i)
                    if (!blocked[i])
                        seen[terms[i].link * count + (q - node.patchBegin)] += terms[i].w;
            }
            for (size_t f = 0; f < fresh.size(); ++f) {
                Made& m = out[fresh[f]];
                double top = 0.0, num = 0.0, den = 0.0;
                for (uint32_t k = 0; k < count; ++k) top = std::max(top, seen[f * count + k]);
                if (!(top > 0)) continue;  // no surface sees the sender: by area
                // Bytes scaled to the link's largest surface value.
                m.w.resize(count);
                for (uint32_t k = 0; k < count; ++k) {
                    m.w[k] = uint8_t(std::lround(255.0 * seen[f * count + k] / top));
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
    });
    seen_.clear();
    seenWeights_.clear();
    seenCache_.clear();
    seenOffsets_.assign(size_t(numClusters_) + 1, 0);
    for (uint32_t c = 0; c < numClusters_; ++c) {
        for (Made& m : made[c]) {
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
    if (model_ != cluster::ClusterModel::Oriented || numClusters_ == 0) return;
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

std::vector<uint32_t> Hierarchy::linkReceivers() const {
    std::vector<uint32_t> r(links_.size());
    for (uint32_t e = 0; e < numElements(); ++e)
        for (uint64_t i = linkBegin(e); i < linkEnd(e); ++i) r[i] = e;
    return r;
}

void Hierarchy::gatherRow(uint32_t r) {
    const bool oriented = model_ == cluster::ClusterModel::Oriented && numClusters_ > 0;
    if (oriented && patch_[r] == kNone) {
        // An oriented cluster gathers nothing as a whole: its links light
        // each surface below it with that surface's cosine when pushed
        // (clusterIrradianceToRoots). Stand-ins by area (cluster/link.h)
        // light its surfaces by area: gathered here and handed down as an
        // isotropic cluster's irradiance is (clusterDown).
        RGB standIn(0.0);
        for (uint64_t i = linkBegin(r); i < linkEnd(r); ++i)
            if (links_[i].byArea() && !links_[i].bySeen()) standIn += standInSent(links_[i]);
        gathered_[r] = standIn;
        return;
    }
    RGB sum(0.0);
    // Higher coefficients gathered over coupling matrices (degree > 0).
    RGB sumHi[scene::kMaxBasisSize];
    for (int a = 1; a < nb_; ++a) sumHi[a] = RGB(0.0);
    // Fixed summation order within a row: results do not depend on how rows
    // are split between threads.
    bool haveCenter = false;
    Vec3 cr(0.0);
    for (uint64_t i = linkBegin(r); i < linkEnd(r); ++i) {
        uint32_t s = links_[i].sender;
        if (links_[i].flags & Link::kStandIn) {
            sum += standInSent(links_[i]);
            continue;
        }
        const float* K = nb_ > 1 ? coupling(i) : nullptr;
        if (K) {
            // c^r_a += sum_b K^{ab} c^s_b (transport/coupling.h).
            const RGB* hs = hi(s);
            for (int a = 0; a < nb_; ++a) {
                const float* row = K + a * nb_;
                RGB v = double(row[0]) * B_[s];
                for (int b = 1; b < nb_; ++b) v += double(row[b]) * hs[b - 1];
                if (a == 0)
                    sum += v;
                else
                    sumHi[a] += v;
            }
            continue;
        }
        if (oriented && isCluster(s) && !haveCenter) {
            cr = center(r);
            haveCenter = true;
        }
        sum += rowSent(i, oriented ? &cr : nullptr);
    }
    if (patch_[r] == kNone) {
        // A cluster gathers irradiance (reflected per surface when pushed);
        // oriented clusters push link by link instead.
        gathered_[r] = model_ == cluster::ClusterModel::Isotropic ? sum : RGB(0.0);
        return;
    }
    const RGB& rho = scene_->patches[patch_[r]].rho;
    gathered_[r] = rho * sum;
    for (int a = 1; a < nb_; ++a)
        gatheredHi_[size_t(r) * size_t(nb_ - 1) + size_t(a - 1)] = rho * sumHi[a];
}

RGB Hierarchy::rowSent(uint64_t i, const Vec3* receiverCenter) const {
    const Link& l = links_[i];
    const uint32_t s = l.sender;
    if (l.flags & Link::kStandIn) return standInSent(l);
    if (const float* K = nb_ > 1 ? coupling(i) : nullptr) {
        // The constant term: sum_b K^{0b} c^s_b (transport/coupling.h).
        RGB v = double(K[0]) * B_[s];
        for (int b = 1; b < nb_; ++b) v += double(K[b]) * hi(s)[b - 1];
        return v;
    }
    if (receiverCenter && isCluster(s)) {
        // An oriented cluster sends what its surfaces facing the receiver
        // carry, not its mean radiosity.
        Vec3 d = *receiverCenter - tree_->node(clusterIndex(s)).centroid;
        double len = glm::length(d);
        return double(l.K) * (len > 0 ? directionalB(s, d / len) : B_[s]);
    }
    return double(l.K) * B_[s];
}

void Hierarchy::gather() {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, numElements(), 256), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) gatherRow(r);
    });
}

std::vector<RGB> Hierarchy::clusterDown() const {
    // Irradiance that clusters hand down to their descendants (radiosity
    // units, before a patch's reflectance): the isotropic part gathered by a
    // cluster and its ancestors. Pre-order: parents before children.
    const uint32_t np = numPatches(), nc = numClusters_;
    std::vector<RGB> down(nc, RGB(0.0));
    for (uint32_t c = 0; c < nc; ++c) {
        uint32_t parent = parent_[np + c];
        down[c] = gathered_[np + c] + (parent == kNone ? RGB(0.0) : down[parent - np]);
    }
    return down;
}

struct Hierarchy::LazyView {
    bool made = false;
    cluster::SurfaceOpenness::View view;
};

template <class F>
void Hierarchy::forEachShare(uint32_t c, uint32_t root, LazyView& lv, F&& f) const {
    // With the openness table each surface takes its share by cosine and by
    // how open it is towards the sender within the receiving cluster
    // (cluster/openness.h).
    const glm::vec3 n(scene_->patches[root].normal);
    bool haveInside = false;
    cluster::SurfaceOpenness::Inside inside;
    for (uint64_t i = linkOffsets_[c]; i < linkOffsets_[c + 1]; ++i) {
        const glm::vec3& dir = clusterLinkDir_[i - clusterLinkBase_];
        double cosine = glm::dot(n, dir);
        if (!(cosine > 0)) continue;
        if (openness_ && (links_[i].flags & Link::kOpenHandOver)) {
            if (!lv.made) {
                lv.view = openness_->view(root);
                lv.made = true;
            }
            if (!haveInside) {
                const cluster::ClusterNode& node = tree_->node(clusterIndex(c));
                inside = openness_->inside(lv.view, node.centroid, node.radius);
                haveInside = true;
            }
            cosine *= openness_->openness(lv.view, inside, Vec3(dir), cosine);
            if (!(cosine > 0)) continue;
        }
        f(i, cosine);
    }
    // Stand-ins handed over by what each surface sees of the sender.
    if (!seenOffsets_.empty()) {
        const uint32_t ci = clusterIndex(c);
        const cluster::ClusterNode& node = tree_->node(ci);
        for (uint64_t e = seenOffsets_[ci]; e < seenOffsets_[ci + 1]; ++e) {
            const SeenEntry& s = seen_[e];
            const uint8_t b = seenWeights_[s.weights + (orderPos_[root] - node.patchBegin)];
            if (b) f(s.link, double(b) * double(s.scale));
        }
    }
}

RGB Hierarchy::clusterIrradianceAt(uint32_t root, const std::vector<RGB>& down,
                                   const glm::vec3* sent) const {
    const uint32_t np = numPatches();
    const scene::Patch& P = scene_->patches[root];
    // A patch the tree leaves out (hr.reach_rays) has no cluster above it.
    if (parent_[root] == kNone) return RGB(0.0);
    RGB h = down[parent_[root] - np];
    if (model_ == cluster::ClusterModel::Oriented) {
        // Each link into an ancestor cluster lights this patch with its own
        // cosine (Smits et al. 1994); what the link sends is K times the
        // sender's radiosity towards the receiving cluster (`sent`, or
        // evaluated here when it is null).
        LazyView view;
        for (uint32_t c = parent_[root]; c != kNone; c = parent_[c])
            forEachShare(c, root, view, [&](uint64_t i, double w) {
                h += w * (sent ? RGB(sent[i - clusterLinkBase_])
                               : linkSent(i, clusterLinkDir_[i - clusterLinkBase_]));
            });
    }
    return P.rho * h;
}

void Hierarchy::linkLight(std::vector<RGB>& reflected, const std::vector<float>* relError,
                          std::vector<RGB>* patchVariance) const {
    const uint32_t np = numPatches(), nc = numClusters_;
    reflected.assign(links_.size(), RGB(0.0));
    if (patchVariance) patchVariance->assign(np, RGB(0.0));
    auto rel = [&](uint64_t i) { return relError ? double((*relError)[i]) : 0.0; };
    const bool oriented = model_ == cluster::ClusterModel::Oriented && nc > 0;
    // Surface receivers: A_r rho_r times what the link sends (gatherRow).
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, numElements(), 256), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) {
            if (patch_[r] == kNone || linkBegin(r) == linkEnd(r)) continue;
            const RGB ar = area_[r] * scene_->patches[patch_[r]].rho;
            const Vec3 cr = oriented ? center(r) : Vec3(0.0);
            for (uint64_t i = linkBegin(r); i < linkEnd(r); ++i)
                reflected[i] = ar * rowSent(i, oriented ? &cr : nullptr);
        }
    });
    if (patchVariance)
        for (uint32_t r = 0; r < numElements(); ++r) {
            if (patch_[r] == kNone) continue;
            const double ap = scene_->patches[patch_[r]].area;
            for (uint64_t i = linkBegin(r); i < linkEnd(r); ++i) {
                const RGB d = reflected[i] * (rel(i) / ap);
                (*patchVariance)[patch_[r]] += d * d;
            }
        }
    if (nc == 0) return;
    // Links gathered as irradiance and handed down by area (gathered_,
    // clusterDown): every link of an isotropic cluster, stand-ins by area
    // of an oriented one. Per cluster, the variance of what they send.
    auto byArea = [&](const Link& l) { return !oriented || (l.byArea() && !l.bySeen()); };
    std::vector<RGB> isoVar(nc, RGB(0.0));
    std::vector<RGB> sent(oriented ? linkOffsets_[np + nc] - clusterLinkBase_ : 0);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nc, 16), [&](const auto& range) {
        for (uint32_t c = range.begin(); c != range.end(); ++c)
            for (uint64_t i = linkBegin(np + c); i < linkEnd(np + c); ++i) {
                if (byArea(links_[i])) {
                    const RGB s = rowSent(i, nullptr);
                    // sum_k A_k rho_k over the surfaces below.
                    reflected[i] = s * (tree_->node(c).area * tree_->node(c).rho);
                    isoVar[c] += (s * rel(i)) * (s * rel(i));
                } else {
                    sent[i - clusterLinkBase_] = linkSent(i, clusterLinkDir_[i - clusterLinkBase_]);
                }
            }
    });
    if (oriented) {
        // The others: sum over the surfaces below of A_k rho_k w_k, per link
        // (each cluster's row summed by one thread, in a fixed order).
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nc, 1), [&](const auto& range) {
            for (uint32_t c = range.begin(); c != range.end(); ++c) {
                if (linkBegin(np + c) == linkEnd(np + c)) continue;
                const cluster::ClusterNode& node = tree_->node(c);
                for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
                    const uint32_t root = tree_->patchAt(q);
                    const scene::Patch& P = scene_->patches[root];
                    LazyView view;
                    forEachShare(np + c, root, view, [&](uint64_t i, double w) {
                        reflected[i] += (P.area * w) * (P.rho * sent[i - clusterLinkBase_]);
                    });
                }
            }
        });
    }
    if (!patchVariance) return;
    // Down the tree: the by-area variance of a cluster and its ancestors.
    for (uint32_t c = 0; c < nc; ++c) {
        const uint32_t parent = parent_[np + c];
        if (parent != kNone) isoVar[c] += isoVar[parent - np];
    }
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, np, 64), [&](const auto& range) {
        for (uint32_t root = range.begin(); root != range.end(); ++root) {
            if (parent_[root] == kNone) continue;
            RGB v = isoVar[parent_[root] - np];
            if (oriented) {
                LazyView view;
                for (uint32_t c = parent_[root]; c != kNone; c = parent_[c])
                    forEachShare(c, root, view, [&](uint64_t i, double w) {
                        const RGB d = sent[i - clusterLinkBase_] * (w * rel(i));
                        v += d * d;
                    });
            }
            const RGB& rho = scene_->patches[root].rho;
            (*patchVariance)[root] += rho * rho * v;
        }
    });
}

std::vector<RGB> Hierarchy::clusterIrradianceToRoots() const {
    uint32_t np = numPatches();
    uint32_t nc = numClusters_;
    std::vector<RGB> fromAbove;
    if (!nc) return fromAbove;
    std::vector<RGB> down = clusterDown();
    // What each link into a cluster sends, K times the sender's radiosity
    // towards that cluster, once per link rather than once per patch below
    // it (directionalB evaluates the sender's radiant moments).
    std::vector<glm::vec3> sent;
    if (model_ == cluster::ClusterModel::Oriented) {
        sent.resize(clusterLinkDir_.size());
        tbb::parallel_for(tbb::blocked_range<uint32_t>(np, np + nc, 16), [&](const auto& range) {
            for (uint32_t c = range.begin(); c != range.end(); ++c)
                for (uint64_t i = linkOffsets_[c]; i < linkOffsets_[c + 1]; ++i)
                    // The sender sends what its surfaces facing this cluster
                    // carry (directionalB), as in gather(): with the mean B a
                    // sender cluster holding an emitter and surfaces facing
                    // elsewhere would send its average.
                    sent[i - clusterLinkBase_] =
                        glm::vec3(linkSent(i, clusterLinkDir_[i - clusterLinkBase_]));
        });
    }
    // Computed for all patches before any B is overwritten: a link into an
    // ancestor cluster may come from a surface element of another root patch,
    // whose B the push-pull rewrites (reading it there made the result depend
    // on thread timing).
    fromAbove.resize(np);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, np, 64), [&](const auto& range) {
        for (uint32_t root = range.begin(); root != range.end(); ++root)
            fromAbove[root] = clusterIrradianceAt(root, down, sent.empty() ? nullptr : sent.data());
    });
    return fromAbove;
}

void Hierarchy::pushPullRoot(uint32_t root, const RGB& fromAbove, std::vector<PushFrame>& stack) {
    // Iterative depth-first traversal: push the accumulated gathered
    // radiosity down, set leaves, pull averages up on the way back.
    const RGB& E = scene_->patches[root].emission;
    stack.clear();
    stack.push_back({root, gathered_[root] + fromAbove, 0});
    while (!stack.empty()) {
        PushFrame& f = stack.back();
        uint32_t fc = firstChild_[f.e];
        if (fc == kNone) {
            B_[f.e] = E + f.down;
            stack.pop_back();
            continue;
        }
        if (f.next < 4) {
            uint32_t c = fc + uint32_t(f.next++);
            RGB down = f.down + gathered_[c];
            stack.push_back({c, down, 0});
            continue;
        }
        // Pull: area-weighted average of the children.
        RGB sum(0.0);
        double a = 0.0;
        for (uint32_t c = fc; c < fc + 4; ++c) {
            sum += area_[c] * B_[c];
            a += area_[c];
        }
        B_[f.e] = sum / a;
        stack.pop_back();
    }
}

void Hierarchy::pushPull() {
    const uint32_t np = numPatches();
    std::vector<RGB> fromAbove = clusterIrradianceToRoots();
    if (nb_ > 1) {
        if (fromAbove.empty()) fromAbove.assign(np, RGB(0.0));
        pushPullPolynomial(fromAbove);
        if (numClusters_) pullClusters();
        return;
    }
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, np, 16), [&](const auto& range) {
        std::vector<PushFrame> stack;
        for (uint32_t root = range.begin(); root != range.end(); ++root)
            pushPullRoot(root, fromAbove.empty() ? RGB(0.0) : fromAbove[root], stack);
    });
    // Pull through the clusters, children before parents.
    if (numClusters_) pullClusters();
}

void Hierarchy::sweep(int blocks, double* gatherSeconds, double* pushPullSeconds) {
    HRAD_CHECK(nb_ == 1);  // HrSettings refuses gauss-seidel with a polynomial basis
    const uint32_t np = numPatches(), nc = numClusters_;
    double tg = 0.0, tp = 0.0;
    Timer t;
    // Cluster rows gather from the radiosities of the previous sweep.
    tbb::parallel_for(tbb::blocked_range<uint32_t>(np, np + nc, 64), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) gatherRow(r);
    });
    tg += t.seconds();
    t.reset();
    std::vector<RGB> fromAbove = clusterIrradianceToRoots();
    tp += t.seconds();
    const uint32_t nb = uint32_t(std::clamp<int64_t>(blocks, 1, std::max<uint32_t>(np, 1)));
    std::vector<uint32_t> rows, stack;
    for (uint32_t b = 0; b < nb; ++b) {
        const uint32_t lo = uint32_t(uint64_t(np) * b / nb),
                       hi = uint32_t(uint64_t(np) * (b + 1) / nb);
        t.reset();
        // The rows of this block: every element below its root patches.
        rows.clear();
        for (uint32_t root = lo; root < hi; ++root) {
            stack.assign(1, root);
            while (!stack.empty()) {
                uint32_t e = stack.back();
                stack.pop_back();
                rows.push_back(e);
                if (firstChild_[e] != kNone)
                    for (uint32_t c = 0; c < 4; ++c) stack.push_back(firstChild_[e] + c);
            }
        }
        tbb::parallel_for(tbb::blocked_range<size_t>(0, rows.size(), 256), [&](const auto& range) {
            for (size_t i = range.begin(); i != range.end(); ++i) gatherRow(rows[i]);
        });
        tg += t.seconds();
        t.reset();
        tbb::parallel_for(tbb::blocked_range<uint32_t>(lo, hi, 16), [&](const auto& range) {
            std::vector<PushFrame> frames;
            for (uint32_t root = range.begin(); root != range.end(); ++root)
                pushPullRoot(root, fromAbove.empty() ? RGB(0.0) : fromAbove[root], frames);
        });
        tp += t.seconds();
    }
    t.reset();
    if (nc) pullClusters();
    tp += t.seconds();
    if (gatherSeconds) *gatherSeconds = tg;
    if (pushPullSeconds) *pushPullSeconds = tp;
}

uint64_t Hierarchy::iterationLinkReads() const {
    uint64_t reads = numLinks();
    if (model_ != cluster::ClusterModel::Oriented) return reads;
    const uint32_t np = numPatches();
    for (uint32_t c = 0; c < numClusters_; ++c) {
        const cluster::ClusterNode& node = tree_->node(c);
        reads += (linkEnd(np + c) - linkBegin(np + c)) * uint64_t(node.patchEnd - node.patchBegin);
    }
    return reads;
}

Hierarchy::RelaxResult Hierarchy::relax(const std::vector<uint32_t>& roots, int maxSweeps,
                                        uint64_t linkBudget, double target) {
    HRAD_CHECK(nb_ == 1);
    RelaxResult out;
    if (roots.empty() || maxSweeps <= 0) return out;
    const uint32_t np = numPatches();
    // The local system: the rows below each root, and the clusters above the
    // roots (ancestors), whose radiosities and moments the roots change and
    // whose links hand the roots irradiance.
    std::vector<uint32_t> rows, rowBegin, stack, ancestors;
    uint64_t linksPerSweep = 0;
    for (uint32_t root : roots) {
        rowBegin.push_back(uint32_t(rows.size()));
        stack.assign(1, root);
        while (!stack.empty()) {
            uint32_t e = stack.back();
            stack.pop_back();
            rows.push_back(e);
            linksPerSweep += linkEnd(e) - linkBegin(e);
            if (firstChild_[e] != kNone)
                for (uint32_t c = 0; c < 4; ++c) stack.push_back(firstChild_[e] + c);
        }
        for (uint32_t c = parent_[root]; c != kNone; c = parent_[c]) ancestors.push_back(c);
    }
    rowBegin.push_back(uint32_t(rows.size()));
    std::sort(ancestors.begin(), ancestors.end());
    ancestors.erase(std::unique(ancestors.begin(), ancestors.end()), ancestors.end());
    const bool isotropic = model_ == cluster::ClusterModel::Isotropic;
    if (isotropic)
        for (uint32_t c : ancestors) linksPerSweep += linkEnd(c) - linkBegin(c);
    else
        for (uint32_t root : roots)  // oriented: every link into an ancestor, per root
            for (uint32_t c = parent_[root]; c != kNone; c = parent_[c])
                linksPerSweep += linkEnd(c) - linkBegin(c);
    std::vector<RGB> down = numClusters_ ? clusterDown() : std::vector<RGB>();
    std::vector<RGB> fromAbove(roots.size(), RGB(0.0));
    std::vector<PushFrame> frames;
    double c1 = 0.0, c2 = 0.0;  // the changes of the last two sweeps
    while (out.sweeps < maxSweeps && out.linkReads + linksPerSweep <= linkBudget) {
        if (!ancestors.empty()) {
            // Clusters above the roots: pull (children first: pre-order
            // indices, so backwards), gather (isotropic clusters gather as a
            // whole), hand down (parents first).
            for (size_t i = ancestors.size(); i-- > 0;) pullCluster(ancestors[i] - np);
            // Isotropic clusters gather as a whole; oriented ones gather
            // only their stand-ins (gatherRow), handed down the same way.
            if (isotropic || hasStandIns_) {
                for (uint32_t c : ancestors) gatherRow(c);
                for (uint32_t c : ancestors) {
                    uint32_t parent = parent_[c];
                    down[c - np] = gathered_[c] + (parent == kNone ? RGB(0.0) : down[parent - np]);
                }
            }
            for (size_t k = 0; k < roots.size(); ++k)
                fromAbove[k] = clusterIrradianceAt(roots[k], down, nullptr);
        }
        // Gauss-Seidel over the roots: each gathers from the radiosities the
        // roots before it have just computed, then pushes and pulls.
        double change = 0.0;
        for (size_t k = 0; k < roots.size(); ++k) {
            for (uint32_t i = rowBegin[k]; i < rowBegin[k + 1]; ++i) gatherRow(rows[i]);
            const RGB before = B_[roots[k]];
            pushPullRoot(roots[k], fromAbove[k], frames);
            change += area_[roots[k]] * maxComponent(glm::abs(B_[roots[k]] - before));
        }
        ++out.sweeps;
        out.linkReads += linksPerSweep;
        // The change still to come: a geometric tail with the rate over two
        // sweeps (a pair of facing surfaces alternates within one).
        bool done = change == 0.0;
        if (out.sweeps >= 3 && c2 > 0.0) {
            double q = std::sqrt(change / c2);
            done = done || (q < 1.0 && change * q / (1.0 - q) < target);
        }
        c2 = c1;
        c1 = change;
        if (done) {
            out.reached = true;
            break;
        }
    }
    if (numClusters_) pullClusters();
    return out;
}

void Hierarchy::pushPullPolynomial(const std::vector<RGB>& fromAbove) {
    // As the constant traversal, with coefficient vectors: a child receives
    // its parent's accumulated gathered polynomial restricted to it (exact
    // push: down_child_j = sum_a T_c[a][j] down_parent_a) plus its own; a leaf
    // is E (constant: the c_0 term) plus that; a parent is the projection of
    // its children (pullPolynomial). Clusters add to c_0 only.
    const uint32_t np = numPatches();
    const size_t m = size_t(nb_ - 1);
    using Coeffs = std::array<RGB, scene::kMaxBasisSize>;
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, np, 16), [&](const auto& range) {
        struct Frame {
            uint32_t e;
            Coeffs down;
            int next;
        };
        std::vector<Frame> stack;
        for (uint32_t root = range.begin(); root != range.end(); ++root) {
            const scene::Patch& P = scene_->patches[root];
            const scene::Basis& basis = basis_->of(P.kind);
            const RGB& E = P.emission;
            stack.clear();
            Frame f0{root, {}, 0};
            f0.down[0] = gathered_[root] + fromAbove[root];
            for (size_t a = 1; a <= m; ++a) f0.down[a] = gatheredHi_[size_t(root) * m + a - 1];
            stack.push_back(f0);
            while (!stack.empty()) {
                Frame& f = stack.back();
                uint32_t fc = firstChild_[f.e];
                if (fc == kNone) {
                    B_[f.e] = E + f.down[0];
                    for (size_t a = 1; a <= m; ++a) hi_[size_t(f.e) * m + a - 1] = f.down[a];
                    stack.pop_back();
                    continue;
                }
                if (f.next < 4) {
                    int ci = f.next++;
                    uint32_t c = fc + uint32_t(ci);
                    const auto& T = basis.twoScale(ci);
                    Frame g{c, {}, 0};
                    for (int j = 0; j < nb_; ++j) {
                        RGB v = j == 0 ? gathered_[c] : gatheredHi_[size_t(c) * m + size_t(j - 1)];
                        for (int a = 0; a < nb_; ++a)
                            v += T[size_t(a * nb_ + j)] * f.down[size_t(a)];
                        g.down[size_t(j)] = v;
                    }
                    stack.push_back(g);  // f is invalidated here
                    continue;
                }
                pullPolynomial(f.e);
                stack.pop_back();
            }
        }
    });
}

void Hierarchy::pullPolynomial(uint32_t e) {
    // L2 projection of the children's polynomials onto the parent's:
    // parent_a = 1/4 sum_c sum_j T_c[a][j] child_j (each child covers a
    // quarter of the parent's parametric domain).
    const size_t m = size_t(nb_ - 1);
    const uint32_t fc = firstChild_[e];
    const scene::Basis& basis = basis_->of(scene_->patches[patch_[e]].kind);
    std::array<RGB, scene::kMaxBasisSize> out{};
    for (int c = 0; c < 4; ++c) {
        const auto& T = basis.twoScale(c);
        uint32_t ch = fc + uint32_t(c);
        for (int a = 0; a < nb_; ++a) {
            RGB v = T[size_t(a * nb_)] * B_[ch];
            for (int j = 1; j < nb_; ++j)
                v += T[size_t(a * nb_ + j)] * hi_[size_t(ch) * m + size_t(j - 1)];
            out[size_t(a)] += 0.25 * v;
        }
    }
    B_[e] = out[0];
    for (size_t a = 1; a <= m; ++a) hi_[size_t(e) * m + a - 1] = out[a];
}

void Hierarchy::extrapolateLeaves(const std::vector<RGB>& previous,
                                  const std::vector<RGB>& previousHi, const RGB& factor) {
    if (nb_ == 1) {
        extrapolateLeaves(previous, factor);
        return;
    }
    HRAD_CHECK(previous.size() == B_.size() && previousHi.size() == hi_.size());
    const uint32_t n = numElements(), np = numPatches(), first = np + numClusters_;
    const size_t m = size_t(nb_ - 1);
    for (uint32_t e = 0; e < n; ++e) {
        if (!isLeaf(e)) continue;
        B_[e] += factor * (B_[e] - previous[e]);
        for (size_t a = 0; a < m; ++a)
            hi_[size_t(e) * m + a] +=
                factor * (hi_[size_t(e) * m + a] - previousHi[size_t(e) * m + a]);
    }
    for (uint32_t e = n; e-- > first;)
        if (firstChild_[e] != kNone) pullPolynomial(e);
    for (uint32_t e = 0; e < np; ++e)
        if (firstChild_[e] != kNone) pullPolynomial(e);
    if (numClusters_) pullClusters();
}

void Hierarchy::extrapolateLeaves(const std::vector<RGB>& previous, const RGB& factor) {
    HRAD_CHECK(previous.size() == B_.size());
    const uint32_t n = numElements(), np = numPatches(), first = np + numClusters_;
    for (uint32_t e = 0; e < n; ++e)
        if (isLeaf(e)) B_[e] += factor * (B_[e] - previous[e]);
    // Pull: sub-elements are allocated after their parents, so a descending
    // sweep sees children before parents; root patches last.
    auto pullOne = [&](uint32_t e) {
        uint32_t fc = firstChild_[e];
        if (fc == kNone) return;
        RGB sum(0.0);
        double a = 0.0;
        for (uint32_t c = fc; c < fc + 4; ++c) {
            sum += area_[c] * B_[c];
            a += area_[c];
        }
        B_[e] = sum / a;
    };
    for (uint32_t e = n; e-- > first;) pullOne(e);
    for (uint32_t e = 0; e < np; ++e) pullOne(e);
    if (numClusters_) pullClusters();
}

RGB Hierarchy::reflectedPower() const {
    RGB s(0.0);
    for (uint32_t e = 0; e < numElements(); ++e)
        if (isLeaf(e)) s += area_[e] * (B_[e] - scene_->patches[patch_[e]].emission);
    return s;
}

RGB Hierarchy::radiosityPower() const {
    RGB s(0.0);
    for (uint32_t e = 0; e < numElements(); ++e)
        if (isLeaf(e)) s += area_[e] * B_[e];
    return s;
}

uint64_t Hierarchy::elementBytes() const {
    return patch_.capacity() * sizeof(uint32_t) + key_.capacity() * sizeof(ElementKey) +
           parent_.capacity() * sizeof(uint32_t) + firstChild_.capacity() * sizeof(uint32_t) +
           area_.capacity() * sizeof(double) + B_.capacity() * sizeof(RGB) +
           gathered_.capacity() * sizeof(RGB) + hi_.capacity() * sizeof(RGB) +
           gatheredHi_.capacity() * sizeof(RGB);
}

uint64_t Hierarchy::linkBytes() const {
    return links_.capacity() * sizeof(Link) + linkOffsets_.capacity() * sizeof(uint32_t) +
           clusterLinkDir_.capacity() * sizeof(glm::vec3) +
           samples_.capacity() * sizeof(KernelSamples) +
           standInBegin_.capacity() * sizeof(uint64_t) +
           standInSamples_.capacity() * sizeof(cluster::StandInSample) +
           couplingIndex_.capacity() * sizeof(uint32_t) + couplingData_.capacity() * sizeof(float);
}

void Hierarchy::reportMemory(MemoryCounters& m) const {
    m.set("elements", elementBytes());
    m.set("links", links_.capacity() * sizeof(Link));
    m.set("link_offsets", linkOffsets_.capacity() * sizeof(uint32_t));
    if (!couplingIndex_.empty())
        m.set("link_coupling", couplingIndex_.capacity() * sizeof(uint32_t) +
                                   couplingData_.capacity() * sizeof(float));
    if (!samples_.empty())
        m.set("link_kernel_samples", samples_.capacity() * sizeof(KernelSamples));
    if (standInSamples_.size() > 0)
        m.set("stand_in_samples", standInBegin_.capacity() * sizeof(uint64_t) +
                                      standInSamples_.capacity() * sizeof(cluster::StandInSample));
    if (!clusterLinkDir_.empty())
        m.set("cluster_link_directions", clusterLinkDir_.capacity() * sizeof(glm::vec3));
    if (!seen_.empty())
        m.set("stand_in_handover", seen_.capacity() * sizeof(SeenEntry) +
                                       seenOffsets_.capacity() * sizeof(uint64_t) +
                                       seenWeights_.capacity() + orderPos_.capacity() * 4 +
                                       seenCache_.size() * (2 * sizeof(uint64_t) + sizeof(void*)) +
                                       seenCache_.bucket_count() * sizeof(void*));
    if (tree_)
        m.set("clusters", tree_->memoryBytes() + moments_.capacity() * sizeof(RadiantMoments) +
                              maxB_.capacity() * sizeof(RGB));
}

// ---- field view ---------------------------------------------------------------

RGB HierarchyField::at(uint32_t patch, double u, double v) const {
    const scene::Patch& p = h_->scene().patches[patch];
    uint32_t e = patch;
    scene::Domain d;
    while (!h_->isLeaf(e)) {
        int c = scene::childContaining(p.kind, d, u, v);
        d = scene::childDomain(p.kind, d, c);
        e = h_->firstChild(e) + uint32_t(c);
    }
    if (h_->basisSize() == 1) return h_->B(e);
    // The leaf's polynomial at the local coordinates of (u, v).
    return h_->evaluate(e, (u - d.u0) / d.h, (v - d.v0) / d.h);
}

RGB HierarchyField::average(uint32_t patch, ElementKey key) const {
    uint32_t e = patch;
    int L = scene::keyLevel(key);
    int l = 0;
    for (; l < L && !h_->isLeaf(e); ++l)
        e = h_->firstChild(e) + uint32_t(scene::keyChildAt(key, l));
    // Either the node at `key` (whose B is the exact area average of its
    // leaves after push-pull) or a leaf containing the whole region.
    if (h_->basisSize() == 1 || l == L) return h_->B(e);
    // A region inside a polynomial leaf: the mean of the leaf's polynomial
    // over it.
    std::array<RGB, scene::kMaxBasisSize> c{};
    c[0] = h_->B(e);
    for (int a = 1; a < h_->basisSize(); ++a) c[size_t(a)] = h_->hi(e)[a - 1];
    return scene::meanOverSubElement(h_->basis()->of(h_->scene().patches[patch].kind), c,
                                     h_->key(e), key);
}

uint32_t HierarchyField::elementAt(uint32_t patch, ElementKey key) const {
    uint32_t e = patch;
    int L = scene::keyLevel(key);
    for (int l = 0; l < L && !h_->isLeaf(e); ++l)
        e = h_->firstChild(e) + uint32_t(scene::keyChildAt(key, l));
    HRAD_CHECK(h_->key(e) == key);
    return e;
}

RGB HierarchyField::leafPoint(uint32_t patch, ElementKey key, const RGB& leafValue, double a,
                              double b) const {
    if (h_->basisSize() == 1) return leafValue;
    return h_->evaluate(elementAt(patch, key), a, b);
}

int HierarchyField::basisDegree() const { return h_->basisSize() == 1 ? 0 : h_->basis()->degree(); }

void HierarchyField::leafHigherCoefficients(uint32_t patch, ElementKey key, RGB* out) const {
    if (h_->basisSize() == 1) return;
    const RGB* hi = h_->hi(elementAt(patch, key));
    std::copy(hi, hi + (h_->basisSize() - 1), out);
}

void HierarchyField::forEachLeaf(uint32_t patch,
                                 const std::function<void(ElementKey, const RGB&)>& fn) const {
    std::vector<uint32_t> stack{patch};
    while (!stack.empty()) {
        uint32_t e = stack.back();
        stack.pop_back();
        if (h_->isLeaf(e)) {
            fn(h_->key(e), h_->B(e));
            continue;
        }
        for (int c = 3; c >= 0; --c) stack.push_back(h_->firstChild(e) + uint32_t(c));
    }
}

}  // namespace hrad::hr
