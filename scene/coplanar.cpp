#include "scene/coplanar.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace hrad::scene {

namespace {

using Vec2 = glm::dvec2;

/// Polygon of a patch in 2-D (the two axes other than the normal's dominant
/// one), counter-clockwise.
std::vector<Vec2> project(const Patch& p, int drop) {
    std::vector<Vec2> out;
    for (int k = 0; k < p.numVertices(); ++k) {
        const Vec3& v = p.v[k];
        out.push_back(drop == 0 ? Vec2(v.y, v.z) : drop == 1 ? Vec2(v.z, v.x) : Vec2(v.x, v.y));
    }
    double a = 0.0;
    for (size_t i = 0; i < out.size(); ++i) {
        const Vec2& p0 = out[i];
        const Vec2& p1 = out[(i + 1) % out.size()];
        a += p0.x * p1.y - p1.x * p0.y;
    }
    if (a < 0) std::reverse(out.begin(), out.end());
    return out;
}

double area2(const std::vector<Vec2>& poly) {
    double a = 0.0;
    for (size_t i = 0; i < poly.size(); ++i) {
        const Vec2& p0 = poly[i];
        const Vec2& p1 = poly[(i + 1) % poly.size()];
        a += p0.x * p1.y - p1.x * p0.y;
    }
    return 0.5 * a;
}

/// Sutherland-Hodgman: `subject` clipped by the convex counter-clockwise `clip`.
std::vector<Vec2> clipConvex(std::vector<Vec2> subject, const std::vector<Vec2>& clip) {
    for (size_t e = 0; e < clip.size() && !subject.empty(); ++e) {
        const Vec2 a = clip[e], b = clip[(e + 1) % clip.size()];
        auto side = [&](const Vec2& p) { return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x); };
        std::vector<Vec2> out;
        for (size_t i = 0; i < subject.size(); ++i) {
            const Vec2 p = subject[i], q = subject[(i + 1) % subject.size()];
            double sp = side(p), sq = side(q);
            if (sp >= 0) out.push_back(p);
            if ((sp >= 0) != (sq >= 0)) out.push_back(p + (q - p) * (sp / (sp - sq)));
        }
        subject = std::move(out);
    }
    return subject;
}

struct PlaneKey {
    int32_t nx, ny, nz;
    int64_t d;
    bool operator==(const PlaneKey& o) const { return nx == o.nx && ny == o.ny && nz == o.nz && d == o.d; }
};
struct PlaneKeyHash {
    size_t operator()(const PlaneKey& k) const {
        uint64_t h = uint64_t(int64_t(k.nx)) * 0x9E3779B97F4A7C15ULL;
        h ^= uint64_t(int64_t(k.ny)) * 0xC2B2AE3D27D4EB4FULL + (h << 6) + (h >> 2);
        h ^= uint64_t(int64_t(k.nz)) * 0x165667B19E3779F9ULL + (h << 6) + (h >> 2);
        h ^= uint64_t(k.d) * 0x27D4EB2F165667C5ULL + (h << 6) + (h >> 2);
        return size_t(h);
    }
};

}  // namespace

bool CoplanarOverlaps::inFront(const Patch& g, uint32_t gi, const Patch& p, uint32_t pi) {
    bool ge = g.isEmitter(), pe = p.isEmitter();
    if (ge != pe) return ge;
    if (g.area != p.area) return g.area < p.area;
    return gi < pi;
}

