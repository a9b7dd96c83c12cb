// Polygon intake (see triangulate.h). The only file of hrad that includes CGAL.
#include "scene/triangulate.h"
#include "scene/element.h"
#include "scene/texture.h"

#include <CGAL/Arr_segment_traits_2.h>
#include <CGAL/Arrangement_2.h>
#include <CGAL/Box_intersection_d/Box_with_info_d.h>
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <cmath>
#include <list>
#include <set>
#include <unordered_map>

namespace hrad::scene {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

struct FaceInfo {
    int nesting = -1;  ///< number of constraints crossed from the infinite face
    bool inDomain() const { return nesting % 2 == 1; }
};

using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;  // input index, -1 if new
using Fbb = CGAL::Triangulation_face_base_with_info_2<FaceInfo, K>;
using Fb = CGAL::Constrained_triangulation_face_base_2<K, Fbb>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
// Exact_predicates_tag lets constraints intersect (self-touching polygons,
// seams); intersection points are constructed inexactly and get index -1.
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;

// Flood fill from `start` at nesting level `index`: faces reachable without
// crossing a constraint get the same level; the far side of each constrained
// edge is queued for level index+1 (CGAL manual, polygon_triangulation.cpp).
void markDomain(CDT& ct, CDT::Face_handle start, int index, std::list<CDT::Edge>& border) {
    if (start->info().nesting != -1) return;
    std::list<CDT::Face_handle> queue;
    queue.push_back(start);
    while (!queue.empty()) {
        CDT::Face_handle fh = queue.front();
        queue.pop_front();
        if (fh->info().nesting != -1) continue;
        fh->info().nesting = index;
        for (int i = 0; i < 3; ++i) {
            CDT::Edge e(fh, i);
            CDT::Face_handle n = fh->neighbor(i);
            if (n->info().nesting == -1) {
                if (ct.is_constrained(e))
                    border.push_back(e);
                else
                    queue.push_back(n);
            }
        }
    }
}

void markDomains(CDT& cdt) {
    for (CDT::Face_handle f : cdt.all_face_handles()) f->info().nesting = -1;
    std::list<CDT::Edge> border;
    markDomain(cdt, cdt.infinite_face(), 0, border);
    while (!border.empty()) {
        CDT::Edge e = border.front();
        border.pop_front();
        CDT::Face_handle n = e.first->neighbor(e.second);
        if (n->info().nesting == -1) markDomain(cdt, n, e.first->info().nesting + 1, border);
    }
}

double polygonDiameter(const std::vector<Vec3>& v) {
    Bounds3 b;
    for (const auto& p : v) b.expand(p);
    return b.diagonal();
}

}  // namespace

Vec3 newellNormal(const std::vector<Vec3>& v) {
    Vec3 n(0.0);
    size_t m = v.size();
    for (size_t i = 0; i < m; ++i) n += glm::cross(v[i], v[(i + 1) % m]);
    return n;
}

std::vector<Vec3> cleanPolygon(const std::vector<Vec3>& input, double relTol) {
    std::vector<Vec3> v = input;
    double diam = polygonDiameter(v);
    if (!(diam > 0)) return {};
    double eps = relTol * diam;
    bool changed = true;
    while (changed && v.size() >= 3) {
        changed = false;
        // Consecutive duplicates (including last == first).
        for (size_t i = 0; i < v.size() && v.size() >= 2;) {
            const Vec3& a = v[i];
            const Vec3& b = v[(i + 1) % v.size()];
            if (glm::length(b - a) <= eps) {
                v.erase(v.begin() + long((i + 1) % v.size()));
                changed = true;
            } else {
                ++i;
            }
        }
        if (v.size() < 3) break;
        // Collinear vertices and spikes: |e1 x e2| tiny relative to |e1||e2|
        // means the vertex lies on the line through its neighbours.
        for (size_t i = 0; i < v.size() && v.size() >= 3;) {
            size_t m = v.size();
            const Vec3& prev = v[(i + m - 1) % m];
            const Vec3& cur = v[i];
            const Vec3& next = v[(i + 1) % m];
            Vec3 e1 = cur - prev, e2 = next - cur;
            double c = glm::length(glm::cross(e1, e2));
            if (c <= relTol * glm::length(e1) * glm::length(e2) ||
                c <= eps * std::max(glm::length(e1), glm::length(e2)) * 1e-3) {
                v.erase(v.begin() + long(i));
                changed = true;
            } else {
                ++i;
            }
        }
    }
    if (v.size() < 3) return {};
    return v;
}

