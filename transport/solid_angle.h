// A polygon seen from a point, as a solid angle to sample directions over:
// its corners, the unit directions to them, the solid angles of its fan
// triangles (0, 1, 2) and (0, 2, 3), and a direction drawn uniformly over
// their union (Arvo 1995, "Stratified sampling of spherical triangles").
// Used where a point must find a nearby polygon in proportion to what it
// subtends, not to its area: the surface links' visibility rays
// (transport/formfactor.cpp, ff.vis_sampling) and the stand-ins
// (cluster/stand_in.cpp).
#pragma once

#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"

namespace hrad::transport {

/// Below this solid angle (sr) Arvo's construction loses its precision
/// (triangles of a few 1e-4 rad across): callers draw a point by area.
constexpr double kMinSolidAngle = 1e-7;

struct PolygonView {
    Vec3 dir[4];
    Vec3 corner[4];
    double tri[2] = {0.0, 0.0};
    double omega = 0.0;
    int count = 0;  ///< 0 when x is not in front of the polygon's plane
};

/// Polygon `corner[0..count)` (3 or 4 corners, plane normal n) seen from x.
PolygonView viewPolygon(const Vec3* corner, int count, const Vec3& n, const Vec3& x);
/// The same for element d of patch P.
PolygonView viewPolygon(const scene::Patch& P, const scene::Domain& d, const Vec3& x);

/// A direction w uniform over pv's solid angle (seen from x), from u0, u1,
/// u2 in [0, 1), and the point y where it meets the polygon's plane (normal
/// n). False when, by rounding at an edge, it does not meet it in front of x.
bool pointOverSolidAngle(const PolygonView& pv, const Vec3& n, const Vec3& x, double u0,
                         double u1, double u2, Vec3& w, Vec3& y);

}  // namespace hrad::transport
