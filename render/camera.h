// Cameras for rendering radiosity fields (a pinhole scene::Camera).
#pragma once

#include "core/types.h"
#include "scene/scene.h"
#include "transport/visibility.h"

namespace hrad::render {

/// The camera of the Cornell box data set (Cornell Program of Computer
/// Graphics, "Cornell Box Data", coordinates in millimetres: eye (278, 273,
/// -800) looking along +z at (278, 273, 0), vertical field of view 39.3077
/// degrees). Only meaningful for a scene in those coordinates; the built-in
/// "cornell" scene sets scene.camera itself.
scene::Camera standardCornellCamera();

/// A camera that sees the whole scene: it looks at the centre of the bounding
/// box from outside, along a diagonal direction (up = scene.upAxis), at the
/// distance where the bounding sphere fits the vertical field of view (40
/// degrees). The direction has 0.8 along the up axis, 1.6 along the longer
/// horizontal axis and 1 along the shorter one (normalised; (1, 0.8, 1.6) for
/// a y-up cube), so the view runs along the longest horizontal extent, unless
/// the scene is open: then the vector area sum_k A_k n_k (zero for closed
/// surfaces) points out of the opening, and the diagonal among
/// (+-1, +-0.8, +-1.6) and (+-1.6, +-0.8, +-1) (components permuted so 0.8 is
/// on the up axis) most aligned with it is used (the Cornell box is seen through its open
/// front). A closed scene seen from outside shows only back faces (black by
/// default, render.back_faces); such scenes should carry their own camera.
scene::Camera autoCamera(const scene::Scene& scene);

/// scene.camera when present, else autoCamera(scene).
scene::Camera cameraFor(const scene::Scene& scene);

/// A view from inside a closed scene (buildings, rooms): candidate eyes on a
/// 5 x 5 x 2 grid inside the bounding box (up = scene.upAxis,
/// eyes at 35 % and 55 % of the height), 8 horizontal view directions each;
/// a fan of 7 x 5 rays scores a view by the fraction of rays that hit a front
/// face farther than 3 % of the box diagonal, plus their mean free distance.
/// The best view wins (ties: first candidate). Deterministic.
scene::Camera interiorCamera(const scene::Scene& scene, const transport::Visibility& visibility);

/// scene.camera when present; else autoCamera for an open scene (non-zero
/// vector area, e.g. the Cornell box seen through its open side) whose view
/// sees front faces on at least half of a 16 x 16 probe; else the one of
/// interiorCamera and autoCamera that sees more front faces.
scene::Camera cameraFor(const scene::Scene& scene, const transport::Visibility& visibility);
/// Fraction of a 16 x 16 grid of primary rays that hit a front face.
double frontFaceFraction(const scene::Scene& scene, const transport::Visibility& visibility,
                         const scene::Camera& camera);

/// A primary ray through the image: pixel coordinates (x right, y down,
/// continuous, [0,width] x [0,height]) to a unit direction from camera.eye.
struct CameraFrame {
    Vec3 eye, forward, right, up;
    double tanHalfY = 0.0, aspect = 1.0;
    int width = 1, height = 1;

    CameraFrame(const scene::Camera& camera, int width, int height);
    Vec3 direction(double px, double py) const;
};

}  // namespace hrad::render