bool triangulatePolygon(const std::vector<Vec3>& v, std::vector<std::array<Vec3, 3>>& tris) {
    tris.clear();
    Vec3 n = newellNormal(v);
    double len = glm::length(n);
    if (!(len > 0) || !std::isfinite(len)) return false;
    n /= len;
    // Orthonormal basis (u, w) of the plane with u x w = n, so that counter-
    // clockwise in 2D is counter-clockwise around n.
    Vec3 a = std::fabs(n.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    Vec3 u = glm::normalize(glm::cross(a, n));
    Vec3 w = glm::cross(n, u);
    Vec3 origin(0.0);
    for (const auto& p : v) origin += p;
    origin /= double(v.size());
    double planeOffset = glm::dot(origin, n);

    try {
        CDT cdt;
        std::vector<CDT::Vertex_handle> handles;
        handles.reserve(v.size());
        for (size_t i = 0; i < v.size(); ++i) {
            Vec3 d = v[i] - origin;
            handles.push_back(cdt.insert(K::Point_2(glm::dot(d, u), glm::dot(d, w))));
        }
        // Vertex info is not initialised by CGAL; the first occurrence of a
        // (duplicate) point names the input vertex.
        for (auto vh : handles) vh->info() = -1;
        for (size_t i = 0; i < v.size(); ++i)
            if (handles[i]->info() < 0) handles[i]->info() = int(i);
        std::set<CDT::Vertex_handle> originals(handles.begin(), handles.end());
        for (size_t i = 0; i < v.size(); ++i) {
            CDT::Vertex_handle p = handles[i], q = handles[(i + 1) % v.size()];
            if (p != q) cdt.insert_constraint(p, q);
        }
        markDomains(cdt);
        for (CDT::Face_handle f : cdt.finite_face_handles()) {
            if (!f->info().inDomain()) continue;
            std::array<Vec3, 3> t;
            for (int k = 0; k < 3; ++k) {
                CDT::Vertex_handle vh = f->vertex(k);
                int idx = vh->info();
                if (originals.count(vh) && idx >= 0 && idx < int(v.size())) {
                    t[k] = v[size_t(idx)];
                } else {
                    // A constraint intersection: lift from the best-fit plane.
                    const K::Point_2& p = vh->point();
                    t[k] = origin + p.x() * u + p.y() * w;
                    t[k] += (planeOffset - glm::dot(t[k], n)) * n;
                }
            }
            tris.push_back(t);  // CDT faces are counter-clockwise in (u, w)
        }
    } catch (const std::exception&) {
        tris.clear();
        return false;
    }
    return !tris.empty();
}

namespace {

/// Gives the patches [first, end) corner UVs from the polygon's vertices
/// (each corner the UV of the nearest input vertex: corners are copies).
void attachUVs(Scene& scene, size_t first, const std::vector<Vec3>& input,
               const std::vector<Vec2>& uvs) {
    for (size_t k = first; k < scene.patches.size(); ++k) {
        Patch& p = scene.patches[k];
        std::array<glm::vec2, 4> row{};
        for (int c = 0; c < p.numVertices(); ++c) {
            size_t best = 0;
            double bestD = 1e300;
            for (size_t i = 0; i < input.size(); ++i) {
                const Vec3 d = input[i] - p.v[size_t(c)];
                const double d2 = glm::dot(d, d);
                if (d2 < bestD) {
                    bestD = d2;
                    best = i;
                }
            }
            row[size_t(c)] = glm::vec2(uvs[best]);
        }
        if (p.kind == PatchKind::Triangle) row[3] = row[2];
        p.uvs = uint32_t(scene.cornerUVs.size());
        scene.cornerUVs.push_back(row);
    }
}

size_t addPolygonPatches(Scene& scene, const std::vector<Vec3>& input, uint32_t material);

}  // namespace

size_t addPolygon(Scene& scene, const std::vector<Vec3>& input, uint32_t material,
                  const std::vector<Vec2>* uvs) {
    const size_t first = scene.patches.size();
    const size_t added = addPolygonPatches(scene, input, material);
    if (uvs && uvs->size() == input.size() && added) attachUVs(scene, first, input, *uvs);
    return added;
}

namespace {

size_t addPolygonPatches(Scene& scene, const std::vector<Vec3>& input, uint32_t material) {
    ++scene.stats.inputFaces;
    // Areas are products of coordinates: past 1e150 they (and the diameter
    // cleanPolygon measures) overflow, and the face looked degenerate.
    for (const Vec3& p : input)
        if (std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}) > 1e150) {
            ++scene.stats.overflowFaces;
            return 0;
        }
    std::vector<Vec3> v = cleanPolygon(input);
    if (v.size() < 3) {
        ++scene.stats.droppedDegenerate;
        return 0;
    }
    if (v.size() == 3) return scene.addTriangle(v[0], v[1], v[2], material) ? 1 : 0;

    Vec3 nn = newellNormal(v);
    double len = glm::length(nn);
    if (std::isinf(len)) {
        ++scene.stats.overflowFaces;
        return 0;
    }
    if (!(len > 0) || !std::isfinite(len)) {
        ++scene.stats.droppedDegenerate;
        return 0;
    }
    Vec3 n = nn / len;
    if (v.size() == 4) {
        double diam = polygonDiameter(v);
        Vec3 c = 0.25 * (v[0] + v[1] + v[2] + v[3]);
        double dev = 0;
        for (const auto& p : v) dev = std::max(dev, std::fabs(glm::dot(p - c, n)));
        bool planar = dev <= 1e-6 * diam;
        // Strictly convex: every corner turns left around n by a non-trivial
        // amount (relative to its edge lengths).
        bool convex = true;
        for (int i = 0; i < 4 && convex; ++i) {
            Vec3 e1 = v[size_t(i)] - v[size_t((i + 3) % 4)];
            Vec3 e2 = v[size_t((i + 1) % 4)] - v[size_t(i)];
            double s = glm::dot(glm::cross(e1, e2), n);
            convex = s > 1e-9 * glm::length(e1) * glm::length(e2);
        }
        if (planar && convex) return scene.addQuad(v[0], v[1], v[2], v[3], material) ? 1 : 0;
    }
    std::vector<std::array<Vec3, 3>> tris;
    if (!triangulatePolygon(v, tris)) {
        ++scene.stats.droppedDegenerate;
        return 0;
    }
    ++scene.stats.triangulatedFaces;
    size_t added = 0;
    for (const auto& t : tris) added += scene.addTriangle(t[0], t[1], t[2], material) ? 1 : 0;
    return added;
}

}  // namespace

