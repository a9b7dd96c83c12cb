// Non-area lights: point, spot, directional (sun) and environments at
// infinity (issue 63 item 1; DESIGN.md "Where the next capabilities go").
//
// Area emitters stay patches with E > 0. A Light is everything else: a
// sender that is not a surface. What every solver needs of it:
//   sample(x, u)   an incident direction w at x, the distance to the light
//                  (infinity for lights at infinity) and the irradiance it
//                  brings to a surface facing w, divided by the pdf of w:
//                  the irradiance at x (normal n, no occlusion) is then
//                  E(x) = value * max(0, n.w) for a delta light (pdf 1) and
//                  its expectation over u for the others (Veach 1997, 3.7).
//   radiance(w)    radiance along an escaping ray of direction w (the
//                  environment; 0 for delta lights): a ray that leaves the
//                  scene picks it up, the light that escapes is lost as in
//                  an open scene.
//   pdf(w)         the solid-angle density sample() draws w with (0 for
//                  delta lights): value = radiance(w) / pdf(w) for the
//                  environments, so a caller can weigh strategies (MIS).
//   importanceSampled()  whether an environment's sample() follows a
//                  radiance that varies, so that estimates draw it beside
//                  cosine directions (transport/light_irradiance.h); false
//                  where cosine directions are exact (a uniform sky).
//   power(R)       total power (max channel) into a sphere of radius R
//                  enclosing the scene: the oracles' power scale.
// Units follow Mitsuba 3's plugins: point/spot intensity I (W/sr), sun
// irradiance E_perp (W/m^2 on a plane facing it), environment radiance L
// (W/m^2/sr). Irradiance is radiosity units (B = E + rho H, scene.h).
//
// One file per kind, one row per kind in registry.cpp (kind name, Mitsuba
// and glTF spellings, factory).
#pragma once

#include <glm/mat3x3.hpp>

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/types.h"

namespace hrad::scene {

struct TextureBudget;  // scene/texture.h

struct LightSample {
    Vec3 dir{0.0};                                          ///< unit, from x towards the light
    double distance = std::numeric_limits<double>::infinity();
    RGB value{0.0};                                         ///< irradiance at normal incidence / pdf
};

/// What a loader read of one light (units above); each kind reads its part.
struct LightSpec {
    std::string kind;     ///< a name of lightKinds()
    Vec3 position{0.0};   ///< point, spot
    Vec3 direction{0.0, 0.0, -1.0};  ///< spot axis, direction the sun's light travels
    RGB value{0.0};       ///< I (point, spot), E_perp (directional), L (constant)
    double cutoffDegrees = 20.0;  ///< spot: Mitsuba's cutoff_angle
    double beamDegrees = -1.0;    ///< spot: Mitsuba's beam_width (< 0: 3/4 of the cutoff)
    std::string filename;         ///< envmap: lat-long image (OpenEXR, Radiance HDR, stb formats)
    double scale = 1.0;           ///< envmap: factor on the image's radiance (Mitsuba's scale)
    glm::dmat3 toWorld{1.0};      ///< envmap: rotation from the map's frame (+y up) to the world
    TextureBudget* budget = nullptr;  ///< envmap: the scene's texture.max_mb (null: its default)
    SourceLocation where;
};

class Light {
  public:
    virtual ~Light() = default;
    /// The kind's name (registry.cpp), e.g. "point".
    virtual const char* name() const = 0;
    /// A point or a direction: sample() ignores u and has pdf 1.
    virtual bool isDelta() const = 0;
    virtual bool atInfinity() const = 0;
    virtual LightSample sample(const Vec3& x, double u1, double u2) const = 0;
    virtual RGB radiance(const Vec3& /*dir*/) const { return RGB(0.0); }
    virtual double pdf(const Vec3& /*dir*/) const { return 0.0; }
    virtual bool importanceSampled() const { return false; }
    virtual double power(double sceneRadius) const = 0;
    /// One line for logs: kind and parameters.
    virtual std::string describe() const = 0;
};

using LightList = std::vector<std::shared_ptr<const Light>>;

struct LightKind {
    const char* name;     ///< hrad's name
    const char* mitsuba;  ///< Mitsuba 3 emitter plugin type
    const char* gltf;     ///< KHR_lights_punctual type ("" none)
    std::shared_ptr<const Light> (*make)(const LightSpec&);
};
/// The registry table (registry.cpp).
const std::vector<LightKind>& lightKinds();
/// The kind of that Mitsuba plugin type or glTF light type (null: none).
const LightKind* lightKindByMitsuba(const std::string& type);
const LightKind* lightKindByGltf(const std::string& type);
/// Builds the light of spec.kind; bad values throw InputError at spec.where.
std::shared_ptr<const Light> makeLight(const LightSpec& spec);

// Factories, one per kind file.
std::shared_ptr<const Light> makePointLight(const LightSpec& s);
std::shared_ptr<const Light> makeSpotLight(const LightSpec& s);
std::shared_ptr<const Light> makeDirectionalLight(const LightSpec& s);
std::shared_ptr<const Light> makeConstantLight(const LightSpec& s);
std::shared_ptr<const Light> makeEnvmapLight(const LightSpec& s);

/// Range checks shared by the kinds: every channel finite and >= 0, not all 0.
void checkLightValue(const LightSpec& s, const char* what);
/// A unit vector from d, or an InputError naming `what`.
Vec3 unitLightVector(const LightSpec& s, const Vec3& d, const char* what);

}  // namespace hrad::scene
