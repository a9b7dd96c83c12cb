#include "cluster/face_clusters.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace hrad::cluster {

void AreaMoments::addPatch(const scene::Patch& p) {
    // Integral of x x^T over a triangle (a, b, c) of area A:
    // A/12 (a a^T + b b^T + c c^T + s s^T), s = a + b + c. Quads are two
    // triangles (v0 v1 v2) and (v0 v2 v3).
    auto tri = [&](const Vec3& a, const Vec3& b, const Vec3& c) {
        double A = 0.5 * glm::length(glm::cross(b - a, c - a));
        if (!(A > 0)) return;
        Vec3 s = a + b + c;
        area += A;
        first += A * s / 3.0;
        const Vec3* v[4] = {&a, &b, &c, &s};
        for (const Vec3* x : v) {
            second[0] += A / 12 * x->x * x->x;
            second[1] += A / 12 * x->x * x->y;
            second[2] += A / 12 * x->x * x->z;
            second[3] += A / 12 * x->y * x->y;
            second[4] += A / 12 * x->y * x->z;
            second[5] += A / 12 * x->z * x->z;
        }
    };
    tri(p.v[0], p.v[1], p.v[2]);
    if (p.kind == scene::PatchKind::Quad) tri(p.v[0], p.v[2], p.v[3]);
}

void AreaMoments::add(const AreaMoments& o) {
    area += o.area;
    first += o.first;
    for (int i = 0; i < 6; ++i) second[i] += o.second[i];
}

PlaneFit fitPlane(const AreaMoments& m, const Vec3& orient) {
    PlaneFit f;
    if (!(m.area > 0)) return f;
    f.centroid = m.first / m.area;
    const Vec3& c = f.centroid;
    const auto& S = m.second;
    // Covariance about the centroid: E[x x^T] - c c^T.
    Eigen::Matrix3d C;
    C(0, 0) = S[0] / m.area - c.x * c.x;
    C(0, 1) = C(1, 0) = S[1] / m.area - c.x * c.y;
    C(0, 2) = C(2, 0) = S[2] / m.area - c.x * c.z;
    C(1, 1) = S[3] / m.area - c.y * c.y;
    C(1, 2) = C(2, 1) = S[4] / m.area - c.y * c.z;
    C(2, 2) = S[5] / m.area - c.z * c.z;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(C);
    // Eigenvalues in increasing order.
    f.meanSquaredDistance = std::max(0.0, es.eigenvalues()(0));
    f.meanSquaredRadius = std::max(0.0, C.trace());
    Eigen::Vector3d n = es.eigenvectors().col(0);
    Vec3 nn(n(0), n(1), n(2));
    double len = glm::length(nn);
    if (len > 0) nn /= len;
    if (glm::dot(nn, orient) < 0) nn = -nn;
    f.normal = nn;
    return f;
}

