// Smooth (C0) vertex reconstruction (see smooth.h).
#include "render/smooth.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <numeric>
#include <tuple>
#include <unordered_map>

#include "core/error.h"
#include "render/texturing.h"

namespace hrad::render {

using scene::Domain;
using scene::ElementKey;
using scene::PatchKind;

namespace {

/// A 3D position on a smooth surface, quantised.
struct VKey {
    uint32_t surface;
    int64_t x, y, z;
    bool operator==(const VKey&) const = default;
};
struct VKeyHash {
    size_t operator()(const VKey& k) const {
        uint64_t h = k.surface * 0x9E3779B97F4A7C15ull;
        for (int64_t c : {k.x, k.y, k.z}) h = (h ^ uint64_t(c)) * 0xff51afd7ed558ccdull;
        return size_t(h ^ (h >> 31));
    }
};

struct Quantiser {
    Vec3 lo;
    double cell;
    VKey key(uint32_t surface, const Vec3& p) const {
        Vec3 q = (p - lo) / cell;
        return {surface, std::llround(q.x), std::llround(q.y), std::llround(q.z)};
    }
};

uint32_t findRoot(std::vector<uint32_t>& parent, uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
}

}  // namespace

struct VertexInterpolation::PatchTable {
    PatchKind kind = PatchKind::Quad;
    std::unordered_map<ElementKey, uint32_t> leafIndex;
    std::vector<ElementKey> keys;
    std::vector<RGB> values;                  ///< forEachLeaf's value
    std::vector<std::array<uint32_t, 4>> ids;  ///< vertex of each corner

