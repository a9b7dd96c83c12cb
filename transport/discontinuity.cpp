// Discontinuity meshing (see discontinuity.h for the method and papers).
#include "transport/discontinuity.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "core/log.h"
#include "core/timer.h"
#include "scene/triangulate.h"
#include "transport/visibility.h"

namespace hrad::transport {

namespace {

using scene::Patch;

std::vector<Vec3> corners(const Patch& p) {
    return std::vector<Vec3>(p.v.begin(), p.v.begin() + p.numVertices());
}

double diameterOf(const std::vector<Vec3>& v) {
    double d = 0;
    for (const Vec3& a : v)
        for (const Vec3& b : v) d = std::max(d, glm::length(a - b));
    return d;
}

// ---- which patches share a vertex (silhouette and tangency tests) -----------

struct VecHash {
    size_t operator()(const Vec3& v) const {
        const std::hash<double> h;
        return h(v.x) ^ (h(v.y) * 31) ^ (h(v.z) * 1000003);
    }
};

/// Patches by corner (exact coordinates: meshes share their vertices).
class Incidence {
  public:
    explicit Incidence(const scene::Scene& s) {
        for (uint32_t i = 0; i < s.patches.size(); ++i)
            for (const Vec3& c : corners(s.patches[i])) at_[c].push_back(i);
    }
    const std::vector<uint32_t>& at(const Vec3& c) const {
        static const std::vector<uint32_t> none;
        auto it = at_.find(c);
        return it == at_.end() ? none : it->second;
    }

  private:
    std::unordered_map<Vec3, std::vector<uint32_t>, VecHash> at_;
};

/// Signs of dot(x - o, m) over `pts` with tolerance: bit 1 some > tol, bit 2 some < -tol.
int sides(const std::vector<Vec3>& pts, const Vec3& o, const Vec3& m, double tol) {
    int s = 0;
    for (const Vec3& x : pts) {
        const double d = glm::dot(x - o, m);
        if (d > tol) s |= 1;
        if (d < -tol) s |= 2;
    }
    return s;
}

// ---- candidate occluders: an AABB tree and the shaft of (source, receiver) ---

class BoxTree {
  public:
    explicit BoxTree(const scene::Scene& s) {
        items_.resize(s.patches.size());
        std::iota(items_.begin(), items_.end(), 0u);
        boxes_.resize(s.patches.size());
        for (uint32_t i = 0; i < s.patches.size(); ++i)
            for (const Vec3& c : corners(s.patches[i])) boxes_[i].expand(c);
        if (!items_.empty()) build(0, uint32_t(items_.size()));
    }
    /// Calls fn(patch) for each patch whose box meets `q`.
    template <class Fn>
    void query(const scene::Bounds3& q, Fn&& fn) const {
        if (nodes_.empty()) return;
        std::vector<uint32_t> stack{0};
        while (!stack.empty()) {
            const Node& n = nodes_[stack.back()];
            stack.pop_back();
            if (!overlaps(n.box, q)) continue;
            if (n.count > 0) {
                for (uint32_t k = n.first; k < n.first + n.count; ++k)
                    if (overlaps(boxes_[items_[k]], q)) fn(items_[k]);
            } else {
                stack.push_back(n.first);
                stack.push_back(n.right);
            }
        }
    }

