// Hemicube form factors; see hemicube.h for the method, settings and paper.
#include "transport/hemicube.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace hrad::transport {

HemicubeSettings HemicubeSettings::fromParams(const Params& params, const std::string& prefix) {
    Params::Scope scope(params, "form factors (" + prefix + ")");
    HemicubeSettings s;
    s.enabled =
        params.getEnum({prefix + ".method",
                        "form factors by quadrature or by hemicubes (Cohen & Greenberg 1985)"},
                       "quadrature", {"quadrature", "hemicube"}) == "hemicube";
    s.res = int(params.getInt(
        {prefix + ".hemicube_res", "hemicube resolution in pixels per side of the top face"}, s.res,
        2, 4096));
    if (s.res % 2 != 0)
        throw InputError(params.where(prefix + ".hemicube_res"),
                         fmt::format("{}.hemicube_res must be even (the side faces have res/2 "
                                     "rows), got {}",
                                     prefix, s.res));
    s.points = int(params.getInt(
        {prefix + ".hemicube_points", "hemicubes per element per axis (placed over the receiver)"},
        s.points, 1, 64));
    return s;
}

std::string HemicubeSettings::describe() const {
    if (!enabled) return "";
    return fmt::format(" method=hemicube hemicube_res={} hemicube_points={}", res, points);
}

Hemicube::Hemicube(int res) : res_(res) {
    HRAD_CHECK_MSG(res >= 2 && res % 2 == 0, "hemicube resolution {} must be even and >= 2", res);
    const double h = 2.0 / res;
    const double dA = h * h;
    const double pi = 3.14159265358979323846;
    cells_.reserve(size_t(3) * res * res);
    // Top face z = 1 (Cohen & Greenberg 1985).
    for (int i = 0; i < res; ++i)
        for (int j = 0; j < res; ++j) {
            double x = -1 + (i + 0.5) * h, y = -1 + (j + 0.5) * h;
            double q = x * x + y * y + 1;
            cells_.push_back({glm::normalize(Vec3(x, y, 1)), dA / (pi * q * q)});
        }
    // Four side faces, upper halves z in (0,1]; (s, z) are the
    // face's in-plane coordinates, the face lies at distance 1 along +-x, +-y.
    for (int face = 0; face < 4; ++face)
        for (int i = 0; i < res; ++i)
            for (int k = 0; k < res / 2; ++k) {
                double s = -1 + (i + 0.5) * h, z = (k + 0.5) * h;
                double q = s * s + z * z + 1;
                Vec3 d = face == 0   ? Vec3(1, s, z)
                         : face == 1 ? Vec3(-1, s, z)
                         : face == 2 ? Vec3(s, 1, z)
                                     : Vec3(s, -1, z);
                cells_.push_back({glm::normalize(d), z * dA / (pi * q * q)});
            }
}

double Hemicube::sum() const {
    double s = 0;
    for (const HemicubeCell& c : cells_) s += c.dF;
    return s;
}

uint64_t Hemicube::project(const Visibility& visibility, const scene::Scene& scene, const Vec3& p,
                           const Vec3& n, uint32_t self,
                           const std::function<void(uint32_t, const Vec3&, double)>& hit) const {
    // Orthonormal frame (t, b, n) (Duff et al. 2017's branchless basis).
    double sign = std::copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z);
    double bb = n.x * n.y * a;
    Vec3 t(1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    Vec3 b(bb, sign + n.y * n.y * a, -n.y);
    for (const HemicubeCell& c : cells_) {
        Vec3 d = c.dir.x * t + c.dir.y * b + c.dir.z * n;
        RayHit h = visibility.intersect(p, d, 0.0, 1e300, self);
        if (!h.hit) continue;
        // The back of a one-sided patch blocks and contributes nothing.
        if (glm::dot(scene.patches[h.patch].normal, d) >= 0) continue;
        hit(h.patch, h.point, c.dF);
    }
    return cells_.size();
}

void hemicubePoints(const scene::Patch& patch, const scene::Domain& dom, int k,
                    std::vector<Vec3>& points, std::vector<double>& weights) {
    points.clear();
    weights.clear();
    if (patch.kind == scene::PatchKind::Quad) {
        for (int i = 0; i < k; ++i)
            for (int j = 0; j < k; ++j) {
                double a = (i + 0.5) / k, b = (j + 0.5) / k;
                points.push_back(scene::elementPoint(patch, dom, a, b));
                weights.push_back(scene::elementJacobian(patch, dom, a, b));
            }
    } else {
        // k^2 congruent sub-triangles: k(k+1)/2 upright, k(k-1)/2 inverted.
        for (int i = 0; i < k; ++i)
            for (int j = 0; i + j < k; ++j) {
                points.push_back(scene::elementPoint(patch, dom, (3.0 * i + 1) / (3.0 * k),
                                                     (3.0 * j + 1) / (3.0 * k)));
                weights.push_back(1.0);
                if (i + j < k - 1) {
                    points.push_back(scene::elementPoint(patch, dom, (3.0 * i + 2) / (3.0 * k),
                                                         (3.0 * j + 2) / (3.0 * k)));
                    weights.push_back(1.0);
                }
            }
    }
    double s = 0;
    for (double w : weights) s += w;
    for (double& w : weights) w /= s;
}

}  // namespace hrad::transport
