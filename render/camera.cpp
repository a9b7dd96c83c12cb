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
    Vec3 dir = glm::normalize(Vec3(1.0, 0.8, 1.6));
    if (glm::length(S) > 1e-3 * area) {
        // The candidate diagonal (|x|,|y|,|z| = 1, 0.8, 1.6 or 1.6, 0.8, 1)
        // most aligned with S; ties go to the first (upper, +x) one.
        double best = -1e300;
        for (int swap = 0; swap < 2; ++swap)
            for (int sy : {1, -1})
                for (int sx : {1, -1})
                    for (int sz : {1, -1}) {
                        Vec3 d = swap ? Vec3(1.6 * sx, 0.8 * sy, 1.0 * sz)
                                      : Vec3(1.0 * sx, 0.8 * sy, 1.6 * sz);
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
    c.up = Vec3(0.0, 1.0, 0.0);
    return c;
}

scene::Camera cameraFor(const scene::Scene& scene) {
    return scene.camera ? *scene.camera : autoCamera(scene);
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
    tanHalfY = std::tan(0.5 * camera.fovYDegrees * kPi / 180.0);
    aspect = double(w) / double(h);
}

Vec3 CameraFrame::direction(double px, double py) const {
    double sx = (2.0 * px / width - 1.0) * tanHalfY * aspect;
    double sy = (1.0 - 2.0 * py / height) * tanHalfY;
    return glm::normalize(forward + sx * right + sy * up);
}

}  // namespace hrad::render
