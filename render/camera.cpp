#include "render/camera.h"

#include <cmath>

#include "core/error.h"

namespace hrad::render {

scene::Camera standardCornellCamera() {
    scene::Camera c;
    c.eye = Vec3(278.0, 273.0, -800.0);
    c.target = Vec3(278.0, 273.0, 0.0);
    c.up = Vec3(0.0, 1.0, 0.0);
    c.fovYDegrees = 39.3077;
    return c;
}

scene::Camera autoCamera(const scene::Scene& scene) {
    scene::Camera c;
    scene::Bounds3 b = scene.bounds();
    if (!b.valid()) return c;
    c.fovYDegrees = 40.0;
    double radius = std::max(0.5 * b.diagonal(), 1e-12);
    // Vector area S = sum_k A_k n_k: zero for a closed surface (divergence
    // theorem), else pointing out of the openings (e.g. -z for the Cornell
    // box, whose front is open and whose walls face inwards).
    Vec3 S(0.0);
    double area = 0.0;
    for (const auto& p : scene.patches) {
        S += p.area * p.normal;
        area += p.area;
    }
    // The format's up axis u gets the 0.8 component; of the two horizontal
    // axes the longer one gets 1.6, so a closed scene is seen along its
    // longest horizontal extent (ties: z for y-up scenes).
    const int u = (scene.upAxis >= 0 && scene.upAxis < 3) ? scene.upAxis : 1;
    const int a1 = (u + 1) % 3, a2 = (u + 2) % 3;
    Vec3 e = b.extent();
    Vec3 dir(0.0);
    dir[u] = 0.8;
    dir[e[a1] >= e[a2] ? a1 : a2] = 1.6;
    dir[e[a1] >= e[a2] ? a2 : a1] = 1.0;
    dir = glm::normalize(dir);
    if (glm::length(S) > 1e-3 * area) {
        // The candidate diagonal (0.8 along up, 1 and 1.6 or 1.6 and 1 along
        // the horizontal axes a1, a2) most aligned with S; ties go to the
        // first (upper) one.
        double best = -1e300;
        for (int swap = 0; swap < 2; ++swap)
            for (int su : {1, -1})
                for (int s2 : {1, -1})
                    for (int s1 : {1, -1}) {
                        Vec3 d(0.0);
                        d[u] = 0.8 * su;
                        d[a1] = (swap ? 1.0 : 1.6) * s1;
                        d[a2] = (swap ? 1.6 : 1.0) * s2;
                        d = glm::normalize(d);
                        double score = glm::dot(d, S);
                        if (score > best + 1e-12 * area) {
                            best = score;
                            dir = d;
                        }
                    }
    }
    // The bounding sphere subtends the (smaller, vertical) field of view.
    double dist = radius / std::sin(0.5 * c.fovYDegrees * kPi / 180.0);
    c.target = b.center();
    c.eye = c.target + dir * dist;
    c.up = Vec3(0.0);
    c.up[u] = 1.0;
    return c;
}

scene::Camera cameraFor(const scene::Scene& scene) {
    return scene.camera ? *scene.camera : autoCamera(scene);
}

namespace {
bool isOpen(const scene::Scene& scene) {
    Vec3 S(0.0);
    double area = 0.0;
    for (const auto& p : scene.patches) {
        S += p.area * p.normal;
        area += p.area;
    }
    return glm::length(S) > 1e-3 * area;
}
}  // namespace

scene::Camera interiorCamera(const scene::Scene& scene, const transport::Visibility& vis) {
    scene::Camera best = autoCamera(scene);
    scene::Bounds3 b = scene.bounds();
    if (!b.valid()) return best;
    Vec3 e = b.extent();
    // The format's up axis (scene.upAxis), not the smallest extent: a tall
    // nave is narrower than high and would otherwise be seen sideways.
    const int upAxis = (scene.upAxis >= 0 && scene.upAxis < 3) ? scene.upAxis : 1;
    int a1 = (upAxis + 1) % 3, a2 = (upAxis + 2) % 3;
    double diag = b.diagonal(), minDist = 0.03 * diag;
    double fovY = 60.0, tanY = std::tan(0.5 * fovY * kPi / 180.0), tanX = tanY * 1.0;
    double bestScore = -1.0;
    for (double hf : {0.35, 0.55})
        for (int i = 0; i < 5; ++i)
            for (int j = 0; j < 5; ++j) {
                Vec3 eye;
                eye[upAxis] = b.lo[upAxis] + hf * e[upAxis];
                eye[a1] = b.lo[a1] + (i + 0.5) / 5.0 * e[a1];
                eye[a2] = b.lo[a2] + (j + 0.5) / 5.0 * e[a2];
                for (int k = 0; k < 8; ++k) {
                    double ang = k * kPi / 4.0;
                    Vec3 fwd(0.0), up(0.0);
                    fwd[a1] = std::cos(ang);
                    fwd[a2] = std::sin(ang);
                    up[upAxis] = 1.0;
                    Vec3 right = glm::normalize(glm::cross(fwd, up));
                    int hits = 0;
                    double dist = 0.0;
                    for (int py = 0; py < 5; ++py)
                        for (int px = 0; px < 7; ++px) {
                            double sx = ((px + 0.5) / 7.0 * 2 - 1) * tanX;
                            double sy = ((py + 0.5) / 5.0 * 2 - 1) * tanY;
                            Vec3 d = glm::normalize(fwd + sx * right + sy * up);
                            transport::RayHit h = vis.intersect(eye, d, 0.0, 4.0 * diag);
                            if (!h.hit || h.t < minDist) continue;
                            if (glm::dot(scene.patches[h.patch].normal, d) >= 0) continue;
                            ++hits;
                            dist += h.t;
                        }
                    double score = hits / 35.0 + (hits ? dist / hits / diag : 0.0);
                    // A view that sees any back face from inside is outside
                    // some closed part: require most rays on front faces.
                    if (hits >= 25 && score > bestScore) {
                        bestScore = score;
                        best.eye = eye;
                        best.target = eye + fwd;
                        best.up = up;
                        best.fovYDegrees = fovY;
                    }
                }
            }
    return best;
}

double frontFaceFraction(const scene::Scene& scene, const transport::Visibility& vis,
                         const scene::Camera& cam) {
    CameraFrame f(cam, 16, 16);
    int front = 0;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            Vec3 d = f.direction(x + 0.5, y + 0.5);
            transport::RayHit h = vis.intersect(cam.eye, d);
            if (h.hit && glm::dot(scene.patches[h.patch].normal, d) < 0) ++front;
        }
    return front / 256.0;
}

