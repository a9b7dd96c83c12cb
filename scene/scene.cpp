#include "scene/scene.h"
#include "scene/texture.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "scene/element.h"

namespace hrad::scene {

namespace {
bool finite(const Vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// A face is degenerate when its area is tiny relative to its longest edge
// squared (needles and collapsed faces), or when it has no finite normal.
bool degenerate(double area, double maxEdge2) {
    return !(area > 0) || !std::isfinite(area) || area <= 1e-12 * maxEdge2;
}
}  // namespace

double Camera::fovYDegreesFor(int width, int height) const {
    if (filmWidth <= 0 || filmHeight <= 0 || width <= 0 || height <= 0) return fovYDegrees;
    const double filmAspect = double(filmWidth) / filmHeight, aspect = double(width) / height;
    if (fovAxis == FovAxis::Y || filmAspect == aspect) return fovYDegrees;
    // tan(fov/2) along an axis, on an image of aspect a = w/h, from the
    // vertical one: x: tanY a; y: tanY; diagonal: tanY sqrt(a^2 + 1) (the
    // image plane at distance 1 is 2 tanY a by 2 tanY). Smaller/larger pick
    // x or y by the image's own shape (Mitsuba resolves them on its film).
    auto axisFor = [&](double a) {
        if (fovAxis == FovAxis::Smaller) return a < 1 ? FovAxis::X : FovAxis::Y;
        if (fovAxis == FovAxis::Larger) return a < 1 ? FovAxis::Y : FovAxis::X;
        return fovAxis;
    };
    auto factor = [](FovAxis axis, double a) {
        return axis == FovAxis::X ? a : axis == FovAxis::Diagonal ? std::sqrt(a * a + 1) : 1.0;
    };
    constexpr double kDeg = 3.14159265358979323846 / 180.0;
    const double tanFilmY = std::tan(0.5 * fovYDegrees * kDeg);
    const double tanAxis = tanFilmY * factor(axisFor(filmAspect), filmAspect);
    const double tanY = tanAxis / factor(axisFor(aspect), aspect);
    return 2.0 * std::atan(tanY) / kDeg;
}

uint32_t Scene::addMaterial(Material m) {
    materials.push_back(std::move(m));
    return static_cast<uint32_t>(materials.size() - 1);
}

bool Scene::addTriangle(const Vec3& a, const Vec3& b, const Vec3& c, uint32_t material) {
    Vec3 pts[4] = {a, b, c, c};
    return addPolygonPatch(PatchKind::Triangle, pts, material);
}

bool Scene::addQuad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, uint32_t material) {
    Vec3 pts[4] = {a, b, c, d};
    return addPolygonPatch(PatchKind::Quad, pts, material);
}

bool Scene::addPolygonPatch(PatchKind kind, const Vec3 (&v)[4], uint32_t material) {
    HRAD_CHECK(material < materials.size());
    int n = kind == PatchKind::Quad ? 4 : 3;
    // Newell normal relative to v[0] (for a triangle exactly cross(b-a, c-a));
    // area from it for a triangle, from the diagonals for a planar quad.
    Vec3 nrm(0.0);
    double maxEdge2 = 0;
    for (int i = 0; i < n; ++i) {
        Vec3 p0 = v[i] - v[0], p1 = v[(i + 1) % n] - v[0];
        nrm += glm::cross(p0, p1);
        maxEdge2 = std::max(maxEdge2, glm::dot(p1 - p0, p1 - p0));
    }
    double len = glm::length(nrm);
    double area = kind == PatchKind::Quad ? 0.5 * glm::length(glm::cross(v[2] - v[0], v[3] - v[1]))
                                          : 0.5 * len;
    if (std::isinf(area) || std::isinf(len) || std::isinf(maxEdge2)) {
        ++stats.overflowFaces;
        return false;
    }
    if (degenerate(area, maxEdge2) || !(len > 0)) {
        ++stats.droppedDegenerate;
        return false;
    }
    Patch p;
    p.kind = kind;
    p.material = material;
    p.v = {v[0], v[1], v[2], v[3]};
    p.normal = nrm / len;
    p.area = area;
    p.rho = materials[material].rho;
    p.emission = materials[material].emission;
    patches.push_back(p);
    return true;
}

void Scene::applyMaterials() {
    for (auto& p : patches) {
        const Material& m = materials[p.material];
        p.rho = m.rho;
        p.emission = (p.backSide && !m.emitsBothSides) ? RGB(0.0) : m.emission;
    }
    if (!textures.empty()) applyTextureMeans(*this);
}

size_t Scene::addBackSides(bool all) {
    const size_t n = patches.size();
    auto wantsTwin = [&](const Patch& p) {
        return p.twin == UINT32_MAX && (all || materials[p.material].twoSided);
    };
    // One allocation of the exact size (push_back's doubling would leave up
    // to half of the largest array of a big scene unused).
    patches.reserve(n + size_t(std::count_if(patches.begin(), patches.end(), wantsTwin)));
    size_t added = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!wantsTwin(patches[i])) continue;  // already a pair, or one-sided
        const Material& m = materials[patches[i].material];
        Patch back = patches[i];
        // Reverse the winding so that the normal is negated and the
        // parametrisation stays counter-clockwise seen from the back:
        // quad v0 v3 v2 v1, triangle v0 v2 v1 (v[3] mirrors v[2]).
        if (back.kind == PatchKind::Quad) {
            std::swap(back.v[1], back.v[3]);
        } else {
            std::swap(back.v[1], back.v[2]);
            back.v[3] = back.v[2];
        }
        if (back.uvs != UINT32_MAX) {
            std::array<glm::vec2, 4> uv = cornerUVs[back.uvs];
            if (back.kind == PatchKind::Quad) {
                std::swap(uv[1], uv[3]);
            } else {
                std::swap(uv[1], uv[2]);
                uv[3] = uv[2];
            }
            back.uvs = uint32_t(cornerUVs.size());
            cornerUVs.push_back(uv);
        }
        back.normal = -patches[i].normal;
        back.backSide = true;
        back.twin = uint32_t(i);
        back.emission = m.emitsBothSides ? m.emission : RGB(0.0);
        patches[i].twin = uint32_t(patches.size());
        patches.push_back(back);
        ++added;
    }
    return added;
}