namespace {

/// The triangles of a patch (a quad is two, split along v0-v2).
int patchTriangles(const Patch& p, std::array<Vec3, 3> (&t)[2]) {
    t[0] = {p.v[0], p.v[1], p.v[2]};
    if (p.kind != PatchKind::Quad) return 1;
    t[1] = {p.v[0], p.v[2], p.v[3]};
    return 2;
}

/// The part of triangle a on the plane (n, d) (n unit): false unless it is
/// a segment (a point, nothing, or the whole triangle otherwise).
bool planeCut(const std::array<Vec3, 3>& a, const Vec3& n, double d, double tol, Vec3& p0,
              Vec3& p1) {
    double s[3];
    for (int i = 0; i < 3; ++i) {
        s[i] = glm::dot(n, a[size_t(i)]) - d;
        if (std::fabs(s[i]) <= tol) s[i] = 0.0;
    }
    if ((s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0)) return false;
    if (s[0] == 0 && s[1] == 0 && s[2] == 0) return false;  // in the plane
    Vec3 pts[3];
    int m = 0;
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3;
        if (s[i] == 0) pts[m++] = a[size_t(i)];
        if (s[i] * s[j] < 0 && m < 3)
            pts[m++] = a[size_t(i)] + (a[size_t(j)] - a[size_t(i)]) * (s[i] / (s[i] - s[j]));
    }
    if (m < 2) return false;
    p0 = pts[0];
    p1 = pts[1];
    return glm::length(p1 - p0) > tol;
}

