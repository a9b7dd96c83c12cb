// Polygon intake (see triangulate.h). The only file of hrad that includes CGAL.
#include "scene/triangulate.h"

#include <algorithm>
#include <cmath>
#include <list>
#include <set>

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

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

size_t addPolygon(Scene& scene, const std::vector<Vec3>& input, uint32_t material) {
    ++scene.stats.inputFaces;
    std::vector<Vec3> v = cleanPolygon(input);
    if (v.size() < 3) {
        ++scene.stats.droppedDegenerate;
        return 0;
    }
    if (v.size() == 3) return scene.addTriangle(v[0], v[1], v[2], material) ? 1 : 0;

    Vec3 nn = newellNormal(v);
    double len = glm::length(nn);
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

}  // namespace hrad::scene
