#include "cluster/tree.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "cluster/face_clusters.h"
#include "core/error.h"
#include "core/timer.h"

namespace hrad::cluster {

namespace {
const std::vector<std::string> kBuilders = {"bvh", "octree"};

double halfSurfaceArea(const scene::Bounds3& b) {
    if (!b.valid()) return 0.0;
    Vec3 e = b.extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
}
}  // namespace

std::vector<std::string> builderNames() { return kBuilders; }

ClusterSettings ClusterSettings::fromParams(const Params& p) {
    ClusterSettings s;
    s.builder = p.getEnum({"cluster.builder", "cluster tree builder: bvh (binned SAH) or octree"},
                          s.builder, kBuilders);
    s.leafSize = int(p.getInt({"cluster.leaf_size", "root patches per leaf cluster at most"},
                              s.leafSize, 1, 64));
    s.maxDepth = int(
        p.getInt({"cluster.max_depth", "depth of the cluster tree at most"}, s.maxDepth, 1, 64));
    s.faces = p.getBool(
        {"cluster.faces", "build face clusters (Willmott et al. 1999) below the volume clusters"},
        s.faces);
    s.faceCone =
        p.getDouble({"cluster.face_cone", "face clusters: normal cone half-angle at most, degrees"},
                    s.faceCone, 0.0, 89.0);
    s.facePlanarity =
        p.getDouble({"cluster.face_planarity", "face clusters: planarity tolerance (relative)"},
                    s.facePlanarity, 0.0, 1.0);
    s.faceShape =
        p.getDouble({"cluster.face_shape", "face clusters: weight of the shape term in merging"},
                    s.faceShape, 0.0, 10.0);
    s.faceCompactness =
        p.getDouble({"cluster.face_compactness", "face clusters: compactness required (0: any)"},
                    s.faceCompactness, 0.0, 1.0);
    if (s.faces && s.builder != "bvh")
        throwInputError({}, "cluster.faces = true needs cluster.builder = bvh (got '{}')",
                        s.builder);
    return s;
}

std::string ClusterSettings::describe() const {
    std::string out =
        fmt::format("cluster(builder={}, leaf_size={}, max_depth={}", builder, leafSize, maxDepth);
    if (faces)
        out += fmt::format(
            ", faces=true, face_cone={}, face_planarity={}, face_shape={}, face_compactness={}",
            faceCone, facePlanarity, faceShape, faceCompactness);
    return out + ")";
}

/// Recursive builders; they fill nodes_ in pre-order and children_ per node.
struct TreeBuilder {
    ClusterTree& t;
    const scene::Scene& s;
    const ClusterSettings& cfg;
    std::vector<scene::Bounds3> pb;  // patch bounds
    std::vector<Vec3> pc;            // patch centroids (of bounds)

    TreeBuilder(ClusterTree& tree, const scene::Scene& scene, const ClusterSettings& settings)
        : t(tree), s(scene), cfg(settings) {
        size_t n = s.patches.size();
        pb.resize(n);
        pc.resize(n);
        for (size_t i = 0; i < n; ++i) {
            const auto& p = s.patches[i];
            for (int k = 0; k < p.numVertices(); ++k) pb[i].expand(p.v[k]);
            pc[i] = pb[i].center();
        }
    }

    uint32_t newNode(uint32_t begin, uint32_t end, int depth) {
        ClusterNode node;
        node.patchBegin = begin;
        node.patchEnd = end;
        node.depth = uint16_t(depth);
        t.nodes_.push_back(node);
        t.depth_ = std::max(t.depth_, depth);
        return uint32_t(t.nodes_.size() - 1);
    }

    void setChildren(uint32_t c, const std::vector<uint32_t>& kids) {
        t.nodes_[c].childBegin = uint32_t(t.children_.size());
        t.nodes_[c].childCount = uint32_t(kids.size());
        t.children_.insert(t.children_.end(), kids.begin(), kids.end());
    }

