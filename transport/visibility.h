// Visibility queries through Embree 3 (DESIGN.md "Visibility").
//
// One Embree scene is built from the root patches (triangles as
// RTC_GEOMETRY_TYPE_TRIANGLE, quads as RTC_GEOMETRY_TYPE_QUAD) in float. Occlusion
// rays are issued in batches (rtcOccluded1M). A segment between a point on patch
// A and a point on patch B ignores hits on A and B themselves (an occlusion
// filter compares the primitive id with the segment's two patch ids), so
// neither offsets nor epsilons decide whether touching patches see each other.
//
// A face lying in the plane of a segment's end patch (or of a nearest-hit
// query's origin patch) never blocks it: the segment leaves that plane, so
// such a face could only meet it at the end point itself. This is the same
// at both ends, so visibility does not depend on which end a ray starts
// from: the two sides of a sheet modelled as two faces of opposite normal see
// their own sides, a tile next to the end point's patch does not block, and
// a face resting on a floor (facing into it) sees nothing. Where a nearest
// hit meets the back of a one-sided face and another face's front at the
// same point, it reports the front. Faces stacked the same way in one plane
// follow scene/coplanar.h. Details in visibility.cpp.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace hrad::transport {

/// A segment from a (on patch patchA) to b (on patch patchB).
struct Segment {
    Vec3 a, b;
    uint32_t patchA = UINT32_MAX, patchB = UINT32_MAX;
};

struct RayHit {
    bool hit = false;
    uint32_t patch = UINT32_MAX;
    double t = 0.0;
    Vec3 point{0.0};
};

class Visibility {
  public:
    /// Reads `scene`'s patches during queries: the scene must outlive this.
    explicit Visibility(const scene::Scene& scene);
    ~Visibility();
    Visibility(const Visibility&) = delete;
    Visibility& operator=(const Visibility&) = delete;

    /// out[i] = 1 when segment i is blocked by some patch other than its two
    /// endpoint patches, else 0. Thread-safe; batched internally.
    void occluded(const Segment* segments, size_t count, uint8_t* out) const;
    bool occluded(const Segment& s) const;

    /// Nearest hit along origin + t dir for t in (tmin, tmax), ignoring
    /// `ignorePatch` (and its twin). On a two-sided surface the hit patch is
    /// the side facing the ray.
    RayHit intersect(const Vec3& origin, const Vec3& dir, double tmin = 0.0, double tmax = 1e300,
                     uint32_t ignorePatch = UINT32_MAX) const;

    /// The patch whose polygon is in the Embree scene (front of a two-sided pair).
    uint32_t frontOf(uint32_t patch) const;

    /// Bytes held by the Embree scene (from the device memory monitor).
    uint64_t memoryBytes() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace hrad::transport
