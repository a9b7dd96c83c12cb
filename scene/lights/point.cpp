// Point light (Mitsuba 3 `point`, glTF KHR_lights_punctual `point`): intensity
// I (W/sr) at a position p, irradiance at x facing it I / |p - x|^2 (the
// inverse-square law; Cohen & Wallace 1993, sec. 2.4). Power 4 pi I.
#include <cmath>

#include <fmt/format.h>

#include "scene/lights/light.h"

namespace hrad::scene {

namespace {
constexpr double kPi = 3.14159265358979323846;

class PointLight final : public Light {
  public:
    PointLight(const Vec3& p, const RGB& I) : p_(p), I_(I) {}
    const char* name() const override { return "point"; }
    bool isDelta() const override { return true; }
    bool atInfinity() const override { return false; }
    LightSample sample(const Vec3& x, double, double) const override {
        LightSample s;
        const Vec3 d = p_ - x;
        const double r2 = glm::dot(d, d);
        if (!(r2 > 0)) return s;
        s.distance = std::sqrt(r2);
        s.dir = d / s.distance;
        s.value = I_ / r2;
        return s;
    }
    double power(double) const override { return 4 * kPi * maxComponent(I_); }
    std::string describe() const override {
        return fmt::format("point at ({}, {}, {}) I = ({}, {}, {}) W/sr", p_.x, p_.y, p_.z, I_.r,
                           I_.g, I_.b);
    }

  private:
    Vec3 p_;
    RGB I_;
};
}  // namespace

std::shared_ptr<const Light> makePointLight(const LightSpec& s) {
    checkLightValue(s, "intensity");
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(s.position[k]))
            throwInputError(s.where, "point light: position must be finite");
    return std::make_shared<PointLight>(s.position, s.value);
}

}  // namespace hrad::scene