    // ---- binned SAH BVH ----------------------------------------------------------
    /// Partitions ids[begin, end) (indices into bb / cc: item bounds and
    /// centroids) by the binned SAH and returns the split position.
    uint32_t sahSplit(std::vector<uint32_t>& ids, uint32_t begin, uint32_t end,
                      const std::vector<scene::Bounds3>& bb0, const std::vector<Vec3>& cc) {
        uint32_t n = end - begin;
        scene::Bounds3 cb;
        for (uint32_t i = begin; i < end; ++i) cb.expand(cc[ids[i]]);
        constexpr int kBins = 16;
        double bestCost = INFINITY;
        int bestAxis = -1, bestSplit = -1;
        Vec3 ext = cb.extent();
        for (int axis = 0; axis < 3; ++axis) {
            if (!(ext[axis] > 0)) continue;
            scene::Bounds3 bb[kBins];
            uint32_t cnt[kBins] = {};
            double scale = kBins / ext[axis];
            auto binOf = [&](uint32_t p) {
                int b = int((cc[p][axis] - cb.lo[axis]) * scale);
                return std::clamp(b, 0, kBins - 1);
            };
            for (uint32_t i = begin; i < end; ++i) {
                uint32_t p = ids[i];
                int b = binOf(p);
                ++cnt[b];
                bb[b].expand(bb0[p].lo);
                bb[b].expand(bb0[p].hi);
            }
            // Sweep: cost(split after bin k) = SA(left) N_left + SA(right) N_right.
            double rightArea[kBins];
            uint32_t rightCnt[kBins];
            scene::Bounds3 acc;
            uint32_t accN = 0;
            for (int k = kBins - 1; k > 0; --k) {
                if (cnt[k]) {
                    acc.expand(bb[k].lo);
                    acc.expand(bb[k].hi);
                }
                accN += cnt[k];
                rightArea[k] = halfSurfaceArea(acc);
                rightCnt[k] = accN;
            }
            acc = scene::Bounds3();
            accN = 0;
            for (int k = 0; k < kBins - 1; ++k) {
                if (cnt[k]) {
                    acc.expand(bb[k].lo);
                    acc.expand(bb[k].hi);
                }
                accN += cnt[k];
                if (accN == 0 || rightCnt[k + 1] == 0) continue;
                double cost = halfSurfaceArea(acc) * accN + rightArea[k + 1] * rightCnt[k + 1];
                if (cost < bestCost) {
                    bestCost = cost;
                    bestAxis = axis;
                    bestSplit = k;
                }
            }
        }
        uint32_t mid;
        if (bestAxis < 0) {
            // All centroids coincide: split by count.
            mid = begin + n / 2;
        } else {
            double scale = kBins / ext[bestAxis];
            auto it = std::partition(ids.begin() + begin, ids.begin() + end, [&](uint32_t p) {
                int b = int((cc[p][bestAxis] - cb.lo[bestAxis]) * scale);
                return std::clamp(b, 0, kBins - 1) <= bestSplit;
            });
            mid = uint32_t(it - ids.begin());
            if (mid == begin || mid == end) mid = begin + n / 2;
        }
        return mid;
    }

    uint32_t bvh(uint32_t begin, uint32_t end, int depth) {
        uint32_t c = newNode(begin, end, depth);
        uint32_t n = end - begin;
        if (n <= uint32_t(cfg.leafSize) || depth >= cfg.maxDepth) {
            return c;
        }
        uint32_t mid = sahSplit(t.order_, begin, end, pb, pc);
        std::vector<uint32_t> kids = {bvh(begin, mid, depth + 1), bvh(mid, end, depth + 1)};
        setChildren(c, kids);
        return c;
    }

    // ---- face clusters under a bvh ---------------------------------------------
    // Items of the bvh are the face forest's roots (forest ids: patches or
    // merged nodes); nodes are emitted in pre-order, appending their
    // patches to order_, so ranges are contiguous.
    const FaceForest* ff = nullptr;
    std::vector<scene::Bounds3> fb;  // bounds per forest id
    std::vector<Vec3> fc;            // bounds centre per forest id

    void prepareFaces(const FaceForest& forest) {
        ff = &forest;
        uint32_t k = forest.numPatches;
        fb.assign(k + forest.nodes.size(), scene::Bounds3());
        fc.assign(fb.size(), Vec3(0.0));
        for (uint32_t i = 0; i < k; ++i) fb[i] = pb[i];
        for (uint32_t i = 0; i < forest.nodes.size(); ++i) {
            const auto& nd = forest.nodes[i];
            scene::Bounds3 b = fb[nd.a];
            b.expand(fb[nd.b].lo);
            b.expand(fb[nd.b].hi);
            fb[k + i] = b;
        }
        for (size_t i = 0; i < fb.size(); ++i) fc[i] = fb[i].center();
        t.order_.clear();
    }

