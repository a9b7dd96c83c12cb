// Constant environment (Mitsuba 3 `constant`): radiance L (W/m^2/sr) from
// every direction at infinity. An unoccluded plane receives E = pi L
// (the cosine integral over the hemisphere). sample() draws a direction
// uniformly on the sphere (pdf 1 / (4 pi)), so value = 4 pi L and the mean
// of value * max(0, n.w) is pi L. Power into a sphere of radius R around the
// scene: pi L times its area 4 pi R^2.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "scene/lights/light.h"

namespace hrad::scene {

namespace {
constexpr double kPi = 3.14159265358979323846;

class ConstantLight final : public Light {
  public:
    explicit ConstantLight(const RGB& L) : L_(L) {}
    const char* name() const override { return "constant"; }
    bool isDelta() const override { return false; }
    bool atInfinity() const override { return true; }
    LightSample sample(const Vec3&, double u1, double u2) const override {
        const double z = 1 - 2 * u1, r = std::sqrt(std::max(0.0, 1 - z * z));
        const double phi = 2 * kPi * u2;
        return LightSample{Vec3(r * std::cos(phi), r * std::sin(phi), z),
                           std::numeric_limits<double>::infinity(), 4 * kPi * L_};
    }
    RGB radiance(const Vec3&) const override { return L_; }
    double pdf(const Vec3&) const override { return 1 / (4 * kPi); }
    double power(double R) const override { return 4 * kPi * kPi * R * R * maxComponent(L_); }
    std::string describe() const override {
        return fmt::format("constant environment L = ({}, {}, {}) W/m^2/sr", L_.r, L_.g, L_.b);
    }

  private:
    RGB L_;
};
}  // namespace

std::shared_ptr<const Light> makeConstantLight(const LightSpec& s) {
    checkLightValue(s, "radiance");
    return std::make_shared<ConstantLight>(s.value);
}

}  // namespace hrad::scene
