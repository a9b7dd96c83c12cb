#include "scene/field.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "core/error.h"

namespace hrad::scene {

RGB RadiosityField::totalPower() const {
    RGB sum(0.0);
    const Scene& s = scene();
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        const Patch& patch = s.patches[p];
        forEachLeaf(p, [&](ElementKey k, const RGB& b) {
            sum += b * elementArea(patch, keyDomain(patch.kind, k));
        });
    }
    return sum;
}

UniformField::UniformField(const Scene& scene, std::vector<uint8_t> levels)
    : scene_(&scene), levels_(std::move(levels)) {
    HRAD_CHECK(levels_.size() == scene.patches.size());
    offsets_.resize(levels_.size() + 1);
    size_t n = 0;
    for (size_t p = 0; p < levels_.size(); ++p) {
        HRAD_CHECK(levels_[p] <= kMaxLevel);
        offsets_[p] = n;
        n += size_t(1) << (2 * levels_[p]);
    }
    offsets_.back() = n;
    values_.assign(n, RGB(0.0));
    areas_.resize(n);
    for (uint32_t p = 0; p < levels_.size(); ++p) {
        const Patch& patch = scene.patches[p];
        for (size_t i = 0; i < count(p); ++i)
            areas_[offsets_[p] + i] = elementArea(patch, keyDomain(patch.kind, key(p, i)));
    }
}

RGB UniformField::at(uint32_t patch, double u, double v) const {
    const Patch& p = scene_->patches[patch];
    ElementKey k = keyAt(p.kind, u, v, levels_[patch]);
    return values_[offsets_[patch] + (k - (ElementKey(1) << (2 * levels_[patch])))];
}

RGB UniformField::average(uint32_t patch, ElementKey key) const {
    int L = levels_[patch], l = keyLevel(key);
    size_t base = offsets_[patch];
    ElementKey first = ElementKey(1) << (2 * L);
    if (l >= L) return values_[base + ((key >> (2 * (l - L))) - first)];
    // Descendants at level L are contiguous keys.
    ElementKey lo = key << (2 * (L - l));
    size_t n = size_t(1) << (2 * (L - l));
    RGB sum(0.0);
    double a = 0.0;
    for (size_t i = 0; i < n; ++i) {
        size_t idx = base + (lo - first) + i;
        sum += values_[idx] * areas_[idx];
        a += areas_[idx];
    }
    return a > 0 ? sum / a : RGB(0.0);
}

void UniformField::forEachLeaf(uint32_t patch,
                               const std::function<void(ElementKey, const RGB&)>& fn) const {
    for (size_t i = 0; i < count(patch); ++i) fn(key(patch, i), values_[offsets_[patch] + i]);
}

std::vector<uint8_t> uniformLevels(const Scene& scene, int level, double maxArea, int maxLevel) {
    std::vector<uint8_t> out(scene.patches.size(), uint8_t(level));
    if (maxArea > 0) {
        for (size_t i = 0; i < scene.patches.size(); ++i) {
            int l = 0;
            double a = scene.patches[i].area;
            // Children of a quad need not have equal area (trapezoids), so the
            // bound uses the exact largest child area per level.
            while (l < maxLevel && a > maxArea) {
                ++l;
                a *= 0.25;
                // Refine the estimate for non-parallelogram quads.
                if (scene.patches[i].kind == PatchKind::Quad) {
                    const Patch& p = scene.patches[i];
                    double amax = 0;
                    int n = 1 << l;
                    for (int iu = 0; iu < n; iu += std::max(1, n - 1))
                        for (int iv = 0; iv < n; iv += std::max(1, n - 1))
                            amax = std::max(amax, elementArea(p, Domain{double(iu) / n,
                                                                        double(iv) / n, 1.0 / n}));
                    a = amax;
                }
            }
            out[i] = uint8_t(l);
        }
    }
    return out;
}