/// The segment two non-parallel triangles share, if any (Moeller 1997: each
/// triangle cut by the other's plane, the two cuts overlapped along the line
/// of the planes).
bool crossSegment(const std::array<Vec3, 3>& a, const std::array<Vec3, 3>& b, double tol, Vec3& s0,
                  Vec3& s1) {
    Vec3 na = glm::cross(a[1] - a[0], a[2] - a[0]), nb = glm::cross(b[1] - b[0], b[2] - b[0]);
    const double la = glm::length(na), lb = glm::length(nb);
    if (!(la > 0) || !(lb > 0)) return false;
    na /= la;
    nb /= lb;
    Vec3 a0, a1, b0, b1;
    if (!planeCut(a, nb, glm::dot(nb, b[0]), tol, a0, a1)) return false;
    if (!planeCut(b, na, glm::dot(na, a[0]), tol, b0, b1)) return false;
    Vec3 dir = glm::cross(na, nb);
    const double ld = glm::length(dir);
    if (!(ld > 0)) return false;
    dir /= ld;
    double ta0 = glm::dot(a0, dir), ta1 = glm::dot(a1, dir);
    if (ta0 > ta1) {
        std::swap(ta0, ta1);
        std::swap(a0, a1);
    }
    const double tb0 = std::min(glm::dot(b0, dir), glm::dot(b1, dir));
    const double tb1 = std::max(glm::dot(b0, dir), glm::dot(b1, dir));
    const double lo = std::max(ta0, tb0), hi = std::min(ta1, tb1);
    if (!(hi - lo > tol) || !(ta1 - ta0 > 0)) return false;
    s0 = a0 + (a1 - a0) * ((lo - ta0) / (ta1 - ta0));
    s1 = a0 + (a1 - a0) * ((hi - ta0) / (ta1 - ta0));
    return std::isfinite(s0.x + s0.y + s0.z + s1.x + s1.y + s1.z);
}

/// Whether segment [a, b] lies along one edge of patch p (within tol).
bool alongBoundary(const Patch& p, const Vec3& a, const Vec3& b, double tol) {
    const int n = p.numVertices();
    for (int i = 0; i < n; ++i) {
        const Vec3& e0 = p.v[size_t(i)];
        const Vec3& e1 = p.v[size_t((i + 1) % n)];
        Vec3 d = e1 - e0;
        double len2 = glm::dot(d, d);
        if (!(len2 > 0)) continue;
        auto dist = [&](const Vec3& x) {
            double t = std::clamp(glm::dot(x - e0, d) / len2, 0.0, 1.0);
            return glm::length(x - (e0 + t * d));
        };
        if (dist(a) <= tol && dist(b) <= tol) return true;
    }
    return false;
}

