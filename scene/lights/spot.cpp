// Spot light (Mitsuba 3 `spot`; glTF KHR_lights_punctual `spot`): a point
// light of intensity I (W/sr) along its axis a, scaled by Mitsuba's falloff
// of the angle t between a and the direction to x:
//   f(t) = 1                                   t <= beam_width
//        = (cutoff - t) / (cutoff - beam_width)  beam_width < t < cutoff
//        = 0                                   t >= cutoff
// (linear in the angle, as Mitsuba 3's spot.cpp falloff_curve). Defaults as
// Mitsuba: cutoff_angle 20 degrees, beam_width 3/4 of it. Power: at most
// 2 pi (1 - cos cutoff) I, the solid angle of the cone times I (the oracle's
// power scale only needs a bound).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "scene/lights/light.h"

namespace hrad::scene {

namespace {
constexpr double kPi = 3.14159265358979323846;

class SpotLight final : public Light {
  public:
    SpotLight(const Vec3& p, const Vec3& axis, const RGB& I, double cutoff, double beam)
        : p_(p), axis_(axis), I_(I), cutoff_(cutoff), beam_(beam) {}
    const char* name() const override { return "spot"; }
    bool isDelta() const override { return true; }
    bool atInfinity() const override { return false; }
    LightSample sample(const Vec3& x, double, double) const override {
        LightSample s;
        const Vec3 d = p_ - x;
        const double r2 = glm::dot(d, d);
        if (!(r2 > 0)) return s;
        s.distance = std::sqrt(r2);
        s.dir = d / s.distance;
        s.value = I_ * (falloff(-s.dir) / r2);
        return s;
    }
    double power(double) const override {
        return 2 * kPi * (1 - std::cos(cutoff_)) * maxComponent(I_);
    }
    std::string describe() const override {
        return fmt::format("spot at ({}, {}, {}) axis ({}, {}, {}) I = ({}, {}, {}) W/sr, cutoff {} "
                           "beam {} deg",
                           p_.x, p_.y, p_.z, axis_.x, axis_.y, axis_.z, I_.r, I_.g, I_.b,
                           cutoff_ * 180 / kPi, beam_ * 180 / kPi);
    }

  private:
    /// f(t) of the header for the unit direction w leaving the light.
    double falloff(const Vec3& w) const {
        const double c = std::clamp(glm::dot(w, axis_), -1.0, 1.0);
        const double t = std::acos(c);
        if (t >= cutoff_) return 0.0;
        if (t <= beam_) return 1.0;
        return (cutoff_ - t) / (cutoff_ - beam_);
    }
    Vec3 p_, axis_;
    RGB I_;
    double cutoff_, beam_;  ///< radians
};
}  // namespace

std::shared_ptr<const Light> makeSpotLight(const LightSpec& s) {
    checkLightValue(s, "intensity");
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(s.position[k]))
            throwInputError(s.where, "spot light: position must be finite");
    const Vec3 axis = unitLightVector(s, s.direction, "direction");
    if (!(s.cutoffDegrees > 0 && s.cutoffDegrees <= 90))
        throwInputError(s.where, "spot light: cutoff_angle = {} must be in (0, 90] degrees",
                        s.cutoffDegrees);
    const double beam = s.beamDegrees < 0 ? 0.75 * s.cutoffDegrees : s.beamDegrees;
    if (!(beam >= 0 && beam <= s.cutoffDegrees))
        throwInputError(s.where, "spot light: beam_width = {} must be in [0, cutoff_angle = {}]",
                        beam, s.cutoffDegrees);
    return std::make_shared<SpotLight>(s.position, axis, s.value, s.cutoffDegrees * kPi / 180,
                                       beam * kPi / 180);
}

}  // namespace hrad::scene