size_t Scene::numSourcePatches() const {
    if (sourcePatch.empty()) return patches.size();
    uint32_t hi = 0;
    for (uint32_t s : sourcePatch) hi = std::max(hi, s);
    return size_t(hi) + 1;
}

size_t Scene::numBackSides() const {
    size_t k = 0;
    for (const auto& p : patches) k += p.backSide ? 1 : 0;
    return k;
}

Bounds3 Scene::bounds() const {
    Bounds3 b;
    for (const auto& p : patches)
        for (int i = 0; i < p.numVertices(); ++i) b.expand(p.v[i]);
    return b;
}

double Scene::totalArea() const {
    double a = 0;
    for (const auto& p : patches) a += p.area;
    return a;
}

RGB Scene::emittedPower() const {
    RGB s(0.0);
    for (const auto& p : patches) s += p.emission * p.area;
    return s;
}

size_t Scene::numEmitters() const {
    size_t n = 0;
    for (const auto& p : patches) n += p.isEmitter() ? 1 : 0;
    return n;
}

size_t Scene::count(PatchKind k) const {
    size_t n = 0;
    for (const auto& p : patches) n += p.kind == k ? 1 : 0;
    return n;
}

RhoCheck clampReflectance(RGB& rho, double clamp) {
    RhoCheck r = RhoCheck::Fine;
    for (int c = 0; c < 3; ++c)
        if (rho[c] >= 1.0) {
            if (!(clamp > 0.0)) return RhoCheck::TooLarge;
            rho[c] = clamp;
            r = RhoCheck::Clamped;
        }
    return r;
}

std::string clampedNote(double clamp) {
    return fmt::format("reflectance >= 1 clamped to {} (scene.clamp_rho)", clamp);
}

void Scene::validate() const {
    SourceLocation where{name, 0, 0};
    if (patches.empty()) throwInputError(where, "scene has no (non-degenerate) faces");
    std::vector<bool> used(materials.size(), false);
    for (const auto& p : patches) {
        for (int i = 0; i < p.numVertices(); ++i)
            if (!finite(p.v[i])) throwInputError(where, "non-finite vertex coordinate");
        used[p.material] = true;
    }
    for (size_t m = 0; m < materials.size(); ++m) {
        if (!used[m]) continue;
        const Material& mat = materials[m];
        for (int c = 0; c < 3; ++c) {
            double r = mat.rho[c];
            if (!(r >= 0.0 && r < 1.0))
                throwInputError(where,
                                "material '{}': reflectance ({:.6g}, {:.6g}, {:.6g}) must be in "
                                "[0, 1) per channel",
                                mat.name, mat.rho.r, mat.rho.g, mat.rho.b);
            double e = mat.emission[c];
            if (!(e >= 0.0) || !std::isfinite(e))
                throwInputError(where, "material '{}': emission must be finite and >= 0",
                                mat.name);
        }
    }
    if (numEmitters() == 0 && lights.empty()) {
        // Say what the loader dropped: "3 emitters of unsupported types were
        // dropped: envmap (scene.xml:12), ..." (issue 63).
        std::string dropped;
        for (const std::string& d : stats.droppedEmitters) dropped += (dropped.empty() ? "" : ", ") + d;
        if (stats.droppedEmitterCount > stats.droppedEmitters.size())
            dropped += fmt::format(", ... ({} more)", stats.droppedEmitterCount - stats.droppedEmitters.size());
        throwInputError(where, "scene has no emitter (no face with emission > 0){}",
                        stats.droppedEmitterCount == 0
                            ? std::string()
                            : fmt::format("; {} emitter{} of unsupported types {} dropped: {}",
                                          stats.droppedEmitterCount,
                                          stats.droppedEmitterCount == 1 ? "" : "s",
                                          stats.droppedEmitterCount == 1 ? "was" : "were", dropped));
    }
    // Each emission finite, their power may still overflow (Ke 1e308 on a
    // face of area 2): the solve would write emitted_power null and exit 0.
    const RGB power = emittedPower();
    for (int c = 0; c < 3; ++c)
        if (!std::isfinite(power[c]))
            throwInputError(where, "the emitted power (emission x area, summed) overflows a double; "
                                   "scale the emission or the geometry down");
}

}  // namespace hrad::scene