/// Retriangulates patch p with the segments as constraints (constrained
/// Delaunay in its plane); triangles counter-clockwise around p's normal.
/// Segment end points within `tol` of a corner of p, of an end point
/// already inserted, or of an edge of p are moved onto it first: the
/// crossing segments are computed in floating point, and an end point a
/// rounding error away from a corner or an edge would otherwise make a
/// piece of no size (areas of 1e-20 m^2 on graz.mgf) whose kernels are
/// singular.
bool splitPatch(const Patch& p, const std::vector<std::pair<Vec3, Vec3>>& segments, double tol,
                std::vector<std::array<Vec3, 3>>& out) {
    const Vec3 n = p.normal;
    const int nv = p.numVertices();
    Vec3 u = p.v[1] - p.v[0];
    u = glm::normalize(u - glm::dot(u, n) * n);
    const Vec3 w = glm::cross(n, u);  // (u, w, n) right-handed: CCW in 2D is CCW around n
    const Vec3 origin = p.v[0];
    const double offset = glm::dot(origin, n);
    auto to2 = [&](const Vec3& x) {
        return K::Point_2(glm::dot(x - origin, u), glm::dot(x - origin, w));
    };
    std::vector<K::Point_2> poly;
    for (int i = 0; i < nv; ++i) poly.push_back(to2(p.v[size_t(i)]));
    // Inside the convex polygon (counter-clockwise), with a relative slack.
    auto inside = [&](const K::Point_2& q) {
        for (int i = 0; i < nv; ++i)
            if (CGAL::orientation(poly[size_t(i)], poly[size_t((i + 1) % nv)], q) ==
                CGAL::RIGHT_TURN)
                return false;
        return true;
    };
    try {
        CDT cdt;
        for (int i = 0; i < nv; ++i)
            cdt.insert_constraint(poly[size_t(i)], poly[size_t((i + 1) % nv)]);
        std::vector<K::Point_2> ends;
        const double t2 = tol * tol;
        auto snap = [&](K::Point_2 q) {
            for (const K::Point_2& c : poly)
                if (CGAL::squared_distance(c, q) <= t2) return c;
            for (const K::Point_2& c : ends)
                if (CGAL::squared_distance(c, q) <= t2) return c;
            for (int i = 0; i < nv; ++i) {
                const K::Segment_2 e(poly[size_t(i)], poly[size_t((i + 1) % nv)]);
                if (CGAL::squared_distance(e, q) <= t2) {
                    const K::Line_2 line = e.supporting_line();
                    q = line.projection(q);
                    break;
                }
            }
            ends.push_back(q);
            return q;
        };
        for (const auto& [a, b] : segments) {
            K::Point_2 pa = snap(to2(a)), pb = snap(to2(b));
            if (CGAL::squared_distance(pa, pb) > t2) cdt.insert_constraint(pa, pb);
        }
        for (CDT::Face_handle f : cdt.finite_face_handles()) {
            K::Point_2 c =
                CGAL::centroid(f->vertex(0)->point(), f->vertex(1)->point(), f->vertex(2)->point());
            if (!inside(c)) continue;
            std::array<Vec3, 3> t;
            for (int k = 0; k < 3; ++k) {
                const K::Point_2& q = f->vertex(k)->point();
                Vec3 x = origin + q.x() * u + q.y() * w;
                t[size_t(k)] = x + (offset - glm::dot(x, n)) * n;
            }
            out.push_back(t);
        }
    } catch (const std::exception&) {
        out.clear();
        return false;
    }
    return out.size() > 1;
}

}  // namespace