namespace {

/// Smallest cone holding two cones (axis, half-angle in radians).
void mergeCones(const Vec3& a1, double t1, const Vec3& a2, double t2, Vec3& axis, double& theta) {
    double phi = std::acos(std::clamp(glm::dot(a1, a2), -1.0, 1.0));
    if (phi + t2 <= t1) {
        axis = a1, theta = t1;
        return;
    }
    if (phi + t1 <= t2) {
        axis = a2, theta = t2;
        return;
    }
    theta = 0.5 * (phi + t1 + t2);
    if (theta >= kPi || !(std::sin(phi) > 1e-12)) {
        axis = a1, theta = std::min(kPi, theta);
        return;
    }
    // Rotate a1 towards a2 by theta - t1 (spherical interpolation).
    double t = theta - t1;
    axis = (std::sin(phi - t) * a1 + std::sin(t) * a2) / std::sin(phi);
    axis = glm::normalize(axis);
}

struct State {
    AreaMoments moments;
    Vec3 axis{0.0};
    double theta = 0.0;
    double perimeter = 0.0;
    uint32_t patches = 0;
};

struct DualEdge {
    uint32_t u, v;
    double length;
};

/// Sorts edges by (u, v) and merges duplicates, summing their lengths.
void uniqueEdges(std::vector<DualEdge>& e) {
    std::sort(e.begin(), e.end(), [](const DualEdge& x, const DualEdge& y) {
        return x.u != y.u ? x.u < y.u : x.v < y.v;
    });
    size_t w = 0;
    for (size_t i = 0; i < e.size(); ++i) {
        if (w > 0 && e[w - 1].u == e[i].u && e[w - 1].v == e[i].v) {
            e[w - 1].length += e[i].length;
        } else {
            e[w++] = e[i];
        }
    }
    e.resize(w);
}

/// The dual graph of the patches: welds vertices by quantised position and
/// makes patches sharing a mesh edge, on the same side and of the same kind
/// (emitting or not), adjacent. Fills each patch's initial state.
std::vector<DualEdge> dualGraph(const scene::Scene& scene, std::vector<State>& st) {
    const auto& P = scene.patches;
    const uint32_t k = uint32_t(P.size());
    double diag = scene.bounds().diagonal();
    double q = diag > 0 ? 1e-7 * diag : 1e-12;
    struct Key {
        int64_t x, y, z;
        bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
    };
    struct KeyHash {
        size_t operator()(const Key& k) const {
            uint64_t h = uint64_t(k.x) * 0x9E3779B97F4A7C15ULL;
            h ^= uint64_t(k.y) + 0x7F4A7C159E3779B9ULL + (h << 6) + (h >> 2);
            h ^= uint64_t(k.z) + 0x94D049BB133111EBULL + (h << 6) + (h >> 2);
            return size_t(h);
        }
    };
    std::unordered_map<Key, uint32_t, KeyHash> weld;
    weld.reserve(size_t(k) * 2);
    struct EdgeEntry {
        uint64_t key;
        uint32_t patch;
        double length;
    };
    std::vector<EdgeEntry> entries;
    entries.reserve(size_t(k) * 4);
    for (uint32_t i = 0; i < k; ++i) {
        const auto& p = P[i];
        int nv = p.numVertices();
        uint32_t vid[4];
        for (int j = 0; j < nv; ++j) {
            Key key{std::llround(p.v[j].x / q), std::llround(p.v[j].y / q),
                    std::llround(p.v[j].z / q)};
            auto [it, inserted] = weld.try_emplace(key, uint32_t(weld.size()));
            vid[j] = it->second;
        }
        State& s = st[i];
        s.moments.addPatch(p);
        s.axis = p.normal;
        s.patches = 1;
        for (int j = 0; j < nv; ++j) {
            uint32_t a = vid[j], b = vid[(j + 1) % nv];
            double len = glm::length(p.v[(j + 1) % nv] - p.v[j]);
            s.perimeter += len;
            if (a == b) continue;
            uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
            entries.push_back({key, i, len});
        }
    }
    std::sort(entries.begin(), entries.end(), [](const EdgeEntry& x, const EdgeEntry& y) {
        return x.key != y.key ? x.key < y.key : x.patch < y.patch;
    });
    std::vector<DualEdge> edges;
    for (size_t i = 0; i < entries.size();) {
        size_t j = i;
        while (j < entries.size() && entries[j].key == entries[i].key) ++j;
        for (size_t a = i; a < j; ++a) {
            for (size_t b = a + 1; b < j; ++b) {
                uint32_t pa = entries[a].patch, pb = entries[b].patch;
                if (pa == pb) continue;
                if (P[pa].backSide != P[pb].backSide) continue;
                if (P[pa].isEmitter() != P[pb].isEmitter()) continue;
                if (P[pa].twin == pb) continue;
                edges.push_back({std::min(pa, pb), std::max(pa, pb), entries[a].length});
            }
        }
        i = j;
    }
    uniqueEdges(edges);
    return edges;
}

struct Candidate {
    double cost;
    uint32_t edge;
};

/// The edges whose merge stays within the cone, planarity and compactness
/// limits, by cost (fit, cone, shape), cheapest first.
void mergeCandidates(const std::vector<DualEdge>& edges, const std::vector<State>& st,
                     const FaceClusterParams& params, std::vector<Candidate>& cand) {
    const double coneLimit = params.coneDegrees * kPi / 180.0;
    cand.clear();
    for (uint32_t e = 0; e < edges.size(); ++e) {
        const State& a = st[edges[e].u];
        const State& b = st[edges[e].v];
        Vec3 axis;
        double theta;
        mergeCones(a.axis, a.theta, b.axis, b.theta, axis, theta);
        if (theta > coneLimit) continue;
        AreaMoments m = a.moments;
        m.add(b.moments);
        PlaneFit f = fitPlane(m, axis);
        double fit =
            f.meanSquaredRadius > 0 ? std::sqrt(f.meanSquaredDistance / f.meanSquaredRadius) : 0.0;
        if (fit > params.planarity) continue;
        if (params.compactness > 0 && m.area < params.compactness * 2 * kPi * f.meanSquaredRadius)
            continue;
        double perim = std::max(0.0, a.perimeter + b.perimeter - 2 * edges[e].length);
        double shape = perim > 0 ? std::max(0.0, 1.0 - 4 * kPi * m.area / (perim * perim)) : 0.0;
        double cost = fit + (1.0 - std::cos(theta)) + params.shapeWeight * shape;
        cand.push_back({cost, e});
    }
    std::sort(cand.begin(), cand.end(), [](const Candidate& x, const Candidate& y) {
        return x.cost != y.cost ? x.cost < y.cost : x.edge < y.edge;
    });
}

/// The contracted graph: merged pairs become their new node.
std::vector<DualEdge> contract(const std::vector<DualEdge>& edges,
                               const std::vector<uint8_t>& matched,
                               const std::vector<uint32_t>& rep) {
    std::vector<DualEdge> next;
    next.reserve(edges.size());
    for (const DualEdge& e : edges) {
        uint32_t u = matched[e.u] ? rep[e.u] : e.u;
        uint32_t v = matched[e.v] ? rep[e.v] : e.v;
        if (u == v) continue;
        next.push_back({std::min(u, v), std::max(u, v), e.length});
    }
    uniqueEdges(next);
    return next;
}

}  // namespace

