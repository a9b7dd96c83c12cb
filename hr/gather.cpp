// Gather and push-pull over the hierarchy (constant and polynomial bases),
// and the light each link brings (DESIGN.md "Gather", "Push-pull"; Hanrahan,
// Salzman & Aupperle 1991; clusters: Smits, Arvo & Greenberg 1994, Sillion 1995).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>

#include "core/error.h"
#include "core/timer.h"
#include "hr/handover.h"
#include "hr/hierarchy.h"

namespace hrad::hr {

void Hierarchy::gatherRow(uint32_t r) {
    const bool oriented = transfer_->receivesByCosine() && numClusters_ > 0;
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
        gathered_[r] = sum;
        return;
    }
    // Elements of textured patches (hr.texture_rho = element) gather
    // irradiance: each leaf applies its own rho in push-pull.
    const RGB rho = gatherReflectance(r);
    gathered_[r] = rho * sum + (r < lightGathered.size() ? lightGathered[r] : RGB(0.0));
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

template <class F>
void Hierarchy::forEachShare(uint32_t c, uint32_t root, F&& f) const {
    // Each surface takes its share by its cosine towards the sender; links
    // the hand-over flagged take what it gives (openShares, asked for in
    // batches, one virtual call per batch), in link order.
    constexpr size_t kBatch = 64;
    const glm::vec3 n(scene_->patches[root].normal);
    uint64_t link[kBatch];
    double w[kBatch];
    bool open[kBatch];
    glm::vec3 openDir[kBatch];
    double openW[kBatch];
    auto flush = [&](size_t count, size_t opened) {
        if (opened) handOver_->openShares(c, root, {openDir, opened}, {openW, opened});
        for (size_t b = 0, o = 0; b < count; ++b) {
            if (open[b] && !((w[b] = openW[o++]) > 0)) continue;
            f(link[b], w[b]);
        }
    };
    size_t count = 0, opened = 0;
    for (uint64_t i = linkOffsets_[c]; i < linkOffsets_[c + 1]; ++i) {
        const glm::vec3& dir = clusterLinkDir_[i - clusterLinkBase_];
        const double cosine = glm::dot(n, dir);
        if (!(cosine > 0)) continue;
        link[count] = i;
        w[count] = cosine;
        open[count] = (links_[i].flags & Link::kOpenHandOver) != 0;
        if (open[count]) {
            openDir[opened] = dir;
            openW[opened++] = cosine;
        }
        if (++count == kBatch) {
            flush(count, opened);
            count = opened = 0;
        }
    }
    flush(count, opened);
    // Stand-ins the hand-over gives each surface a share of.
    handOver_->forEachSurfaceShare(c, root, f);
}

RGB Hierarchy::clusterIrradianceAt(uint32_t root, const std::vector<RGB>& down,
                                   const glm::vec3* sent) const {
    const uint32_t np = numPatches();
    // A patch the tree leaves out (hr.reach_rays) has no cluster above it.
    if (parent_[root] == kNone) return RGB(0.0);
    RGB h = down[parent_[root] - np];
    if (transfer_->receivesByCosine()) {
        // Each link into an ancestor cluster lights this patch with its own
        // cosine (Smits et al. 1994); what the link sends is K times the
        // sender's radiosity towards the receiving cluster (`sent`, or
        // evaluated here when it is null).
        for (uint32_t c = parent_[root]; c != kNone; c = parent_[c])
            forEachShare(c, root, [&](uint64_t i, double w) {
                h += w * (sent ? RGB(sent[i - clusterLinkBase_])
                               : linkSent(i, clusterLinkDir_[i - clusterLinkBase_]));
            });
    }
    return gatherReflectance(root) * h;
}

std::vector<RGB> Hierarchy::textureReflectingExcess(const std::vector<RGB>& rootReflecting) const {
    std::vector<RGB> excess;
    if (!elementRho_ || !tree_) return excess;
    excess.assign(numClusters_, RGB(0.0));
    for (uint32_t c = 0; c < numClusters_; ++c) {
        const cluster::ClusterNode& node = tree_->node(c);
        for (uint32_t q = node.patchBegin; q < node.patchEnd; ++q) {
            const uint32_t root = tree_->patchAt(q);
            if (pushesIrradiance(root))
                excess[c] += rootReflecting[root] - area_[root] * scene_->patches[root].rho;
        }
    }
    return excess;
}

void Hierarchy::linkLight(std::vector<RGB>& reflected, const std::vector<float>* relError,
                          std::vector<RGB>* patchVariance) const {
    const uint32_t np = numPatches(), nc = numClusters_;
    reflected.assign(links_.size(), RGB(0.0));
    if (patchVariance) patchVariance->assign(np, RGB(0.0));
    auto rel = [&](uint64_t i) { return relError ? double((*relError)[i]) : 0.0; };
    const bool oriented = transfer_->receivesByCosine() && nc > 0;
    // Surface receivers: A_r rho_r times what the link sends (gatherRow).
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, numElements(), 256), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) {
            if (patch_[r] == kNone || linkBegin(r) == linkEnd(r)) continue;
            const RGB ar = reflectingArea(r);
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
    // Per cluster, what its textured patches' leaves reflect beyond the
    // tree's sum A_k rho_k of patch means (hr.texture_rho = element).
    // Per textured root patch, reflectingArea once (not once per link share).
    std::vector<RGB> rootReflecting;
    if (elementRho_) {
        rootReflecting.assign(np, RGB(0.0));
        for (uint32_t root = 0; root < np; ++root)
            if (pushesIrradiance(root)) rootReflecting[root] = reflectingArea(root);
    }
    std::vector<RGB> leafExcess = textureReflectingExcess(rootReflecting);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, nc, 16), [&](const auto& range) {
        for (uint32_t c = range.begin(); c != range.end(); ++c)
            for (uint64_t i = linkBegin(np + c); i < linkEnd(np + c); ++i) {
                if (byArea(links_[i])) {
                    const RGB s = rowSent(i, nullptr);
                    // sum_k A_k rho_k over the surfaces below.
                    reflected[i] = s * (tree_->node(c).area * tree_->node(c).rho);
                    if (!leafExcess.empty()) reflected[i] += s * leafExcess[c];
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
                    forEachShare(np + c, root, [&](uint64_t i, double w) {
                        reflected[i] += pushesIrradiance(root)
                                            ? w * (rootReflecting[root] * sent[i - clusterLinkBase_])
                                            : (P.area * w) * (P.rho * sent[i - clusterLinkBase_]);
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
                for (uint32_t c = parent_[root]; c != kNone; c = parent_[c])
                    forEachShare(c, root, [&](uint64_t i, double w) {
                        const RGB d = sent[i - clusterLinkBase_] * (w * rel(i));
                        v += d * d;
                    });
            }
            const RGB rho = pushesIrradiance(root) ? rootReflecting[root] / area_[root]
                                                   : scene_->patches[root].rho;
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
    if (transfer_->receivesByCosine()) {
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
    const bool irradiance = pushesIrradiance(root);
    stack.clear();
    stack.push_back({root, gathered_[root] + fromAbove, 0});
    while (!stack.empty()) {
        PushFrame& f = stack.back();
        uint32_t fc = firstChild_[f.e];
        if (fc == kNone) {
            // Textured (hr.texture_rho = element): `down` is irradiance.
            B_[f.e] = irradiance ? E + rho(f.e) * f.down : E + f.down;
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
    if (!transfer_->receivesByCosine()) return reads;
    const uint32_t np = numPatches();
    for (uint32_t c = 0; c < numClusters_; ++c) {
        const cluster::ClusterNode& node = tree_->node(c);
        reads += (linkEnd(np + c) - linkBegin(np + c)) * uint64_t(node.patchEnd - node.patchBegin);
    }
    return reads;
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
            const bool irradiance = pushesIrradiance(root);
            stack.clear();
            Frame f0{root, {}, 0};
            f0.down[0] = gathered_[root] + fromAbove[root];
            for (size_t a = 1; a <= m; ++a) f0.down[a] = gatheredHi_[size_t(root) * m + a - 1];
            stack.push_back(f0);
            while (!stack.empty()) {
                Frame& f = stack.back();
                uint32_t fc = firstChild_[f.e];
                if (fc == kNone) {
                    // Textured (hr.texture_rho = element): `down` is irradiance.
                    const RGB rho = irradiance ? this->rho(f.e) : RGB(1.0);
                    B_[f.e] = irradiance ? E + rho * f.down[0] : E + f.down[0];
                    for (size_t a = 1; a <= m; ++a)
                        hi_[size_t(f.e) * m + a - 1] = irradiance ? rho * f.down[a] : f.down[a];
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

}  // namespace hrad::hr