SplitStats splitIntersections(Scene& scene, std::vector<uint32_t>* origin, bool touching) {
    SplitStats st;
    const uint32_t np = uint32_t(scene.patches.size());
    if (origin) {
        origin->resize(np);
        for (uint32_t i = 0; i < np; ++i) (*origin)[i] = i;
    }
    if (np < 2) return st;
    const double diag = scene.bounds().diagonal();
    const double tol = 1e-7 * diag;
    // Candidate pairs: overlapping bounding boxes (CGAL box intersection).
    using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, uint32_t>;
    std::vector<Box> boxes;
    boxes.reserve(np);
    for (uint32_t i = 0; i < np; ++i) {
        const Patch& p = scene.patches[i];
        double lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = hi[a] = p.v[0][a];
            for (int k = 1; k < p.numVertices(); ++k) {
                lo[a] = std::min(lo[a], p.v[size_t(k)][a]);
                hi[a] = std::max(hi[a], p.v[size_t(k)][a]);
            }
            lo[a] -= tol;
            hi[a] += tol;
        }
        boxes.emplace_back(lo, hi, i);
    }
    std::unordered_map<uint32_t, std::vector<std::pair<Vec3, Vec3>>> cuts;
    auto test = [&](const Box& ba, const Box& bb) {
        const uint32_t i = ba.info(), j = bb.info();
        const Patch& P = scene.patches[i];
        const Patch& Q = scene.patches[j];
        // Parallel planes cross nowhere (coplanar overlaps: scene/coplanar.h).
        if (std::fabs(glm::dot(P.normal, Q.normal)) > 1.0 - 1e-9) return;
        std::array<Vec3, 3> tp[2], tq[2];
        const int mp = patchTriangles(P, tp), mq = patchTriangles(Q, tq);
        for (int a = 0; a < mp; ++a) {
            for (int b = 0; b < mq; ++b) {
                Vec3 s0, s1;
                if (!crossSegment(tp[a], tq[b], tol, s0, s1)) continue;
                // Touching (an edge of one lying on the other, a box standing
                // on a floor) lets no light through; only a crossing does.
                const bool onP = alongBoundary(P, s0, s1, tol);
                const bool onQ = alongBoundary(Q, s0, s1, tol);
                if (onP && onQ) continue;  // shared edges
                if (!touching && (onP || onQ)) continue;
                // With `touching`, an edge of one lying inside the other cuts
                // the other only.
                if (!onP) cuts[i].emplace_back(s0, s1);
                if (!onQ) cuts[j].emplace_back(s0, s1);
                ++st.crossings;
            }
        }
    };
    CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), test);
    if (cuts.empty()) return st;
    std::vector<Patch> old = std::move(scene.patches);
    scene.patches.clear();
    scene.patches.reserve(old.size() + 4 * cuts.size());
    if (origin) {
        origin->clear();
        origin->reserve(old.size() + 4 * cuts.size());
    }
    std::vector<std::array<Vec3, 3>> tris;
    for (uint32_t i = 0; i < uint32_t(old.size()); ++i) {
        auto it = cuts.find(i);
        tris.clear();
        if (it == cuts.end() || !splitPatch(old[i], it->second, tol, tris)) {
            scene.patches.push_back(old[i]);
            if (origin) origin->push_back(i);
            continue;
        }
        ++st.splitPatches;
        for (const auto& t : tris) {
            // A piece thinner than the tolerance (two constraints crossing
            // or meeting at a grazing angle) is left out: a slit narrower
            // than the rounding of the crossing itself.
            double longest2 = 0.0;
            for (int k = 0; k < 3; ++k) {
                const Vec3 e = t[size_t((k + 1) % 3)] - t[size_t(k)];
                longest2 = std::max(longest2, glm::dot(e, e));
            }
            const double area = 0.5 * glm::length(glm::cross(t[1] - t[0], t[2] - t[0]));
            if (!(2.0 * area > tol * std::sqrt(longest2))) {
                ++st.thinPieces;
                st.thinArea += area;
                continue;
            }
            if (!scene.addTriangle(t[0], t[1], t[2], old[i].material)) continue;
            Patch& added = scene.patches.back();
            added.rho = old[i].rho;
            added.emission = old[i].emission;
            if (old[i].uvs < scene.cornerUVs.size()) {
                // A piece's corners take the UVs of the patch they lie on.
                std::array<glm::vec2, 4> row{};
                for (int c = 0; c < 3; ++c)
                    row[size_t(c)] = glm::vec2(uvAt(old[i], scene.cornerUVs[old[i].uvs],
                                                    patchInverse(old[i], t[size_t(c)]).x,
                                                    patchInverse(old[i], t[size_t(c)]).y));
                row[3] = row[2];
                added.uvs = uint32_t(scene.cornerUVs.size());
                scene.cornerUVs.push_back(row);
            }
            if (origin) origin->push_back(i);
            ++st.pieces;
        }
    }
    return st;
}


// ---- cutConvexPolygon (discontinuity meshing) ------------------------------