LeafField::LeafField(const Scene& scene, std::vector<std::vector<Leaf>> leaves, int degree,
                     std::vector<std::vector<RGB>> higher)
    : scene_(&scene), leaves_(std::move(leaves)), degree_(degree), higher_(std::move(higher)) {
    if (leaves_.size() != scene.patches.size())
        throw Error(fmt::format("leaf field: {} patches of leaves for a scene of {}",
                                leaves_.size(), scene.patches.size()));
    if (degree_ < 0 || degree_ > kMaxBasisDegree)
        throw Error(fmt::format("leaf field: basis degree {} (0..{})", degree_, kMaxBasisDegree));
    if (degree_ > 0) {
        basis_ = std::make_unique<BasisSet>(degree_);
        const size_t extra = size_t(basisSize(degree_) - 1);
        if (higher_.size() != leaves_.size())
            throw Error(
                fmt::format("leaf field: {} patches of coefficients for {} patches of leaves",
                            higher_.size(), leaves_.size()));
        for (uint32_t p = 0; p < leaves_.size(); ++p)
            if (higher_[p].size() != extra * leaves_[p].size())
                throw Error(
                    fmt::format("leaf field: patch {}: {} coefficients for {} leaves of degree {}",
                                p, higher_[p].size(), leaves_[p].size(), degree_));
    } else {
        higher_.clear();
    }
    index_.resize(leaves_.size());
    for (uint32_t p = 0; p < leaves_.size(); ++p) {
        const Patch& patch = scene.patches[p];
        double area = 0.0;
        for (uint32_t i = 0; i < leaves_[p].size(); ++i) {
            ElementKey k = leaves_[p][i].key;
            if (!isValidKey(k) || !index_[p].emplace(k, i).second)
                throw Error(fmt::format("leaf field: patch {}: invalid or repeated key {}", p, k));
            area += elementArea(patch, keyDomain(patch.kind, k));
        }
        // Tiling: no leaf inside another, and the areas add up to the patch's.
        for (const Leaf& l : leaves_[p])
            for (ElementKey a = l.key >> 2; a >= 1; a >>= 2)
                if (index_[p].count(a))
                    throw Error(fmt::format("leaf field: patch {}: leaf {} lies inside leaf {}", p,
                                            l.key, a));
        if (std::abs(area - patch.area) > 1e-9 * patch.area)
            throw Error(fmt::format("leaf field: patch {}: leaves cover area {} of {}", p, area,
                                    patch.area));
    }
}

static std::vector<std::vector<LeafField::Leaf>> leavesOf(const RadiosityField& field) {
    std::vector<std::vector<LeafField::Leaf>> out(field.scene().patches.size());
    for (uint32_t p = 0; p < out.size(); ++p)
        field.forEachLeaf(p, [&](ElementKey k, const RGB& b) { out[p].push_back({k, b}); });
    return out;
}

static std::vector<std::vector<RGB>> higherOf(const RadiosityField& field) {
    const int degree = field.basisDegree();
    std::vector<std::vector<RGB>> out;
    if (degree == 0) return out;
    const size_t extra = size_t(basisSize(degree) - 1);
    out.resize(field.scene().patches.size());
    for (uint32_t p = 0; p < out.size(); ++p)
        field.forEachLeaf(p, [&](ElementKey k, const RGB&) {
            size_t at = out[p].size();
            out[p].resize(at + extra);
            field.leafHigherCoefficients(p, k, out[p].data() + at);
        });
    return out;
}

LeafField::LeafField(const RadiosityField& field)
    : LeafField(field.scene(), leavesOf(field), field.basisDegree(), higherOf(field)) {
    setLeafTextureRho(field.leafTextureRho());
}

LeafField::~LeafField() = default;

RGB LeafField::evaluate(uint32_t patch, size_t i, double a, double b) const {
    const RGB& mean = leaves_[patch][i].value;
    if (degree_ == 0) return mean;
    double phi[kMaxBasisSize];
    basis_->of(scene_->patches[patch].kind).eval(a, b, phi);
    const int n = basis_->size();
    const RGB* c = higher_[patch].data() + i * size_t(n - 1);
    RGB v = mean;
    for (int k = 1; k < n; ++k) v += phi[k] * c[k - 1];
    return v;
}

