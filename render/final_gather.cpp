// Final gather and path tracing; see final_gather.h.
#include "render/final_gather.h"

#include "scene/texture.h"

#include <algorithm>
#include <cmath>

#include "core/sampling.h"
#include "scene/element.h"
#include "transport/light_irradiance.h"

namespace hrad::render {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Cosine-distributed direction (Malley's method) from (r1, r2) in [0,1)^2.
Vec3 cosineDir(const Vec3& n, double r1, double r2) {
    Vec3 t, b;
    orthonormalBasis(n, t, b);
    double phi = 2 * kPi * r1, s = std::sqrt(r2);
    return std::cos(phi) * s * t + std::sin(phi) * s * b + std::sqrt(std::max(0.0, 1 - r2)) * n;
}

bool isEmitter(const scene::Patch& p) {
    return p.emission.r > 0 || p.emission.g > 0 || p.emission.b > 0;
}

}  // namespace

Gatherer::Gatherer(const scene::Scene& scene, const transport::Visibility& visibility,
                   GatherSettings settings)
    : scene_(&scene), vis_(&visibility), settings_(settings),
      hasSampledEnv_(transport::hasSampledEnvironment(scene)) {
    for (uint32_t i = 0; i < scene.patches.size(); ++i)
        if (isEmitter(scene.patches[i])) emitters_.push_back(i);
}

RGB Gatherer::direct(uint32_t patch, const Vec3& x, Pcg32& rng) const {
    const scene::Patch& r = scene_->patches[patch];
    RGB sum(0.0);
    const int k = settings_.shadowRays;
    for (uint32_t e : emitters_) {
        if (e == patch) continue;
        const scene::Patch& p = scene_->patches[e];
        const scene::Domain root = scene::keyDomain(p.kind, scene::kRootKey);
        double acc = 0;
        for (int s = 0; s < k; ++s) {
            double a = rng.nextDouble(), b = rng.nextDouble();
            double w;  // 1 / pdf in the local (a,b) square or triangle
            if (p.kind == scene::PatchKind::Triangle) {
                if (a + b > 1) {
                    a = 1 - a;
                    b = 1 - b;
                }
                w = 0.5;
            } else {
                w = 1.0;
            }
            Vec3 y = scene::elementPoint(p, root, a, b);
            Vec3 d = y - x;
            double r2 = glm::dot(d, d);
            if (!(r2 > 0)) continue;
            Vec3 dir = d / std::sqrt(r2);
            double cx = glm::dot(r.normal, dir), cy = -glm::dot(p.normal, dir);
            if (cx <= 0 || cy <= 0) continue;
            transport::RayHit h = vis_->intersect(x, dir, 0.0, 1e300, patch);
            if (!h.hit || h.patch != e) continue;
            acc += w * scene::elementJacobian(p, root, a, b) * cx * cy / (kPi * r2);
        }
        sum += p.emission * (acc / k);
    }
    // Point, spot and sun lights: one shadow ray each, exact (transport/light_irradiance.h).
    uint64_t rays = 0;  // not reported: the image counts no rays
    for (const auto& l : scene_->lights)
        if (l->isDelta()) sum += transport::lightIrradiance(*l, *vis_, x, r.normal, patch, 1, 0, rays);
    return sum;
}

RGB Gatherer::finalGather(const scene::RadiosityField& field, uint32_t patch, const Vec3& x,
                          Pcg32& rng, const RGB* texel) const {
    const scene::Patch& r = scene_->patches[patch];
    const int n = settings_.gatherRays;
    const int strata = int(std::lround(std::sqrt(double(n))));
    const bool stratified = strata * strata == n;
    const bool envMis = hasSampledEnv_;
    RGB ind(0.0), env(0.0);  // env: the sampled environments' cosine half, already weighted
    for (int s = 0; s < n; ++s) {
        double r1 = rng.nextDouble(), r2 = rng.nextDouble();
        if (stratified) {
            r1 = ((s % strata) + r1) / strata;
            r2 = ((s / strata) + r2) / strata;
        }
        Vec3 dir = cosineDir(r.normal, r1, r2);
        transport::RayHit h = vis_->intersect(x, dir, 0.0, 1e300, patch);
        if (!h.hit) {
            if (!envMis) {
                ind += kPi * transport::environmentRadiance(*scene_, dir);  // the sky, pi L by the cosine pdf
                continue;
            }
            ind += kPi * transport::unsampledEnvironmentRadiance(*scene_, dir);
            env += transport::sampledEnvironmentEscape(*scene_, r.normal, dir,
                                                       settings_.shadowRays, n);
            continue;
        }
        const scene::Patch& q = scene_->patches[h.patch];
        if (glm::dot(q.normal, dir) >= 0) continue;  // the back of a one-sided patch
        Vec2 uv = glm::clamp(scene::patchInverse(q, h.point), Vec2(0.0), Vec2(1.0));
        if (q.kind == scene::PatchKind::Triangle && uv.x + uv.y > 1) uv /= uv.x + uv.y;
        ind += field.at(h.patch, uv.x, uv.y) - q.emission;
    }
    if (!envMis) return r.emission + rhoAt(patch, x, texel) * (direct(patch, x, rng) + ind / double(n));
    const RGB d = direct(patch, x, rng);
    env += environmentDirect(patch, x, n, rng);
    return r.emission + rhoAt(patch, x, texel) * (d + ind / double(n) + env);
}

RGB Gatherer::environmentDirect(uint32_t patch, const Vec3& x, int cosineSamples,
                                Pcg32& rng) const {
    uint64_t rays = 0;  // not reported: the image counts no rays
    return transport::sampledEnvironmentDirect(*scene_, *vis_, x, scene_->patches[patch].normal,
                                               patch, settings_.shadowRays, cosineSamples, rng,
                                               rays);
}

RGB Gatherer::rhoAt(uint32_t patch, const Vec3& x, const RGB* texel) const {
    const scene::Patch& p = scene_->patches[patch];
    if (!settings_.textures || !scene::patchTexture(*scene_, p)) return p.rho;
    const Vec2 uv = scene::clampToPatchDomain(p.kind, scene::patchInverse(p, x));
    RGB rho = texel ? *texel : scene::textureRho(*scene_, p, uv.x, uv.y);
    // Clamped like the patch means (the loader's clamp_rho), so no texel
    // reflects all the light it receives.
    const double cap = scene_->materials[p.material].diffuseMap.clampRho;
    if (cap > 0) rho = glm::min(rho, RGB(cap));
    return rho;
}

RGB Gatherer::pathTraced(uint32_t patch, const Vec3& x0, Pcg32& rng) const {
    RGB result = scene_->patches[patch].emission;
    RGB throughput(1.0);
    uint32_t cur = patch;
    Vec3 x = x0;
    for (int depth = 0;; ++depth) {
        const scene::Patch& p = scene_->patches[cur];
        throughput *= rhoAt(cur, x);
        result += throughput * direct(cur, x, rng);
        if (hasSampledEnv_) result += throughput * environmentDirect(cur, x, 1, rng);
        if (depth >= 3) {
            double q = std::min(0.95, maxComponent(throughput));
            if (!(q > 0) || rng.nextDouble() >= q) break;
            throughput /= q;
        }
        Vec3 dir = cosineDir(p.normal, rng.nextDouble(), rng.nextDouble());
        transport::RayHit h = vis_->intersect(x, dir, 0.0, 1e300, cur);
        if (!h.hit) {
            // Escaped: the environment, MIS-weighted for the sampled ones (final_gather.h).
            if (!hasSampledEnv_)
                result += throughput * (kPi * transport::environmentRadiance(*scene_, dir));
            else
                result += throughput * (kPi * transport::unsampledEnvironmentRadiance(*scene_, dir) +
                                        transport::sampledEnvironmentEscape(
                                            *scene_, p.normal, dir, settings_.shadowRays, 1));
            break;
        }
        if (glm::dot(scene_->patches[h.patch].normal, dir) >= 0) break;
        cur = h.patch;
        x = h.point;
        // Emission of the next vertex is counted by next-event estimation.
    }
    return result;
}

}  // namespace hrad::render
