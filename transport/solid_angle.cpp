#include "transport/solid_angle.h"

#include "core/sampling.h"
#include "scene/element.h"

namespace hrad::transport {

PolygonView viewPolygon(const Vec3* corner, int count, const Vec3& n, const Vec3& x) {
    PolygonView v;
    if (!(glm::dot(n, x - corner[0]) > 0)) return v;
    for (int i = 0; i < count; ++i) {
        v.corner[i] = corner[i];
        const Vec3 e = corner[i] - x;
        const double l = glm::length(e);
        if (!(l > 0)) return v;
        v.dir[i] = e / l;
    }
    v.tri[0] = sphericalTriangleArea(v.dir[0], v.dir[1], v.dir[2]);
    if (count == 4) v.tri[1] = sphericalTriangleArea(v.dir[0], v.dir[2], v.dir[3]);
    v.omega = v.tri[0] + v.tri[1];
    v.count = count;
    return v;
}

PolygonView viewPolygon(const scene::Patch& P, const scene::Domain& d, const Vec3& x) {
    Vec3 corner[4];
    const int count = scene::elementCorners(P, d, corner);
    return viewPolygon(corner, count, P.normal, x);
}

bool pointOverSolidAngle(const PolygonView& pv, const Vec3& n, const Vec3& x, double u0,
                         double u1, double u2, Vec3& w, Vec3& y) {
    const double pick = u0 * pv.omega;
    const int tri = pv.count == 4 && pick >= pv.tri[0] ? 1 : 0;
    w = sphericalTriangleDirection(pv.dir[0], pv.dir[1 + tri], pv.dir[2 + tri], pv.tri[tri], u1,
                                   u2);
    const double dn = glm::dot(n, w);
    const double tp = dn < 0 ? glm::dot(n, pv.corner[0] - x) / dn : -1.0;
    y = x + tp * w;
    return tp > 0;
}

}  // namespace hrad::transport