    uint32_t openNode(int depth) {
        ClusterNode node;
        node.patchBegin = uint32_t(t.order_.size());
        node.depth = uint16_t(depth);
        t.nodes_.push_back(node);
        t.depth_ = std::max(t.depth_, depth);
        return uint32_t(t.nodes_.size() - 1);
    }

    void closeNode(uint32_t c) {
        ClusterNode& node = t.nodes_[c];
        node.patchEnd = uint32_t(t.order_.size());
    }

    void appendPatches(uint32_t id) {
        std::vector<uint32_t> stack = {id};
        while (!stack.empty()) {
            uint32_t x = stack.back();
            stack.pop_back();
            if (ff->isPatch(x)) {
                t.order_.push_back(x);
            } else {
                stack.push_back(ff->node(x).b);
                stack.push_back(ff->node(x).a);
            }
        }
    }

    uint32_t leafOf(const std::vector<uint32_t>& patches, int depth) {
        uint32_t c = openNode(depth);
        for (uint32_t p : patches) t.order_.push_back(p);
        closeNode(c);
        return c;
    }

    uint32_t emitFace(uint32_t id, int depth) {
        uint32_t c = openNode(depth);
        t.nodes_[c].face = true;
        bool patch = ff->isPatch(id);
        if (t.faces_.size() <= c) t.faces_.resize(c + 1);
        t.faces_[c].coneAxis = patch ? s.patches[id].normal : ff->node(id).coneAxis;
        uint32_t count = patch ? 1 : ff->node(id).patches;
        if (count <= uint32_t(cfg.leafSize)) {
            appendPatches(id);
            closeNode(c);
            return c;
        }
        std::vector<uint32_t> kids;
        for (uint32_t child : {ff->node(id).a, ff->node(id).b})
            kids.push_back(emitFace(child, depth + 1));
        setChildren(c, kids);
        closeNode(c);
        return c;
    }

    uint32_t bvhItems(std::vector<uint32_t>& items, uint32_t begin, uint32_t end, int depth) {
        uint32_t n = end - begin;
        if (n == 1 && !ff->isPatch(items[begin])) return emitFace(items[begin], depth);
        bool allLone = true;
        for (uint32_t i = begin; i < end; ++i) allLone = allLone && ff->isPatch(items[i]);
        if (allLone && (n <= uint32_t(cfg.leafSize) || depth >= cfg.maxDepth))
            return leafOf(std::vector<uint32_t>(items.begin() + begin, items.begin() + end), depth);
        uint32_t c = openNode(depth);
        std::vector<uint32_t> kids;
        if (depth >= cfg.maxDepth) {
            // Depth cap: the face clusters and one leaf of the lone patches.
            std::vector<uint32_t> lone;
            for (uint32_t i = begin; i < end; ++i) {
                if (ff->isPatch(items[i]))
                    lone.push_back(items[i]);
                else
                    kids.push_back(emitFace(items[i], depth + 1));
            }
            if (!lone.empty()) kids.push_back(leafOf(lone, depth + 1));
        } else {
            uint32_t mid = sahSplit(items, begin, end, fb, fc);
            kids = {bvhItems(items, begin, mid, depth + 1), bvhItems(items, mid, end, depth + 1)};
        }
        setChildren(c, kids);
        closeNode(c);
        return c;
    }

    // ---- octree ---------------------------------------------------------------
    uint32_t octree(uint32_t begin, uint32_t end, int depth, Vec3 lo, double size) {
        uint32_t c = newNode(begin, end, depth);
        buildOctreeChildren(c, begin, end, depth, lo, size);
        return c;
    }

