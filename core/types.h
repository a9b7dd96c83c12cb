// Basic numeric types shared by every hrad module.
//
// Geometry and radiosity are double precision throughout: hrad compares
// solvers against references to many digits, and float round-off in form
// factors would dominate the errors we want to measure. Embree receives float
// copies of the geometry (transport/visibility.h).
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/geometric.hpp>

namespace hrad {

using Vec2 = glm::dvec2;
using Vec3 = glm::dvec3;
/// Linear RGB triple (radiosity in W/m^2 per channel, or a reflectance).
using RGB = glm::dvec3;

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kInvPi = 1.0 / kPi;

/// Luminance of linear sRGB/Rec.709 primaries (ITU-R BT.709 weights).
inline double luminance(const RGB& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

inline double maxComponent(const RGB& c) {
    return c.r > c.g ? (c.r > c.b ? c.r : c.b) : (c.g > c.b ? c.g : c.b);
}

}  // namespace hrad