  private:
    struct Node {
        scene::Bounds3 box;
        uint32_t first = 0, count = 0;  ///< leaf: items [first, first + count)
        uint32_t right = 0;             ///< inner (count 0): children first and right
    };
    static bool overlaps(const scene::Bounds3& a, const scene::Bounds3& b) {
        return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y &&
               a.lo.z <= b.hi.z && b.lo.z <= a.hi.z;
    }
    // Median split on the widest axis of the centroids.
    uint32_t build(uint32_t lo, uint32_t hi) {
        const uint32_t id = uint32_t(nodes_.size());
        nodes_.emplace_back();
        scene::Bounds3 box, cent;
        for (uint32_t k = lo; k < hi; ++k) {
            box.expand(boxes_[items_[k]].lo);
            box.expand(boxes_[items_[k]].hi);
            cent.expand(boxes_[items_[k]].center());
        }
        nodes_[id].box = box;
        if (hi - lo <= 4) {
            nodes_[id].first = lo;
            nodes_[id].count = hi - lo;
            return id;
        }
        const Vec3 e = cent.extent();
        const int axis = e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
        const uint32_t mid = (lo + hi) / 2;
        std::nth_element(items_.begin() + lo, items_.begin() + mid, items_.begin() + hi,
                         [&](uint32_t a, uint32_t b) {
                             return boxes_[a].center()[axis] < boxes_[b].center()[axis];
                         });
        const uint32_t left = build(lo, mid);
        const uint32_t right = build(mid, hi);
        nodes_[id].first = left;
        nodes_[id].right = right;
        return id;
    }

