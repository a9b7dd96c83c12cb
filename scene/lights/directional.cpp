// Directional light, the sun (Mitsuba 3 `directional`, glTF
// KHR_lights_punctual `directional`): parallel light travelling along d with
// irradiance E_perp (W/m^2) on a plane facing it, so E(x) = E_perp cos t on
// a surface whose normal makes angle t with -d (Lambert's cosine law).
// Power into a sphere of radius R around the scene: E_perp pi R^2.
#include <cmath>

#include <fmt/format.h>

#include "scene/lights/light.h"

namespace hrad::scene {

namespace {
constexpr double kPi = 3.14159265358979323846;

class DirectionalLight final : public Light {
  public:
    DirectionalLight(const Vec3& d, const RGB& E) : toLight_(-d), E_(E) {}
    const char* name() const override { return "directional"; }
    bool isDelta() const override { return true; }
    bool atInfinity() const override { return true; }
    LightSample sample(const Vec3&, double, double) const override {
        return LightSample{toLight_, std::numeric_limits<double>::infinity(), E_};
    }
    double power(double R) const override { return kPi * R * R * maxComponent(E_); }
    std::string describe() const override {
        return fmt::format("directional towards ({}, {}, {}) E = ({}, {}, {}) W/m^2", -toLight_.x,
                           -toLight_.y, -toLight_.z, E_.r, E_.g, E_.b);
    }

  private:
    Vec3 toLight_;
    RGB E_;
};
}  // namespace

std::shared_ptr<const Light> makeDirectionalLight(const LightSpec& s) {
    checkLightValue(s, "irradiance");
    return std::make_shared<DirectionalLight>(unitLightVector(s, s.direction, "direction"), s.value);
}

}  // namespace hrad::scene