    void buildOctreeChildren(uint32_t c, uint32_t begin, uint32_t end, int depth, Vec3 lo,
                             double size) {
        uint32_t n = end - begin;
        for (int guard = 0;; ++guard) {
            if (n <= uint32_t(cfg.leafSize) || depth >= cfg.maxDepth || guard > 60) {
                return;
            }
            double h = 0.5 * size;
            Vec3 mid = lo + Vec3(h);
            auto octant = [&](uint32_t p) {
                return (pc[p].x >= mid.x ? 1 : 0) | (pc[p].y >= mid.y ? 2 : 0) |
                       (pc[p].z >= mid.z ? 4 : 0);
            };
            std::sort(t.order_.begin() + begin, t.order_.begin() + end,
                      [&](uint32_t a, uint32_t b) {
                          int oa = octant(a), ob = octant(b);
                          return oa != ob ? oa < ob : a < b;
                      });
            uint32_t counts[8] = {};
            for (uint32_t i = begin; i < end; ++i) ++counts[octant(t.order_[i])];
            int nonEmpty = 0, only = -1;
            for (int o = 0; o < 8; ++o)
                if (counts[o]) {
                    ++nonEmpty;
                    only = o;
                }
            if (nonEmpty == 1) {
                // Collapse a chain of single children: shrink the cube in place.
                lo = lo + Vec3(only & 1 ? h : 0, only & 2 ? h : 0, only & 4 ? h : 0);
                size = h;
                continue;
            }
            std::vector<uint32_t> kids;
            uint32_t start = begin;
            for (int o = 0; o < 8; ++o) {
                if (!counts[o]) continue;
                Vec3 clo = lo + Vec3(o & 1 ? h : 0, o & 2 ? h : 0, o & 4 ? h : 0);
                kids.push_back(octree(start, start + counts[o], depth + 1, clo, h));
                start += counts[o];
            }
            setChildren(c, kids);
            return;
        }
    }
};

ClusterTree::ClusterTree(const scene::Scene& scene, const ClusterSettings& settings,
                         const std::vector<uint8_t>& include)
    : scene_(&scene), settings_(settings) {
    faceConeCos_ = std::cos(settings.faceCone * kPi / 180.0);
    Timer timer;
    if (!include.empty() && !settings.faces) {
        HRAD_CHECK(include.size() == scene.patches.size());
        for (uint32_t p = 0; p < uint32_t(include.size()); ++p)
            if (include[p]) order_.push_back(p);
    } else {
        order_.resize(scene.patches.size());
        std::iota(order_.begin(), order_.end(), 0u);
    }
    size_t n = order_.size();
    HRAD_CHECK(n > 0);
    TreeBuilder b(*this, scene, settings);
    nodes_.reserve(2 * n / size_t(std::max(1, settings.leafSize)) + 16);
    if (settings.builder == "bvh" && settings.faces) {
        FaceClusterParams fp;
        fp.coneDegrees = settings.faceCone;
        fp.planarity = settings.facePlanarity;
        fp.shapeWeight = settings.faceShape;
        fp.compactness = settings.faceCompactness;
        FaceForest forest = buildFaceForest(scene, fp);
        b.prepareFaces(forest);
        std::vector<uint32_t> items = forest.roots;
        b.bvhItems(items, 0, uint32_t(items.size()), 0);
        HRAD_CHECK(order_.size() == n);
    } else if (settings.builder == "bvh") {
        b.bvh(0, uint32_t(n), 0);
    } else if (settings.builder == "octree") {
        scene::Bounds3 all = scene.bounds();
        Vec3 e = all.extent();
        double size = std::max({e.x, e.y, e.z}) * (1 + 1e-9) + 1e-12;
        b.octree(0, uint32_t(n), 0, all.lo, size);
    } else {
        throwInputError({}, "unknown cluster builder '{}'; valid builders: {}", settings.builder,
                        fmt::join(kBuilders, ", "));
    }
    finalize();
    buildSeconds_ = timer.seconds();
}

void ClusterTree::finalize() {
    // The builders grow these by doubling; the tree lives as long as the solve.
    nodes_.shrink_to_fit();
    children_.shrink_to_fit();
    if (settings_.faces) {
        faces_.resize(nodes_.size());  // volume nodes above the face clusters: the default
        faces_.shrink_to_fit();
    }
    const auto& P = scene_->patches;
    areaPrefix_.resize(order_.size() + 1);
    areaPrefix_[0] = 0;
    for (size_t i = 0; i < order_.size(); ++i)
        areaPrefix_[i + 1] = areaPrefix_[i] + P[order_[i]].area;
    // Only a quad reads its halves (pointOnPatch), so they are stored where
    // quads are at least a quarter of the patches, and computed per point
    // elsewhere (the same arithmetic, so the same points).
    const size_t quads = size_t(std::count_if(P.begin(), P.end(), [](const scene::Patch& p) {
        return p.kind != scene::PatchKind::Triangle;
    }));
    halves_.assign(4 * quads >= P.size() ? P.size() : 0, {0.0, 0.0});
    halves_.shrink_to_fit();
    for (size_t i = 0; i < halves_.size(); ++i)
        if (P[i].kind != scene::PatchKind::Triangle) halves_[i] = quadHalves(P[i]);
    parent_.assign(nodes_.size(), UINT32_MAX);
    patchCluster_.assign(P.size(), UINT32_MAX);
    // Children have larger indices than parents: accumulate bottom-up.
    for (size_t ci = nodes_.size(); ci-- > 0;) {
        ClusterNode& c = nodes_[ci];
        for (uint32_t i = 0; i < c.childCount; ++i)
            parent_[children_[c.childBegin + i]] = uint32_t(ci);
        for (uint32_t i = c.ownBegin(); i < c.ownEnd(); ++i) patchCluster_[order_[i]] = uint32_t(ci);
        double a = 0;
        RGB rho(0.0);
        Vec3 cen(0.0), S(0.0);
        std::array<double, 6> M{};
        scene::Bounds3 box;  // of every vertex below: what the sphere must hold
        for (uint32_t i = c.patchBegin; i < c.patchEnd; ++i) {
            const auto& p = P[order_[i]];
            for (int k = 0; k < p.numVertices(); ++k) box.expand(p.v[k]);
            a += p.area;
            rho += p.area * p.rho;
            cen += p.area * p.centroid();
            S += p.area * p.normal;
            const Vec3& nn = p.normal;
            M[0] += p.area * nn.x * nn.x;
            M[1] += p.area * nn.x * nn.y;
            M[2] += p.area * nn.x * nn.z;
            M[3] += p.area * nn.y * nn.y;
            M[4] += p.area * nn.y * nn.z;
            M[5] += p.area * nn.z * nn.z;
        }
        c.area = a;
        c.rho = a > 0 ? rho / a : RGB(0.0);
        c.centroid = a > 0 ? cen / a : box.center();
        c.normalSum = S;
        c.normalMoment = M;
        // Sphere around the centroid containing the whole box.
        double r2 = 0;
        for (int k = 0; k < 8; ++k) {
            Vec3 corner(k & 1 ? box.hi.x : box.lo.x, k & 2 ? box.hi.y : box.lo.y,
                        k & 4 ? box.hi.z : box.lo.z);
            r2 = std::max(r2, glm::dot(corner - c.centroid, corner - c.centroid));
        }
        c.radius = std::sqrt(r2);
        if (c.face) {
            // Normal cone around the builder's axis, and planarity: the
            // largest vertex distance from the least-squares plane over the
            // radius.
            FaceShape& fs = faces_[ci];
            AreaMoments m;
            double minCos = 1.0;
            for (uint32_t i = c.patchBegin; i < c.patchEnd; ++i) {
                const auto& p = P[order_[i]];
                m.addPatch(p);
                minCos = std::min(minCos, glm::dot(p.normal, fs.coneAxis));
            }
            fs.coneCos = minCos;
            PlaneFit f = fitPlane(m, fs.coneAxis);
            fs.planeNormal = f.normal;
            double dmax = 0.0;
            for (uint32_t i = c.patchBegin; i < c.patchEnd; ++i) {
                const auto& p = P[order_[i]];
                for (int v = 0; v < p.numVertices(); ++v)
                    dmax = std::max(dmax, std::abs(glm::dot(p.v[v] - f.centroid, f.normal)));
            }
            fs.planarity = c.radius > 0 ? std::min(1.0, dmax / c.radius) : 0.0;
        }
    }
}

bool ClusterTree::planarFace(uint32_t ci) const {
    if (!nodes_[ci].face) return false;
    const FaceShape& f = faces_[ci];
    return f.coneCos >= faceConeCos_ && f.planarity <= settings_.facePlanarity;
}

bool ClusterTree::flatFace(uint32_t ci) const {
    if (!nodes_[ci].face) return false;
    const FaceShape& f = faces_[ci];
    return f.coneCos >= 1.0 - 1e-12 && f.planarity <= 1e-9;
}

uint32_t ClusterTree::numFaceNodes() const {
    uint32_t n = 0;
    for (const auto& c : nodes_) n += c.face;
    return n;
}

uint32_t ClusterTree::numPlanarFaceNodes() const {
    uint32_t n = 0;
    for (uint32_t c = 0; c < size(); ++c) n += planarFace(c);
    return n;
}

uint64_t ClusterTree::memoryBytes() const {
    return nodes_.capacity() * sizeof(ClusterNode) + faces_.capacity() * sizeof(FaceShape) +
           children_.capacity() * sizeof(uint32_t) + order_.capacity() * sizeof(uint32_t) +
           areaPrefix_.capacity() * sizeof(double) + halves_.capacity() * sizeof(halves_[0]) +
           parent_.capacity() * sizeof(uint32_t) + patchCluster_.capacity() * sizeof(uint32_t);
}

double ClusterTree::projectedArea(uint32_t ci, const Vec3& d) const {
    const ClusterNode& c = nodes_[ci];
    const auto& M = c.normalMoment;
    double q = d.x * (M[0] * d.x + M[1] * d.y + M[2] * d.z) +
               d.y * (M[1] * d.x + M[3] * d.y + M[4] * d.z) +
               d.z * (M[2] * d.x + M[4] * d.y + M[5] * d.z);
    double absPart = std::sqrt(std::max(0.0, c.area * q));  // >= sum A |n.d|
    double v = 0.5 * (absPart + glm::dot(c.normalSum, d));
    return std::clamp(v, 0.0, c.area);
}

uint32_t ClusterTree::samplePatch(uint32_t ci, double u0) const {
    const ClusterNode& c = nodes_[ci];
    double lo = areaPrefix_[c.patchBegin], hi = areaPrefix_[c.patchEnd];
    double target = lo + u0 * (hi - lo);
    auto it = std::upper_bound(areaPrefix_.begin() + c.patchBegin + 1,
                               areaPrefix_.begin() + c.patchEnd + 1, target);
    size_t idx = size_t(it - areaPrefix_.begin()) - 1;
    idx = std::min<size_t>(std::max<size_t>(idx, c.patchBegin), c.patchEnd - 1);
    return order_[idx];
}

Vec3 ClusterTree::samplePoint(uint32_t ci, double u0, double u1, double u2, uint32_t& patch) const {
    patch = samplePatch(ci, u0);
    return pointOnPatch(patch, u1, u2);
}

std::array<double, 2> ClusterTree::quadHalves(const scene::Patch& p) {
    const auto& v = p.v;
    return {glm::length(glm::cross(v[1] - v[0], v[2] - v[0])),
            glm::length(glm::cross(v[2] - v[0], v[3] - v[0]))};
}

Vec3 ClusterTree::pointOnPatch(uint32_t patch, double u1, double u2) const {
    const auto& p = scene_->patches[patch];
    // Uniform point on a triangle (a, b, c) from (u1, u2).
    auto tri = [&](const Vec3& a, const Vec3& b, const Vec3& cc) {
        double su = std::sqrt(u1);
        return (1 - su) * a + su * (1 - u2) * b + su * u2 * cc;
    };
    if (p.kind == scene::PatchKind::Triangle) return tri(p.v[0], p.v[1], p.v[2]);
    const std::array<double, 2> h = halves_.empty() ? quadHalves(p) : halves_[patch];
    const double a1 = h[0], a2 = h[1];
    double pick = u2 * (a1 + a2);
    if (pick < a1) {
        u2 = a1 > 0 ? pick / a1 : 0.5;
        return tri(p.v[0], p.v[1], p.v[2]);
    }
    u2 = a2 > 0 ? (pick - a1) / a2 : 0.5;
    return tri(p.v[0], p.v[2], p.v[3]);
}

}  // namespace hrad::cluster