    std::vector<uint32_t> items_;
    std::vector<scene::Bounds3> boxes_;
    std::vector<Node> nodes_;
};

struct Plane {
    Vec3 o, m;  ///< outside: dot(x - o, m) > tol
};

/// Faces of the convex hull of two convex polygons: every plane through an
/// edge of one and a vertex of the other with all vertices on one side.
std::vector<Plane> hullPlanes(const std::vector<Vec3>& a, const std::vector<Vec3>& b, double tol) {
    std::vector<Vec3> all = a;
    all.insert(all.end(), b.begin(), b.end());
    std::vector<Plane> out;
    for (int pass = 0; pass < 2; ++pass) {
        const std::vector<Vec3>& e = pass ? b : a;
        const std::vector<Vec3>& v = pass ? a : b;
        for (size_t i = 0; i < e.size(); ++i)
            for (const Vec3& x : v) {
                const Vec3 p = e[i], q = e[(i + 1) % e.size()];
                Vec3 m = glm::cross(q - p, x - p);
                const double len = glm::length(m);
                if (len <= 1e-12 * glm::dot(q - p, q - p)) continue;
                m /= len;
                const int s = sides(all, p, m, tol);
                if (s == 1) out.push_back({p, -m});
                if (s == 2) out.push_back({p, m});
            }
    }
    return out;
}

// ---- the receiver's plane ---------------------------------------------------

struct Frame {
    Vec3 o, u, w, n;  ///< origin, in-plane axes, normal of the lit side (negated: lit from the back)
    Vec2 to2(const Vec3& x) const { return Vec2(glm::dot(x - o, u), glm::dot(x - o, w)); }
    Vec3 to3(const Vec2& p) const { return o + p.x * u + p.y * w; }
    double height(const Vec3& x) const { return glm::dot(x - o, n); }
};

Frame frameOf(const Patch& p) {
    Frame f;
    f.o = p.v[0];
    f.n = p.normal;
    Vec3 u = p.v[1] - p.v[0];
    f.u = glm::normalize(u - glm::dot(u, f.n) * f.n);
    f.w = glm::cross(f.n, f.u);  // CCW in (u, w) is CCW around the normal
    return f;
}

/// Clips [a, b] to the convex polygon `poly` (CCW); false when nothing is left.
bool clipToPolygon(const std::vector<Vec2>& poly, Vec2& a, Vec2& b) {
    double t0 = 0, t1 = 1;
    const Vec2 d = b - a;
    for (size_t i = 0; i < poly.size(); ++i) {
        const Vec2 p = poly[i], e = poly[(i + 1) % poly.size()] - p;
        const double num = e.x * (a.y - p.y) - e.y * (a.x - p.x);  // >= 0 inside
        const double den = e.x * d.y - e.y * d.x;
        if (den == 0) {
            if (num < 0) return false;
            continue;
        }
        const double t = -num / den;
        if (den > 0) t0 = std::max(t0, t);
        else t1 = std::min(t1, t);
        if (t0 > t1) return false;
    }
    const Vec2 a0 = a;
    a = a0 + t0 * d;
    b = a0 + t1 * d;
    return true;
}

// ---- events ---------------------------------------------------------------

/// One critical segment on a receiver: the 2D cut and what casts it (for the
/// visibility test): the lines from a point of `sourceEdge` (or the point
/// source vertex) through a point of `occEdge` (or the occluder vertex).
struct Curve {
    Vec2 a, b;
    Vec3 s0, s1;  ///< source vertex (s0 == s1, EV) or source edge (VE)
    Vec3 o0, o1;  ///< occluder edge (EV) or occluder vertex (o0 == o1, VE)
    uint32_t occluder = 0, source = 0;
    double length() const { return glm::length(b - a); }
};

/// The central projection onto the receiver's plane of the lines through
/// L(t) = s0 + t (s1 - s0) and O(t) = o0 + t (o1 - o0), t in [0, 1] (one of
/// the two is a point), continued beyond O: p = L + (O - L) hL / (hL - hO).
/// Kept where 0 <= hO <= (1 - eps) hL, so the line meets the plane beyond the
/// occluder at a bounded distance (eps from the receiver's size: every point
/// of the receiver is kept). Returns false when no part reaches the plane.
double pointSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
    const Vec3 d = b - a;
    const double dd = glm::dot(d, d);
    const double t = dd > 0 ? std::clamp(glm::dot(p - a, d) / dd, 0.0, 1.0) : 0.0;
    return glm::length(a + t * d - p);
}

bool projectEvent(const Frame& f, double receiverDiameter, Curve& c, Vec3& pa, Vec3& pb) {
    const double hl0 = f.height(c.s0), hl1 = f.height(c.s1);
    const double ho0 = f.height(c.o0), ho1 = f.height(c.o1);
    // A receiver point at distance R from L lies at k = |p - L| / |O - L| <=
    // R / dmin along the line, so hO <= hL (1 - dmin / (2 R)) keeps it
    // (k = hL / (hL - hO)). One of the two ends is a point.
    const double dmin = c.s0 == c.s1 ? pointSegment(c.s0, c.o0, c.o1)
                                     : pointSegment(c.o0, c.s0, c.s1);
    const double far =
        std::max(glm::length(c.s0 - f.o), glm::length(c.s1 - f.o)) + receiverDiameter;
    const double eps = std::clamp(0.5 * dmin / std::max(far, 1e-300), 1e-9, 0.5);
    double t0 = 0, t1 = 1;
    // Linear constraints g(t) = g0 + t (g1 - g0) >= 0.
    auto keep = [&](double g0, double g1) {
        if (g0 < 0 && g1 < 0) return false;
        if (g0 < 0) t0 = std::max(t0, g0 / (g0 - g1));
        if (g1 < 0) t1 = std::min(t1, g0 / (g0 - g1));
        return t0 <= t1;
    };
    if (!keep(ho0, ho1) || !keep((1 - eps) * hl0 - ho0, (1 - eps) * hl1 - ho1)) return false;
    auto at = [&](double t) {
        const Vec3 L = c.s0 + t * (c.s1 - c.s0), O = c.o0 + t * (c.o1 - c.o0);
        const double hl = f.height(L), ho = f.height(O);
        return L + (O - L) * (hl / (hl - ho));
    };
    pa = at(t0);
    pb = at(t1);
    return std::isfinite(pa.x + pa.y + pa.z + pb.x + pb.y + pb.z);
}

struct PairContext {
    const scene::Scene& scene;
    const Incidence& inc;
    const Frame& frame;
    const std::vector<Vec2>& poly2;
    double diameter, tol;
};

/// Clips a projected event to the receiver and keeps it when long enough.
void addCurve(const PairContext& pc, Curve c, const Vec3& pa, const Vec3& pb, double minLen,
              std::vector<Curve>& out) {
    c.a = pc.frame.to2(pa);
    c.b = pc.frame.to2(pb);
    if (!clipToPolygon(pc.poly2, c.a, c.b) || c.length() < minLen) return;
    out.push_back(c);
}

/// The vertices (other than the edge's or vertex's own) of the patches
/// incident on a vertex (both ends, for an edge: those sharing the edge).
std::vector<Vec3> neighbourVertices(const PairContext& pc, uint32_t occ, const Vec3& a,
                                    const Vec3* b) {
    std::vector<Vec3> out;
    auto add = [&](uint32_t q) {
        for (const Vec3& x : corners(pc.scene.patches[q]))
            if (x != a && (!b || x != *b)) out.push_back(x);
    };
    const std::vector<uint32_t>& at = pc.inc.at(a);
    if (at.empty()) add(occ);
    for (uint32_t q : at) {
        if (!b) {
            add(q);
            continue;
        }
        const std::vector<Vec3> cq = corners(pc.scene.patches[q]);
        if (std::find(cq.begin(), cq.end(), *b) != cq.end()) add(q);
    }
    return out;
}

/// EV and VE events of source `src` and occluder `occ` on the receiver.
void pairEvents(const PairContext& pc, uint32_t src, uint32_t occ, double minLen,
                std::vector<Curve>& out) {
    const std::vector<Vec3> sv = corners(pc.scene.patches[src]);
    const std::vector<Vec3> ov = corners(pc.scene.patches[occ]);
    Vec3 pa, pb;
    // EV: source vertex V, occluder edge (a, b). The plane must be tangent to
    // the source at V and the edge a silhouette seen from V.
    for (size_t e = 0; e < ov.size(); ++e) {
        const Vec3 a = ov[e], b = ov[(e + 1) % ov.size()];
        const std::vector<Vec3> nb = neighbourVertices(pc, occ, a, &b);
        for (const Vec3& V : sv) {
            Vec3 m = glm::cross(b - a, V - a);
            const double len = glm::length(m);
            if (len == 0) continue;
            m /= len;
            const int ss = sides(sv, a, m, pc.tol), so = sides(nb, a, m, pc.tol);
            if (ss == 3 || ss == 0 || so == 3 || so == 0) continue;
            Curve c{{}, {}, V, V, a, b, occ, src};
            if (projectEvent(pc.frame, pc.diameter, c, pa, pb)) addCurve(pc, c, pa, pb, minLen, out);
        }
    }
    // VE: occluder vertex v, source edge (c0, c1). Tangent to the occluder at v.
    for (const Vec3& v : ov) {
        const std::vector<Vec3> nb = neighbourVertices(pc, occ, v, nullptr);
        for (size_t e = 0; e < sv.size(); ++e) {
            const Vec3 c0 = sv[e], c1 = sv[(e + 1) % sv.size()];
            Vec3 m = glm::cross(c1 - c0, v - c0);
            const double len = glm::length(m);
            if (len == 0) continue;
            m /= len;
            const int so = sides(nb, v, m, pc.tol), ss = sides(sv, c0, m, pc.tol);
            if (so == 3 || so == 0 || ss == 0) continue;
            Curve c{{}, {}, c0, c1, v, v, occ, src};
            if (projectEvent(pc.frame, pc.diameter, c, pa, pb)) addCurve(pc, c, pa, pb, minLen, out);
        }
    }
}

// ---- hidden critical surfaces --------------------------------------------

/// Closest point on line (p, q) to line (a, b) (the lines meet: they lie in
/// the event's plane).
Vec3 lineMeet(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b) {
    const Vec3 d1 = q - p, d2 = b - a, r = p - a;
    const double aa = glm::dot(d1, d1), bb = glm::dot(d1, d2), cc = glm::dot(d2, d2);
    const double dd = glm::dot(d1, r), ee = glm::dot(d2, r);
    const double den = aa * cc - bb * bb;
    if (std::abs(den) <= 1e-300) return p;
    return p + d1 * ((bb * ee - cc * dd) / den);
}

/// True when the critical lines of `c` are blocked at all three sample points
/// (receiver -> occluder, occluder -> source, by surfaces other than theirs).
bool hiddenCurve(const Frame& f, const Visibility& vis, uint32_t receiver, const Curve& c) {
    std::array<Segment, 6> segs;
    const double fr[3] = {0.2, 0.5, 0.8};
    for (int k = 0; k < 3; ++k) {
        const Vec3 P = f.to3(c.a + fr[k] * (c.b - c.a));
        // EV: the line from the source vertex through P meets the edge at q.
        // VE: the line from P through the occluder vertex meets the source edge at L.
        const bool ev = c.s0 == c.s1;
        const Vec3 q = ev ? lineMeet(c.s0, P, c.o0, c.o1) : c.o0;
        const Vec3 L = ev ? c.s0 : lineMeet(P, c.o0, c.s0, c.s1);
        // Every end steps 1e-3 of its segment inwards: off the occluder's
        // edge (only the event's own line is tested), off the receiver's
        // and the source's boundary (a source vertex is a corner its frame
        // shares: a window in its reveal).
        const double d = 1e-3;
        segs[size_t(2 * k)] = Segment{P + d * (q - P), q + d * (P - q), receiver, c.occluder};
        segs[size_t(2 * k + 1)] = Segment{q + d * (L - q), L + d * (q - L), c.occluder, c.source};
    }
    std::array<uint8_t, 6> blocked{};
    vis.occluded(segs.data(), segs.size(), blocked.data());
    for (int k = 0; k < 3; ++k)
        if (!blocked[size_t(2 * k)] && !blocked[size_t(2 * k + 1)]) return false;
    return true;
}

// ---- per receiver -------------------------------------------------------------

struct Sources {
    std::vector<uint32_t> ids;
};

Sources pickSources(const scene::Scene& s, const scene::DiscontinuitySettings& st) {
    Sources out;
    std::vector<uint32_t> reflectors;
    for (uint32_t i = 0; i < s.patches.size(); ++i) {
        if (s.patches[i].isEmitter()) out.ids.push_back(i);
        else if (luminance(s.patches[i].rho) > 0) reflectors.push_back(i);
    }
    if (st.mode == scene::DiscontinuitySettings::Mode::EmittersOccluders) {
        auto weight = [&](uint32_t i) { return s.patches[i].area * luminance(s.patches[i].rho); };
        const size_t k = std::min(reflectors.size(), size_t(st.secondarySources));
        std::partial_sort(reflectors.begin(), reflectors.begin() + long(k), reflectors.end(),
                          [&](uint32_t a, uint32_t b) { return weight(a) > weight(b); });
        out.ids.insert(out.ids.end(), reflectors.begin(), reflectors.begin() + long(k));
    }
    return out;
}

struct Shared {
    const scene::Scene& scene;
    const scene::DiscontinuitySettings& settings;
    const Incidence& inc;
    const BoxTree& tree;
    const Visibility& vis;
    const Sources& sources;
    double sceneTol;
};

/// Occluder candidates of (receiver, source): in the shaft, largest first.
std::vector<uint32_t> shaftOccluders(const Shared& sh, uint32_t r, uint32_t s, const Frame& f,
                                     scene::DiscontinuityStats& st) {
    const std::vector<Vec3> rv = corners(sh.scene.patches[r]), sv = corners(sh.scene.patches[s]);
    const std::vector<Plane> hull = hullPlanes(sv, rv, sh.sceneTol);
    scene::Bounds3 box;
    for (const Vec3& x : rv) box.expand(x);
    for (const Vec3& x : sv) box.expand(x);
    std::vector<uint32_t> out;
    sh.tree.query(box, [&](uint32_t o) {
        if (o == r || o == s) return;
        const std::vector<Vec3> ov = corners(sh.scene.patches[o]);
        if (!(sides(ov, f.o, f.n, sh.sceneTol) & 1)) return;  // on or behind the receiver
        for (const Plane& pl : hull)
            if (sides(ov, pl.o, pl.m, sh.sceneTol) == 1) return;  // outside a hull face
        out.push_back(o);
    });
    st.occluders += out.size();
    if (out.size() > size_t(sh.settings.maxOccluders)) {
        std::sort(out.begin(), out.end(), [&](uint32_t a, uint32_t b) {
            return sh.scene.patches[a].area > sh.scene.patches[b].area;
        });
        st.occludersDropped += out.size() - size_t(sh.settings.maxOccluders);
        out.resize(size_t(sh.settings.maxOccluders));
    }
    return out;
}

/// The receiver's frame lit by source s, or false when s does not light it
/// (behind its plane, straddling it, or facing away).
bool litFrame(const Shared& sh, uint32_t r, uint32_t s, Frame& f) {
    const Patch& rp = sh.scene.patches[r];
    const Patch& sp = sh.scene.patches[s];
    f = frameOf(rp);
    const std::vector<Vec3> sv = corners(sp), rv = corners(rp);
    const int side = sides(sv, f.o, f.n, sh.sceneTol);
    if (side == 2 && sh.scene.materials[rp.material].twoSided) {
        f.n = -f.n;
    } else if (side != 1) {
        return false;
    }
    const scene::Material& sm = sh.scene.materials[sp.material];
    const bool bothSides = sm.twoSided && (sm.emitsBothSides || !sp.isEmitter());
    const int facing = sides(rv, sp.v[0], sp.normal, sh.sceneTol);
    return bothSides ? facing != 0 : (facing & 1) != 0;
}

struct ReceiverCut {
    std::vector<std::array<Vec3, 3>> pieces;
    scene::DiscontinuityStats st;
};

/// Every source's curves on receiver r, limited and culled.
std::vector<Curve> receiverCurves(const Shared& sh, uint32_t r, const std::vector<Vec2>& poly2,
                                  double diam, Frame& f, scene::DiscontinuityStats& st) {
    std::vector<Curve> curves;
    for (uint32_t s : sh.sources.ids) {
        if (s == r || !litFrame(sh, r, s, f)) continue;
        ++st.pairs;
        const PairContext pc{sh.scene, sh.inc, f, poly2, diam, sh.sceneTol};
        const size_t before = curves.size();
        for (uint32_t o : shaftOccluders(sh, r, s, f, st))
            pairEvents(pc, s, o, sh.settings.minCurve * diam, curves);
        st.events += curves.size() - before;
        if (sh.settings.cullHidden) {
            auto hidden = [&](const Curve& c) { return hiddenCurve(f, sh.vis, r, c); };
            auto it = std::remove_if(curves.begin() + long(before), curves.end(), hidden);
            st.hidden += uint64_t(curves.end() - it);
            curves.erase(it, curves.end());
        }
    }
    if (curves.size() > size_t(sh.settings.maxCurves)) {
        std::sort(curves.begin(), curves.end(),
                  [](const Curve& a, const Curve& b) { return a.length() > b.length(); });
        st.curvesDropped += curves.size() - size_t(sh.settings.maxCurves);
        curves.resize(size_t(sh.settings.maxCurves));
    }
    return curves;
}

ReceiverCut cutReceiver(const Shared& sh, uint32_t r) {
    ReceiverCut out;
    const Patch& rp = sh.scene.patches[r];
    if (luminance(rp.rho) <= 0) return out;  // reflects nothing: no shadow to resolve
    const std::vector<Vec3> rv = corners(rp);
    const double diam = diameterOf(rv);
    Frame f = frameOf(rp);
    std::vector<Vec2> poly2;
    for (const Vec3& x : rv) poly2.push_back(f.to2(x));
    const std::vector<Curve> curves = receiverCurves(sh, r, poly2, diam, f, out.st);
    if (curves.empty()) return out;
    std::vector<std::pair<Vec2, Vec2>> segs;
    for (const Curve& c : curves) segs.emplace_back(c.a, c.b);
    scene::PlanarCut cut;
    // One face: every curve ran along the boundary (a wall's edge on the
    // floor it stands on); the patch stays whole.
    if (!scene::cutConvexPolygon(poly2, segs, 1e-6 * diam, cut) || cut.faces < 2 ||
        cut.triangles.size() < 2)
        return out;
    out.st.curves = curves.size();
    out.st.faces = cut.faces;
    out.st.thin = cut.thin;
    // Back to 3D on the patch's plane; the patch's own corners exactly.
    const Frame plane = frameOf(rp);
    double area = 0;
    for (const auto& t : cut.triangles) {
        std::array<Vec3, 3> p;
        for (size_t k = 0; k < 3; ++k) {
            p[k] = plane.to3(t[k]);
            for (size_t j = 0; j < poly2.size(); ++j)
                if (t[k] == poly2[j]) p[k] = rv[j];
        }
        area += 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
        out.pieces.push_back(p);
    }
    out.st.thinArea = std::max(0.0, rp.area - area);
    out.st.cutPatches = 1;
    out.st.pieces = out.pieces.size();
    return out;
}

void addStats(scene::DiscontinuityStats& a, const scene::DiscontinuityStats& b) {
    a.pairs += b.pairs;
    a.occluders += b.occluders;
    a.occludersDropped += b.occludersDropped;
    a.events += b.events;
    a.hidden += b.hidden;
    a.curvesDropped += b.curvesDropped;
    a.curves += b.curves;
    a.cutPatches += b.cutPatches;
    a.pieces += b.pieces;
    a.faces += b.faces;
    a.thin += b.thin;
    a.thinArea += b.thinArea;
}

/// The cut scene: each patch, or its pieces in its place.
void replacePatches(scene::Scene& scene, const std::vector<ReceiverCut>& cuts,
                    std::vector<uint32_t>& origin) {
    std::vector<Patch> out;
    origin.clear();
    for (uint32_t i = 0; i < scene.patches.size(); ++i) {
        const Patch& p = scene.patches[i];
        if (cuts[i].pieces.empty()) {
            out.push_back(p);
            origin.push_back(i);
            continue;
        }
        for (const auto& t : cuts[i].pieces) {
            Patch q = p;
            q.kind = scene::PatchKind::Triangle;
            q.v = {t[0], t[1], t[2], t[2]};
            q.area = 0.5 * glm::length(glm::cross(t[1] - t[0], t[2] - t[0]));
            out.push_back(q);
            origin.push_back(i);
        }
    }
    scene.patches = std::move(out);
}

}  // namespace