    /// Leaf containing (u,v) (UINT32_MAX if the leaves do not cover it).
    uint32_t find(double u, double v, Domain& dom) const {
        ElementKey key = scene::kRootKey;
        dom = Domain{};
        for (int level = 0; level <= scene::kMaxLevel; ++level) {
            auto it = leafIndex.find(key);
            if (it != leafIndex.end()) return it->second;
            int c = scene::childContaining(kind, dom, u, v);
            dom = scene::childDomain(kind, dom, c);
            key = scene::childKey(key, c);
        }
        return UINT32_MAX;
    }
};

VertexInterpolation::VertexInterpolation(const scene::RadiosityField& field, const SmoothSettings& s,
                                         const LeafReflectance* leaf)
    : field_(&field), settings_(s), leaf_(leaf && leaf->any() ? leaf : nullptr) {
    buildSurfaces(s.creaseDegrees);
    buildVertices();
}

VertexInterpolation::~VertexInterpolation() = default;

bool VertexInterpolation::holdsIrradiance(uint32_t patch) const { return leaf_ && leaf_->covers(patch); }

bool VertexInterpolation::interpolatesIrradiance() const { return leaf_ != nullptr; }

/// Phase 1: smooth surfaces, the union of root patches across shared edges
/// with equal materials and normals within the crease angle.
void VertexInterpolation::buildSurfaces(double creaseDegrees) {
    const scene::Scene& sc = field_->scene();
    const size_t n = sc.patches.size();
    surface_.resize(n);
    std::iota(surface_.begin(), surface_.end(), 0u);
    const Quantiser q{sc.bounds().lo, std::max(1e-7 * sc.bounds().diagonal(), 1e-300)};
    const double cosCrease = std::cos(creaseDegrees * std::numbers::pi / 180.0);
    // Edge (two quantised end points, ordered) -> first patch seen with it.
    struct EKey {
        VKey a, b;
        bool operator==(const EKey&) const = default;
    };
    struct EKeyHash {
        size_t operator()(const EKey& e) const { return VKeyHash{}(e.a) * 31 + VKeyHash{}(e.b); }
    };
    std::unordered_map<EKey, std::vector<uint32_t>, EKeyHash> edges;
    edges.reserve(2 * n);
    auto less = [](const VKey& x, const VKey& y) {
        return std::tie(x.x, x.y, x.z) < std::tie(y.x, y.y, y.z);
    };
    for (uint32_t p = 0; p < n; ++p) {
        const scene::Patch& pa = sc.patches[p];
        const int nv = pa.numVertices();
        for (int i = 0; i < nv; ++i) {
            VKey a = q.key(0, pa.v[size_t(i)]), b = q.key(0, pa.v[size_t((i + 1) % nv)]);
            if (less(b, a)) std::swap(a, b);
            edges[{a, b}].push_back(p);
        }
    }
    // A patch holding H never joins one holding B (smooth.h).
    auto compatible = [&](uint32_t i, uint32_t j) {
        const scene::Patch &a = sc.patches[i], &b = sc.patches[j];
        return holdsIrradiance(i) == holdsIrradiance(j) && a.rho == b.rho &&
               a.emission == b.emission && glm::dot(a.normal, b.normal) >= cosCrease;
    };
    for (const auto& [e, ps] : edges)
        for (size_t i = 0; i < ps.size(); ++i)
            for (size_t j = i + 1; j < ps.size(); ++j)
                if (compatible(ps[i], ps[j])) {
                    uint32_t ra = findRoot(surface_, ps[i]), rb = findRoot(surface_, ps[j]);
                    if (ra != rb) surface_[std::max(ra, rb)] = std::min(ra, rb);
                }
    for (uint32_t p = 0; p < n; ++p) surface_[p] = findRoot(surface_, p);
}

/// Phase 2: vertices (one per surface and position), their averaged values,
/// and the anchoring of T-vertices, coarsest edges first.
void VertexInterpolation::buildVertices() {
    const scene::Scene& sc = field_->scene();
    const size_t n = sc.patches.size();
    tables_.resize(n);
    tbb::parallel_for(size_t(0), n, [&](size_t p) {
        auto t = std::make_unique<PatchTable>();
        t->kind = sc.patches[p].kind;
        field_->forEachLeaf(uint32_t(p), [&](ElementKey k, const RGB& b) {
            t->leafIndex.emplace(k, uint32_t(t->keys.size()));
            t->keys.push_back(k);
            t->values.push_back(b);
        });
        t->ids.resize(t->keys.size());
        tables_[p] = std::move(t);
    });
    const Quantiser q{sc.bounds().lo, std::max(1e-7 * sc.bounds().diagonal(), 1e-300)};
    std::unordered_map<VKey, uint32_t, VKeyHash> vertices;
    // Per vertex and channel: the sum of the leaves' values and of their
    // weights (1 each; on patches holding H, B - E and rho_l: smooth.h).
    std::vector<RGB> weight;
    for (uint32_t p = 0; p < n; ++p) {
        PatchTable& t = *tables_[p];
        const scene::Patch& pa = sc.patches[p];
        const bool irradiance = holdsIrradiance(p);
        for (size_t i = 0; i < t.keys.size(); ++i) {
            Vec3 c[4];
            int nc = scene::elementCorners(pa, scene::keyDomain(pa.kind, t.keys[i]), c);
            for (int k = 0; k < nc; ++k) {
                auto [it, fresh] = vertices.try_emplace(q.key(surface_[p], c[k]), uint32_t(value_.size()));
                if (fresh) {
                    value_.push_back(RGB(0.0));
                    weight.push_back(RGB(0.0));
                }
                Vec2 a = scene::cornerLocal(pa.kind, k);
                const RGB b = field_->leafPoint(p, t.keys[i], t.values[i], a.x, a.y);
                value_[it->second] += irradiance ? b - pa.emission : b;
                weight[it->second] += irradiance ? leaf_->rho(p, t.keys[i]) : RGB(1.0);
                t.ids[i][size_t(k)] = it->second;
            }
        }
    }
    for (size_t v = 0; v < value_.size(); ++v)
        for (int c = 0; c < 3; ++c) value_[v][c] = weight[v][c] > 0 ? value_[v][c] / weight[v][c] : 0.0;

    // T-vertices: recursive midpoints of leaf edges that are vertices of the
    // same surface; (level of the edge, end points, midpoint).
    struct Anchor {
        int level;
        uint32_t a, b, m;
    };
    std::vector<Anchor> anchors;
    auto probe = [&](auto&& self, uint32_t surface, const Vec3& A, const Vec3& B, uint32_t a,
                     uint32_t b, int level) -> void {
        if (level > scene::kMaxLevel) return;
        Vec3 M = 0.5 * (A + B);
        auto it = vertices.find(q.key(surface, M));
        if (it == vertices.end()) return;
        // An edge shorter than the vertex quantum has its midpoint on an end
        // point's key: it has no T-vertex, and following it would recurse
        // down to kMaxLevel on both halves (2^30 anchors; a bathroom solve
        // ran out of memory here).
        if (it->second == a || it->second == b) return;
        anchors.push_back({level, a, b, it->second});
        self(self, surface, A, M, a, it->second, level + 1);
        self(self, surface, M, B, it->second, b, level + 1);
    };
    for (uint32_t p = 0; p < n; ++p) {
        const PatchTable& t = *tables_[p];
        const scene::Patch& pa = sc.patches[p];
        for (size_t i = 0; i < t.keys.size(); ++i) {
            Vec3 c[4];
            int nc = scene::elementCorners(pa, scene::keyDomain(pa.kind, t.keys[i]), c);
            for (int k = 0; k < nc; ++k)
                probe(probe, surface_[p], c[k], c[(k + 1) % nc], t.ids[i][size_t(k)],
                      t.ids[i][size_t((k + 1) % nc)], scene::keyLevel(t.keys[i]));
        }
    }
    // A T-vertex lies inside edges of coarser levels only (dyadic positions),
    // so after sorting by level every anchor's end points are final.
    std::stable_sort(anchors.begin(), anchors.end(),
                     [](const Anchor& x, const Anchor& y) { return x.level < y.level; });
    std::vector<char> done(value_.size(), 0);
    for (const Anchor& an : anchors) {
        if (done[an.m]) continue;
        value_[an.m] = 0.5 * (value_[an.a] + value_[an.b]);
        done[an.m] = 1;
        ++anchored_;
    }
}

RGB VertexInterpolation::cornerValue(uint32_t patch, ElementKey key, int corner) const {
    const PatchTable& t = *tables_.at(patch);
    auto it = t.leafIndex.find(key);
    HRAD_CHECK_MSG(it != t.leafIndex.end(), "key {} is not a leaf of patch {}", key, patch);
    return value_[t.ids[it->second][size_t(corner)]];
}

RGB VertexInterpolation::at(uint32_t patch, double u, double v) const {
    const PatchTable& t = *tables_[patch];
    Vec2 uv = scene::clampToPatchDomain(t.kind, Vec2(u, v));
    Domain d;
    uint32_t leaf = t.find(uv.x, uv.y, d);
    if (leaf == UINT32_MAX)
        return holdsIrradiance(patch) ? leaf_->irradianceAt(patch, uv.x, uv.y) : field_->at(patch, uv.x, uv.y);
    // Local coordinates; for inverted triangles h < 0 maps the corners
    // (u0,v0), (u0+h,v0), (u0,v0+h) to (0,0), (1,0), (0,1) all the same.
    double a = std::clamp((uv.x - d.u0) / d.h, 0.0, 1.0);
    double b = std::clamp((uv.y - d.v0) / d.h, 0.0, 1.0);
    const auto& id = t.ids[leaf];
    if (t.kind == PatchKind::Quad)
        return (1 - a) * (1 - b) * value_[id[0]] + a * (1 - b) * value_[id[1]] +
               a * b * value_[id[2]] + (1 - a) * b * value_[id[3]];
    return (1 - a - b) * value_[id[0]] + a * value_[id[1]] + b * value_[id[2]];
}

}  // namespace hrad::render