namespace {

/// A face of one plane bucket, projected to 2-D.
struct Item {
    uint32_t patch;
    std::vector<Vec2> poly;
    Vec2 lo, hi;
    double area;
};

/// Calls visit(i, j), i < j, for every pair of items whose 2-D boxes overlap
/// (with positive area). A bounding-box tree split at the median of the
/// longer axis, then one query per item: O(n log n) plus the pairs reported.
/// (A sweep over x alone visited every pair of a strip of faces that all span
/// the same x range: 200 k triangles took 107 s, issue 64.)
template <typename Visit>
void forEachBoxOverlap(const std::vector<Item>& items, Visit&& visit) {
    struct Node {
        Vec2 lo, hi;
        uint32_t begin, end;  // range of `order` (leaves) or children (left = +1)
        uint32_t right;       // 0: a leaf
    };
    std::vector<uint32_t> order(items.size());
    for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    std::vector<Node> nodes;
    nodes.reserve(2 * items.size() / 4 + 2);
    // Build iteratively (no recursion whatever the input): each entry is a
    // node whose range is still to be split.
    nodes.push_back({Vec2(0), Vec2(0), 0, uint32_t(items.size()), 0});
    std::vector<uint32_t> todo{0};
    while (!todo.empty()) {
        uint32_t ni = todo.back();
        todo.pop_back();
        Node nd = nodes[ni];
        Vec2 lo(1e300), hi(-1e300), clo(1e300), chi(-1e300);
        for (uint32_t k = nd.begin; k < nd.end; ++k) {
            const Item& it = items[order[k]];
            lo = glm::min(lo, it.lo);
            hi = glm::max(hi, it.hi);
            Vec2 c = 0.5 * (it.lo + it.hi);
            clo = glm::min(clo, c);
            chi = glm::max(chi, c);
        }
        nodes[ni].lo = lo;
        nodes[ni].hi = hi;
        if (nd.end - nd.begin <= 8) continue;
        const int axis = chi.x - clo.x >= chi.y - clo.y ? 0 : 1;
        const uint32_t mid = nd.begin + (nd.end - nd.begin) / 2;
        std::nth_element(order.begin() + nd.begin, order.begin() + mid, order.begin() + nd.end,
                         [&](uint32_t x, uint32_t y) {
                             return items[x].lo[axis] + items[x].hi[axis] <
                                    items[y].lo[axis] + items[y].hi[axis];
                         });
        const uint32_t left = uint32_t(nodes.size());
        nodes.push_back({Vec2(0), Vec2(0), nd.begin, mid, 0});
        nodes.push_back({Vec2(0), Vec2(0), mid, nd.end, 0});
        nodes[ni].begin = left;
        nodes[ni].right = left + 1;
        todo.push_back(left);
        todo.push_back(left + 1);
    }
    auto overlaps = [](Vec2 alo, Vec2 ahi, Vec2 blo, Vec2 bhi) {
        return alo.x < bhi.x && blo.x < ahi.x && alo.y < bhi.y && blo.y < ahi.y;
    };
    std::vector<uint32_t> stack;
    for (uint32_t i = 0; i < items.size(); ++i) {
        const Item& a = items[i];
        stack.assign(1, 0);
        while (!stack.empty()) {
            const Node& nd = nodes[stack.back()];
            stack.pop_back();
            if (!overlaps(a.lo, a.hi, nd.lo, nd.hi)) continue;
            if (nd.right != 0) {
                stack.push_back(nd.begin);
                stack.push_back(nd.right);
                continue;
            }
            for (uint32_t k = nd.begin; k < nd.end; ++k) {
                uint32_t j = order[k];
                if (j > i && overlaps(a.lo, a.hi, items[j].lo, items[j].hi)) visit(i, j);
            }
        }
    }
}

/// The faces of `cand` projected onto the plane's dominant axes.
std::vector<Item> projectBucket(const Scene& scene, const std::vector<uint32_t>& cand) {
    const Vec3& nrm = scene.patches[cand[0]].normal;
    Vec3 an = glm::abs(nrm);
    int drop = an.x >= an.y && an.x >= an.z ? 0 : (an.y >= an.z ? 1 : 2);
    std::vector<Item> items;
    items.reserve(cand.size());
    for (uint32_t c : cand) {
        Item it{c, project(scene.patches[c], drop), Vec2(1e300), Vec2(-1e300), 0.0};
        for (const Vec2& q : it.poly) {
            it.lo = glm::min(it.lo, q);
            it.hi = glm::max(it.hi, q);
        }
        it.area = area2(it.poly);
        items.push_back(std::move(it));
    }
    return items;
}

/// Overlapping pairs of faces in one plane (see the header): facing the same
/// way (`opposite` false) or opposite ways (true; the two sides of a sheet,
/// among one-sided faces only: a two-sided surface sees both ways already,
/// and its twin and the twins of faces stacked on it are not sheets).
/// Patches are bucketed by their quantised plane; for opposite pairs the
/// plane is taken with a canonical sign, so a face and its reverse share a
/// bucket.
std::vector<std::pair<uint32_t, uint32_t>> overlappingPairs(const Scene& scene, bool opposite) {
    const uint32_t n = uint32_t(scene.patches.size());
    Bounds3 b = scene.bounds();
    const double diag = glm::length(b.hi - b.lo);
    const double tol = std::max(1e-6 * diag, 1e-300);
    std::unordered_map<PlaneKey, std::vector<uint32_t>, PlaneKeyHash> buckets;
    std::vector<double> offset(n);
    for (uint32_t i = 0; i < n; ++i) {
        const Patch& p = scene.patches[i];
        if (opposite && p.twin != UINT32_MAX) continue;
        offset[i] = glm::dot(p.normal, p.v[0]);
        PlaneKey k{int32_t(std::lround(p.normal.x * 1000)), int32_t(std::lround(p.normal.y * 1000)),
                   int32_t(std::lround(p.normal.z * 1000)), 0};
        double off = offset[i];
        // lround is odd-symmetric, so -n quantises to -k: flip to the sign
        // whose first non-zero component is positive.
        const int32_t first = k.nx != 0 ? k.nx : (k.ny != 0 ? k.ny : k.nz);
        if (opposite && first < 0) {
            k.nx = -k.nx;
            k.ny = -k.ny;
            k.nz = -k.nz;
            off = -off;
        }
        k.d = int64_t(std::floor(off / tol));
        buckets[k].push_back(i);
    }
    std::vector<std::pair<uint32_t, uint32_t>> found;
    for (const auto& [key, members] : buckets) {
        // This cell and the next offset cell (each pair of cells once).
        std::vector<uint32_t> cand = members;
        PlaneKey next = key;
        next.d += 1;
        auto it = buckets.find(next);
        size_t own = cand.size();
        if (it != buckets.end()) cand.insert(cand.end(), it->second.begin(), it->second.end());
        if (cand.size() < 2) continue;
        const std::vector<Item> items = projectBucket(scene, cand);
        forEachBoxOverlap(items, [&](uint32_t i, uint32_t j) {
            // Pairs inside the next cell are found when that cell is visited.
            if (i >= own && j >= own) return;
            const Item& A = items[i];
            const Item& B = items[j];
            const Patch& pa = scene.patches[A.patch];
            const Patch& pb = scene.patches[B.patch];
            const double c = glm::dot(pa.normal, pb.normal);
            if (opposite ? c > -(1.0 - 1e-6) : c < 1.0 - 1e-6) return;
            const double gap = opposite ? offset[A.patch] + offset[B.patch]
                                        : offset[A.patch] - offset[B.patch];
            if (std::fabs(gap) > tol) return;
            double common = std::fabs(area2(clipConvex(A.poly, B.poly)));
            if (common > 1e-6 * std::min(A.area, B.area))
                found.emplace_back(std::min(A.patch, B.patch), std::max(A.patch, B.patch));
        });
    }
    std::sort(found.begin(), found.end());
    found.erase(std::unique(found.begin(), found.end()), found.end());
    return found;
}

}  // namespace