FaceForest buildFaceForest(const scene::Scene& scene, const FaceClusterParams& params) {
    const uint32_t k = uint32_t(scene.patches.size());
    FaceForest forest;
    forest.numPatches = k;
    std::vector<State> st(size_t(k) * 2);
    std::vector<DualEdge> edges = dualGraph(scene, st);
    std::vector<uint8_t> isChild(size_t(k) * 2, 0);
    std::vector<uint32_t> rep(size_t(k) * 2);
    std::vector<Candidate> cand;
    std::vector<uint8_t> matched(size_t(k) * 2, 0);
    constexpr int kMaxRounds = 48;  // bounds the depth of the face hierarchy
    for (int round = 0; round < kMaxRounds && !edges.empty(); ++round) {
        mergeCandidates(edges, st, params, cand);
        if (cand.empty()) break;
        int merged = 0;
        for (const Candidate& c : cand) {
            uint32_t u = edges[c.edge].u, v = edges[c.edge].v;
            if (matched[u] || matched[v]) continue;
            matched[u] = matched[v] = 1;
            uint32_t id = k + uint32_t(forest.nodes.size());
            FaceForest::Node node;
            node.a = u;
            node.b = v;
            const State& a = st[u];
            const State& b = st[v];
            State& m = st[id];
            mergeCones(a.axis, a.theta, b.axis, b.theta, m.axis, m.theta);
            m.moments = a.moments;
            m.moments.add(b.moments);
            m.perimeter = std::max(0.0, a.perimeter + b.perimeter - 2 * edges[c.edge].length);
            m.patches = a.patches + b.patches;
            node.patches = m.patches;
            node.coneAxis = m.axis;
            node.coneCos = std::cos(m.theta);
            forest.nodes.push_back(node);
            isChild[u] = isChild[v] = 1;
            rep[u] = rep[v] = id;
            ++merged;
        }
        forest.rounds = round + 1;
        edges = contract(edges, matched, rep);
        std::fill(matched.begin(), matched.end(), 0);
        if (merged == 0) break;
    }
    uint32_t total = k + uint32_t(forest.nodes.size());
    for (uint32_t id = 0; id < total; ++id)
        if (!isChild[id]) forest.roots.push_back(id);
    return forest;
}

}  // namespace hrad::cluster
