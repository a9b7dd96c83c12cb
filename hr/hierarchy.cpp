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
#include "hr/element_rho.h"
#include "hr/handover.h"
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
    : scene_(&scene), tree_(tree), handOver_(makeHandOver("none", {})), model_(model) {
    HRAD_CHECK(basisDegree >= 0 && basisDegree <= scene::kMaxBasisDegree);
    if (basisDegree > 0) {
        basis_ = std::make_unique<scene::BasisSet>(basisDegree);
        nb_ = basis_->size();
    }
    if (!cluster::transferModel(model_).hasClusters()) tree_ = nullptr;
    if (!tree_) model_ = cluster::ClusterModel::None;
    transfer_ = &cluster::transferModel(model_);
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
    const bool oriented = transfer_->sendsByDirection();
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
    if (transfer_->sendsByDirection()) moments_.assign(nc, RadiantMoments{});
    maxB_.resize(nc);
    // Children before parents (pre-order indices, so walk backwards).
    for (uint32_t c = nc; c-- > 0;) pullCluster(c);
}

RGB Hierarchy::directionalB(uint32_t e, const Vec3& d) const {
    if (!isCluster(e) || !transfer_->sendsByDirection()) return B_[e];
    const uint32_t c = clusterIndex(e);
    return transfer_->sent(*tree_, c, moments_[c], B_[e], d);
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
    if (e >= numPatches() && pushesIrradiance(e)) {
        const uint32_t fc = firstChild_[parent_[e]];
        return elementRho_->child(fc, e - fc);
    }
    return scene_->patches[patch_[e]].rho;
}

void Hierarchy::setElementRho(bool on) {
    HRAD_CHECK(numElements() == numPatches() + numClusters_);  // before any subdivision
    elementRho_.reset();
    if (!on) return;
    auto t = std::make_unique<ElementRho>(*scene_);
    if (t->any()) elementRho_ = std::move(t);
}

uint64_t Hierarchy::elementRhoBytes() const { return elementRho_ ? elementRho_->bytes() : 0; }

bool Hierarchy::pushesIrradiance(uint32_t e) const {
    return elementRho_ && patch_[e] != kNone && elementRho_->textured(patch_[e]);
}

RGB Hierarchy::gatherReflectance(uint32_t e) const {
    return pushesIrradiance(e) ? RGB(1.0) : scene_->patches[patch_[e]].rho;
}

RGB Hierarchy::reflectingArea(uint32_t e) const {
    if (!pushesIrradiance(e)) return area_[e] * scene_->patches[patch_[e]].rho;
    if (firstChild_[e] == kNone) return area_[e] * rho(e);
    RGB sum(0.0);
    for (uint32_t c = firstChild_[e]; c < firstChild_[e] + 4; ++c) sum += reflectingArea(c);
    return sum;
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
    if (pushesIrradiance(e)) elementRho_->addChildren(first, p, d);
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

Hierarchy::~Hierarchy() = default;
Hierarchy::Hierarchy(Hierarchy&&) noexcept = default;
Hierarchy& Hierarchy::operator=(Hierarchy&&) noexcept = default;

void Hierarchy::setHandOver(std::unique_ptr<HandOver> handOver) {
    HRAD_CHECK(handOver);
    handOver_ = std::move(handOver);
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
    // The hand-over sees the links, their directions and the radiosities.
    HandOverLinks view;
    view.numPatches = numPatches();
    view.numClusters = numClusters_;
    view.offsets = linkOffsets_;
    view.links = links_;
    view.dirs = clusterLinkDir_;
    view.dirBase = clusterLinkBase_;
    view.patchOf = patch_;
    view.B = B_;
    view.hasStandIns = hasStandIns_;
    view.seed = seed_;
    handOver_->newLinks(view);
    handOver_->standIns(view);
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

void Hierarchy::compactStandIns() {
    // Blocks of stand-ins that refinement replaced are dropped; the others
    // are renumbered in link order.
    if (standInSamples_.empty()) return;
    std::vector<uint64_t> begin{0};
    std::vector<cluster::StandInSample> kept;
    for (Link& l : links_) {
        if (!(l.flags & Link::kStandIn) || !isCluster(l.sender)) continue;
        const uint32_t b = l.sampleBlock();
        HRAD_DCHECK(size_t(b) + 1 < standInBegin_.size());
        kept.insert(kept.end(), standInSamples_.begin() + ptrdiff_t(standInBegin_[b]),
                    standInSamples_.begin() + ptrdiff_t(standInBegin_[b + 1]));
        begin.push_back(kept.size());
        l.setSampleBlock(uint32_t(begin.size() - 2));
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
    const uint32_t block = l.sampleBlock();
    HRAD_DCHECK(size_t(block) + 1 < standInBegin_.size());
    RGB sum(0.0);
    for (uint64_t k = standInBegin_[block] + 1; k < standInBegin_[block + 1]; ++k)
        sum += double(standInSamples_[k].weight) * B_[standInSamples_[k].patch];
    return sum;
}

RGB Hierarchy::standInReflected(uint32_t r, uint64_t i) const {
    const Link& l = links_[i];
    const RGB sent = standInSent(l);
    if (!isCluster(r))
        return pushesIrradiance(r) ? sent * reflectingArea(r)
                                   : sent * area(r) * scene_->patches[patch_[r]].rho;
    if (l.bySeen())  // as the push hands it (clusterIrradianceAt)
        if (const std::optional<RGB> sum = handOver_->surfaceReflected(r, i)) return sent * *sum;
    Vec3 d = center(l.sender) - center(r);
    const double len = glm::length(d);
    const bool byCosine = !l.byArea() && transfer_->receivesByCosine() && len > 0;
    if (byCosine) d /= len;
    const glm::vec3 dir(d);
    RGB sum(0.0);
    const cluster::ClusterNode& node = tree_->node(clusterIndex(r));
    for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
        const uint32_t root = tree_->patchAt(q);
        const scene::Patch& P = scene_->patches[root];
        const double w = byCosine ? std::max(0.0, double(glm::dot(glm::vec3(P.normal), dir))) : 1.0;
        sum += pushesIrradiance(root) ? w * reflectingArea(root) : (P.area * w) * P.rho;
    }
    return sent * sum;
}

double Hierarchy::standInJudged(const Link& l) const {
    if (!isCluster(l.sender)) return l.judgedF();
    const uint32_t block = l.sampleBlock();
    HRAD_DCHECK(size_t(block) + 1 < standInBegin_.size());
    return standInSamples_[standInBegin_[block]].weight;
}

RGB Hierarchy::linkSent(uint64_t i, const glm::vec3& dir) const {
    const Link& l = links_[i];
    if (l.flags & Link::kStandIn) return standInSent(l);
    return double(l.K) * directionalB(l.sender, -Vec3(dir));
}

std::vector<uint32_t> Hierarchy::linkReceivers() const {
    std::vector<uint32_t> r(links_.size());
    for (uint32_t e = 0; e < numElements(); ++e)
        for (uint64_t i = linkBegin(e); i < linkEnd(e); ++i) r[i] = e;
    return r;
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
    if (elementRho_) m.set("element_rho", elementRhoBytes());
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
    handOver_->reportMemory(m);
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