CoplanarOverlaps::CoplanarOverlaps(const Scene& scene) {
    const uint32_t n = uint32_t(scene.patches.size());
    if (n < 2) return;
    const std::vector<std::pair<uint32_t, uint32_t>> sheets = overlappingPairs(scene, true);
    sheetPairs_ = sheets.size();
    if (!sheets.empty()) sheet_.assign(n, 0);
    for (auto [i, j] : sheets) sheet_[i] = sheet_[j] = 1;
    std::vector<std::pair<uint32_t, uint32_t>> found = overlappingPairs(scene, false);
    pairs_ = found.size();
    if (found.empty()) return;
    std::vector<std::vector<uint32_t>> cover(n), partner(n);
    for (auto [i, j] : found) {
        const Patch& pi = scene.patches[i];
        const Patch& pj = scene.patches[j];
        if (inFront(pi, i, pj, j))
            cover[j].push_back(i);
        else
            cover[i].push_back(j);
        partner[i].push_back(j);
        partner[j].push_back(i);
    }
    coverOffsets_.assign(size_t(n) + 1, 0);
    partnerOffsets_.assign(size_t(n) + 1, 0);
    for (uint32_t p = 0; p < n; ++p) {
        coverOffsets_[p + 1] = coverOffsets_[p] + cover[p].size();
        partnerOffsets_[p + 1] = partnerOffsets_[p] + partner[p].size();
        for (uint32_t g : cover[p]) {
            const Patch& G = scene.patches[g];
            Face f;
            f.v = G.v;
            f.n = G.numVertices();
            f.normal = G.normal;
            covers_.push_back(f);
        }
        partners_.insert(partners_.end(), partner[p].begin(), partner[p].end());
    }
}

uint64_t CoplanarOverlaps::numHiddenPatches() const {
    uint64_t k = 0;
    for (size_t p = 0; p + 1 < coverOffsets_.size(); ++p) k += coverOffsets_[p + 1] > coverOffsets_[p] ? 1 : 0;
    return k;
}

bool CoplanarOverlaps::hidden(uint32_t p, const Vec3& x) const {
    if (p + 1 >= coverOffsets_.size()) return false;
    for (uint64_t i = coverOffsets_[p]; i < coverOffsets_[p + 1]; ++i) {
        const Face& f = covers_[i];
        bool inside = true;
        for (int k = 0; k < f.n && inside; ++k) {
            const Vec3& a = f.v[k];
            const Vec3& b = f.v[(k + 1) % f.n];
            // Counter-clockwise about the normal: inside is to the left of every edge.
            inside = glm::dot(glm::cross(b - a, x - a), f.normal) >= 0.0;
        }
        if (inside) return true;
    }
    return false;
}

bool CoplanarOverlaps::partners(uint32_t p, uint32_t q) const {
    if (p + 1 >= partnerOffsets_.size()) return false;
    for (uint64_t i = partnerOffsets_[p]; i < partnerOffsets_[p + 1]; ++i)
        if (partners_[i] == q) return true;
    return false;
}

}  // namespace hrad::scene