RGB LeafField::leafPoint(uint32_t patch, ElementKey key, const RGB& leafValue, double a,
                         double b) const {
    if (degree_ == 0) return leafValue;
    auto it = index_[patch].find(key);
    if (it == index_[patch].end()) return leafValue;
    return evaluate(patch, it->second, a, b);
}

void LeafField::leafHigherCoefficients(uint32_t patch, ElementKey key, RGB* out) const {
    if (degree_ == 0) return;
    auto it = index_[patch].find(key);
    if (it == index_[patch].end())
        throw Error(fmt::format("leaf field: patch {}: no leaf {}", patch, key));
    const size_t extra = size_t(basis_->size() - 1);
    const RGB* c = higher_[patch].data() + it->second * extra;
    std::copy(c, c + extra, out);
}

size_t LeafField::numLeaves() const {
    size_t n = 0;
    for (const auto& l : leaves_) n += l.size();
    return n;
}

int64_t LeafField::leafAtOrAbove(uint32_t patch, ElementKey key) const {
    for (ElementKey a = key; a >= 1; a >>= 2) {
        auto it = index_[patch].find(a);
        if (it != index_[patch].end()) return it->second;
    }
    return -1;
}

RGB LeafField::at(uint32_t patch, double u, double v) const {
    const Patch& p = scene_->patches[patch];
    // Descend from the root to the leaf containing (u,v).
    ElementKey k = 1;
    Domain d{};
    for (int level = 0; level <= kMaxLevel; ++level) {
        auto it = index_[patch].find(k);
        if (it != index_[patch].end()) {
            if (degree_ == 0) return leaves_[patch][it->second].value;
            // The leaf's polynomial at the local coordinates of (u, v).
            return evaluate(patch, it->second, (u - d.u0) / d.h, (v - d.v0) / d.h);
        }
        int c = childContaining(p.kind, d, u, v);
        d = childDomain(p.kind, d, c);
        k = childKey(k, c);
    }
    return RGB(0.0);  // unreachable for a tiling (checked in the constructor)
}

RGB LeafField::averageBelow(uint32_t patch, ElementKey key, double* area) const {
    const Patch& p = scene_->patches[patch];
    auto it = index_[patch].find(key);
    double a = elementArea(p, keyDomain(p.kind, key));
    *area = a;
    if (it != index_[patch].end()) return leaves_[patch][it->second].value;
    RGB sum(0.0);
    double total = 0.0;
    for (int c = 0; c < 4; ++c) {
        double ac = 0.0;
        RGB b = averageBelow(patch, childKey(key, c), &ac);
        sum += b * ac;
        total += ac;
    }
    return total > 0 ? sum / total : RGB(0.0);
}

RGB LeafField::average(uint32_t patch, ElementKey key) const {
    int64_t i = leafAtOrAbove(patch, key);
    if (i >= 0) {
        const Leaf& leaf = leaves_[patch][size_t(i)];
        if (degree_ == 0 || leaf.key == key) return leaf.value;  // the leaf's mean
        // A region inside a polynomial leaf: the mean of the leaf's
        // polynomial over it.
        std::array<RGB, kMaxBasisSize> c{};
        c[0] = leaf.value;
        leafHigherCoefficients(patch, leaf.key, c.data() + 1);
        return meanOverSubElement(basis_->of(scene_->patches[patch].kind), c, leaf.key, key);
    }
    double a = 0.0;
    return averageBelow(patch, key, &a);
}

void LeafField::forEachLeaf(uint32_t patch,
                            const std::function<void(ElementKey, const RGB&)>& fn) const {
    for (const Leaf& l : leaves_[patch]) fn(l.key, l.value);
}

}  // namespace hrad::scene