scene::Camera cameraFor(const scene::Scene& scene, const transport::Visibility& visibility) {
    if (scene.camera) return *scene.camera;
    scene::Camera outside = autoCamera(scene);
    // From outside, a closed scene (or a building open only at a few doors)
    // shows back faces: then look from inside instead.
    if (isOpen(scene) && frontFaceFraction(scene, visibility, outside) >= 0.5) return outside;
    scene::Camera inside = interiorCamera(scene, visibility);
    return frontFaceFraction(scene, visibility, inside) >=
                   frontFaceFraction(scene, visibility, outside)
               ? inside
               : outside;
}

CameraFrame::CameraFrame(const scene::Camera& camera, int w, int h) : width(w), height(h) {
    HRAD_CHECK(w > 0 && h > 0);
    eye = camera.eye;
    Vec3 f = camera.target - camera.eye;
    HRAD_CHECK_MSG(glm::length(f) > 0, "camera eye equals target");
    forward = glm::normalize(f);
    Vec3 r = glm::cross(forward, camera.up);
    if (glm::length(r) < 1e-9 * glm::length(camera.up)) {
        // up parallel to the view direction: pick any perpendicular.
        Vec3 alt = std::fabs(forward.y) < 0.9 ? Vec3(0, 1, 0) : Vec3(1, 0, 0);
        r = glm::cross(forward, alt);
    }
    right = glm::normalize(r);
    up = glm::cross(right, forward);
    // The scene file's fov holds along its axis at this image's aspect
    // (scene::Camera::fovYDegreesFor; plain fovYDegrees without a film).
    tanHalfY = std::tan(0.5 * camera.fovYDegreesFor(w, h) * kPi / 180.0);
    aspect = double(w) / double(h);
}

Vec3 CameraFrame::direction(double px, double py) const {
    double sx = (2.0 * px / width - 1.0) * tanHalfY * aspect;
    double sy = (1.0 - 2.0 * py / height) * tanHalfY;
    return glm::normalize(forward + sx * right + sy * up);
}

}  // namespace hrad::render