namespace {

using EK = CGAL::Exact_predicates_exact_constructions_kernel;
using ArrTraits = CGAL::Arr_segment_traits_2<EK>;
using Arrangement = CGAL::Arrangement_2<ArrTraits>;

/// Moves a cut's end point within `tol` of a corner, an earlier end point or
/// a boundary edge onto it (the cuts are computed in floating point; a
/// rounding error away from a corner would make a piece of no size).
class EndSnapper {
  public:
    EndSnapper(const std::vector<Vec2>& polygon, double tol) : poly_(polygon), tol_(tol) {}
    Vec2 operator()(Vec2 q) {
        for (const Vec2& c : poly_)
            if (glm::length(c - q) <= tol_) return c;
        for (const Vec2& c : ends_)
            if (glm::length(c - q) <= tol_) return c;
        for (size_t i = 0; i < poly_.size(); ++i) {
            const Vec2 a = poly_[i], b = poly_[(i + 1) % poly_.size()];
            const Vec2 d = b - a;
            const double t = std::clamp(glm::dot(q - a, d) / glm::dot(d, d), 0.0, 1.0);
            if (glm::length(a + t * d - q) <= tol_) {
                q = a + t * d;
                break;
            }
        }
        ends_.push_back(q);
        return q;
    }

  private:
    const std::vector<Vec2>& poly_;
    double tol_;
    std::vector<Vec2> ends_;
};

/// The arrangement of the boundary and the snapped cuts (exact).
void buildArrangement(const std::vector<Vec2>& polygon,
                      const std::vector<std::pair<Vec2, Vec2>>& segments, double tol,
                      Arrangement& arr) {
    std::vector<ArrTraits::Segment_2> curves;
    for (size_t i = 0; i < polygon.size(); ++i) {
        const Vec2 a = polygon[i], b = polygon[(i + 1) % polygon.size()];
        curves.emplace_back(EK::Point_2(a.x, a.y), EK::Point_2(b.x, b.y));
    }
    EndSnapper snap(polygon, tol);
    for (const auto& [a0, b0] : segments) {
        const Vec2 a = snap(a0), b = snap(b0);
        if (glm::length(a - b) > tol)
            curves.emplace_back(EK::Point_2(a.x, a.y), EK::Point_2(b.x, b.y));
    }
    CGAL::insert(arr, curves.begin(), curves.end());
}

}  // namespace

bool cutConvexPolygon(const std::vector<Vec2>& polygon,
                      const std::vector<std::pair<Vec2, Vec2>>& segments, double tol,
                      PlanarCut& out) {
    out = PlanarCut{};
    if (polygon.size() < 3) return false;
    try {
        Arrangement arr;
        buildArrangement(polygon, segments, tol, arr);
        out.vertices = arr.number_of_vertices();
        out.edges = arr.number_of_edges();
        out.faces = arr.number_of_faces() - arr.number_of_unbounded_faces();
        // Every arrangement edge is a constraint: each triangle then lies in
        // one face of the arrangement (a region between cuts).
        CDT cdt;
        for (auto e = arr.edges_begin(); e != arr.edges_end(); ++e) {
            const K::Point_2 a(CGAL::to_double(e->source()->point().x()),
                               CGAL::to_double(e->source()->point().y()));
            const K::Point_2 b(CGAL::to_double(e->target()->point().x()),
                               CGAL::to_double(e->target()->point().y()));
            if (a != b) cdt.insert_constraint(a, b);
        }
        for (CDT::Face_handle f : cdt.finite_face_handles()) {
            std::array<Vec2, 3> t;
            for (int k = 0; k < 3; ++k)
                t[size_t(k)] = Vec2(f->vertex(k)->point().x(), f->vertex(k)->point().y());
            // Thinness: twice the area over the longest edge is the height.
            const double a2 = (t[1].x - t[0].x) * (t[2].y - t[0].y) -
                              (t[2].x - t[0].x) * (t[1].y - t[0].y);
            const double longest = std::max({glm::length(t[1] - t[0]), glm::length(t[2] - t[1]),
                                             glm::length(t[0] - t[2])});
            if (a2 <= tol * longest) {
                ++out.thin;
                continue;
            }
            out.triangles.push_back(t);
        }
    } catch (const std::exception&) {
        out = PlanarCut{};
        return false;
    }
    return true;
}

}  // namespace hrad::scene
