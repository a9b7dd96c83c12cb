#include "hr/hierarchy.h"

#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/rng.h"

namespace hrad::hr {

using scene::ElementKey;

Hierarchy::Hierarchy(const scene::Scene& scene) : scene_(&scene) {
    uint32_t n = uint32_t(scene.patches.size());
    patch_.resize(n);
    key_.assign(n, scene::kRootKey);
    parent_.assign(n, kNone);
    firstChild_.assign(n, kNone);
    area_.resize(n);
    B_.resize(n);
    gathered_.assign(n, RGB(0.0));
    for (uint32_t i = 0; i < n; ++i) {
        patch_[i] = i;
        area_[i] = scene.patches[i].area;
        B_[i] = scene.patches[i].emission;
    }
    linkOffsets_.assign(n + 1, 0);
}

scene::Domain Hierarchy::domain(uint32_t e) const {
    return scene::keyDomain(scene_->patches[patch_[e]].kind, key_[e]);
}

uint64_t Hierarchy::stableId(uint32_t e) const { return hashIds(patch_[e], key_[e]); }

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
}

uint32_t Hierarchy::numLeaves() const {
    uint32_t n = 0;
    for (uint32_t e = 0; e < numElements(); ++e) n += firstChild_[e] == kNone ? 1 : 0;
    return n;
}

void Hierarchy::setLinks(const std::vector<uint32_t>& receivers, std::vector<Link>&& links) {
    HRAD_CHECK(receivers.size() == links.size());
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
    for (size_t i = 0; i < links.size(); ++i) sorted[fill[receivers[i]]++] = links[i];
    links_ = std::move(sorted);
    links_.shrink_to_fit();
    links.clear();
    links.shrink_to_fit();
}

std::vector<uint32_t> Hierarchy::linkReceivers() const {
    std::vector<uint32_t> r(links_.size());
    for (uint32_t e = 0; e < numElements(); ++e)
        for (uint64_t i = linkBegin(e); i < linkEnd(e); ++i) r[i] = e;
    return r;
}

void Hierarchy::gather() {
    uint32_t n = numElements();
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 256), [&](const auto& range) {
        for (uint32_t r = range.begin(); r != range.end(); ++r) {
            RGB sum(0.0);
            // Fixed summation order within a row: results do not depend on
            // how the range is split between threads.
            for (uint64_t i = linkBegin(r); i < linkEnd(r); ++i)
                sum += double(links_[i].K) * B_[links_[i].sender];
            gathered_[r] = scene_->patches[patch_[r]].rho * sum;
        }
    });
}

void Hierarchy::pushPull() {
    uint32_t np = numPatches();
    // Iterative depth-first traversal per root patch: push the accumulated
    // gathered radiosity down, set leaves, pull averages up on the way back.
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, np, 16), [&](const auto& range) {
        struct Frame {
            uint32_t e;
            RGB down;
            int next;  // next child to visit (0..4)
        };
        std::vector<Frame> stack;
        for (uint32_t root = range.begin(); root != range.end(); ++root) {
            const RGB& E = scene_->patches[root].emission;
            stack.clear();
            stack.push_back({root, gathered_[root], 0});
            while (!stack.empty()) {
                Frame& f = stack.back();
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
    });
}

RGB Hierarchy::reflectedPower() const {
    RGB s(0.0);
    for (uint32_t e = 0; e < numElements(); ++e)
        if (firstChild_[e] == kNone) s += area_[e] * (B_[e] - scene_->patches[patch_[e]].emission);
    return s;
}

RGB Hierarchy::radiosityPower() const {
    RGB s(0.0);
    for (uint32_t e = 0; e < numElements(); ++e)
        if (firstChild_[e] == kNone) s += area_[e] * B_[e];
    return s;
}

void Hierarchy::resetToEmission() {
    for (uint32_t e = 0; e < numElements(); ++e) {
        B_[e] = scene_->patches[patch_[e]].emission;
        gathered_[e] = RGB(0.0);
    }
}

uint64_t Hierarchy::elementBytes() const {
    return patch_.capacity() * sizeof(uint32_t) + key_.capacity() * sizeof(ElementKey) +
           parent_.capacity() * sizeof(uint32_t) + firstChild_.capacity() * sizeof(uint32_t) +
           area_.capacity() * sizeof(double) + B_.capacity() * sizeof(RGB) +
           gathered_.capacity() * sizeof(RGB);
}

uint64_t Hierarchy::linkBytes() const {
    return links_.capacity() * sizeof(Link) + linkOffsets_.capacity() * sizeof(uint64_t);
}

void Hierarchy::reportMemory(MemoryCounters& m) const {
    m.set("elements", elementBytes());
    m.set("links", links_.capacity() * sizeof(Link));
    m.set("link_offsets", linkOffsets_.capacity() * sizeof(uint64_t));
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
    return h_->B(e);
}

RGB HierarchyField::average(uint32_t patch, ElementKey key) const {
    uint32_t e = patch;
    int L = scene::keyLevel(key);
    for (int l = 0; l < L && !h_->isLeaf(e); ++l)
        e = h_->firstChild(e) + uint32_t(scene::keyChildAt(key, l));
    // Either the node at `key` (whose B is the exact area average of its
    // leaves after push-pull) or a leaf containing the whole region.
    return h_->B(e);
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
