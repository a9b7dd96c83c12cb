// The light registry (light.h): one row per kind.
#include <cmath>

#include <fmt/format.h>

#include "scene/lights/light.h"

namespace hrad::scene {

const std::vector<LightKind>& lightKinds() {
    static const std::vector<LightKind> kinds = {
        {"point", "point", "point", &makePointLight},
        {"spot", "spot", "spot", &makeSpotLight},
        {"directional", "directional", "directional", &makeDirectionalLight},
        {"constant", "constant", "", &makeConstantLight},
        {"envmap", "envmap", "", &makeEnvmapLight},
    };
    return kinds;
}

const LightKind* lightKindByMitsuba(const std::string& type) {
    for (const LightKind& k : lightKinds())
        if (type == k.mitsuba) return &k;
    return nullptr;
}

const LightKind* lightKindByGltf(const std::string& type) {
    for (const LightKind& k : lightKinds())
        if (*k.gltf && type == k.gltf) return &k;
    return nullptr;
}

std::shared_ptr<const Light> makeLight(const LightSpec& spec) {
    std::string names;
    for (const LightKind& k : lightKinds()) {
        if (spec.kind == k.name) return k.make(spec);
        names += names.empty() ? k.name : std::string(", ") + k.name;
    }
    throwInputError(spec.where, "unknown light kind '{}' (expected one of {})", spec.kind, names);
}

void checkLightValue(const LightSpec& s, const char* what) {
    for (int c = 0; c < 3; ++c)
        if (!(s.value[c] >= 0) || !std::isfinite(s.value[c]))
            throwInputError(s.where, "{} light: {} must be finite and >= 0 in every channel",
                            s.kind, what);
    if (!(maxComponent(s.value) > 0))
        throwInputError(s.where, "{} light: {} is zero (a light that sends nothing)", s.kind, what);
}

Vec3 unitLightVector(const LightSpec& s, const Vec3& d, const char* what) {
    const double len = glm::length(d);
    if (!(len > 0) || !std::isfinite(len))
        throwInputError(s.where, "{} light: {} must be a non-zero finite vector", s.kind, what);
    return d / len;
}

}  // namespace hrad::scene