scene::DiscontinuityStats discontinuityMesh(scene::Scene& scene,
                                            const scene::DiscontinuitySettings& settings,
                                            std::vector<uint32_t>& origin) {
    Timer timer;
    scene::DiscontinuityStats st;
    const size_t n = scene.patches.size();
    origin.resize(n);
    std::iota(origin.begin(), origin.end(), 0u);
    if (settings.mode == scene::DiscontinuitySettings::Mode::Off || n == 0) return st;
    const Sources sources = pickSources(scene, settings);
    st.sources = sources.ids.size();
    std::vector<ReceiverCut> cuts(n);
    {
        const Incidence inc(scene);
        const BoxTree tree(scene);
        const Visibility vis(scene);
        const Shared sh{scene, settings, inc, tree, vis, sources, 1e-9 * scene.bounds().diagonal()};
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const auto& range) {
            for (size_t r = range.begin(); r != range.end(); ++r)
                cuts[r] = cutReceiver(sh, uint32_t(r));
        });
    }
    for (const ReceiverCut& c : cuts) addStats(st, c.st);
    replacePatches(scene, cuts, origin);
    st.seconds = timer.seconds();
    spdlog::info(
        "discontinuity meshing: {} sources, {} receiver-source pairs, {} occluders ({} over "
        "mesh.max_occluders), {} events ({} hidden), {} curves ({} over mesh.max_curves) cut "
        "{} patches into {} triangles in {} faces ({} slivers, {:.3g} in area; {:.2f} s)",
        st.sources, st.pairs, st.occluders, st.occludersDropped, st.events, st.hidden, st.curves,
        st.curvesDropped, st.cutPatches, st.pieces, st.faces, st.thin, st.thinArea, st.seconds);
    return st;
}

scene::MeshingFn discontinuityMeshFn() {
    return [](scene::Scene& s, const scene::DiscontinuitySettings& st,
              std::vector<uint32_t>& origin) { return discontinuityMesh(s, st, origin); };
}

}  // namespace hrad::transport
