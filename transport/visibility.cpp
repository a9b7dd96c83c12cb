// Visibility through Embree 3.
//
// Layout: one RTCDevice and one RTCScene per Visibility. The root patches go
// into (at most) two geometries: all triangles in one RTC_GEOMETRY_TYPE_TRIANGLE
// geometry and all quads in one RTC_GEOMETRY_TYPE_QUAD geometry, float vertices
// (one copy per corner; sharing is not needed for occlusion). Each geometry's
// user pointer is its primID -> patch index table, so the filter functions
// map a hit back to a patch without a search.
//
// Ignoring the endpoint patches: every query passes an extended
// RTCIntersectContext (Embree's documented pattern: the context is the first
// member, the filter casts it back) that points to one (patchA, patchB) pair
// per ray. The ray's `id` field holds the ray's index in the batch: Embree
// copies it into the RTCRayN handed to the filter even when it regroups the
// rays of rtcOccluded1M into packets, so the filter indexes the pair table with
// RTCRayN_id(ray, N, i), never with the lane i. A hit on either endpoint
// patch is rejected by clearing valid[i].
//
// Two-sided surfaces (scene.h, Patch::twin): only the front patch of a pair
// goes into Embree, segment endpoints and ignored patches are mapped to their
// front patch, and intersect() reports the side the ray arrives at (the back
// twin when the ray meets the front patch's back face).
//
// Segment rays: org = a, dir = b - a (unnormalised), tnear = 0,
// tfar = 1 - 1e-5; hits on a's and b's own patches are filtered.
//
// Faces lying in an end point's plane: a segment leaves the plane of each of
// its end points (it carries light only where the cosines at both ends are
// positive), so a face that lies in the plane of A's or B's patch can meet
// it only at that end point. The filter rejects such a hit, at both ends
// alike: a face in the plane of an end point never blocks. This decides
// three cases that float round-off used to decide, differently at the two
// ends (a hit at t = 0 counted, one at t = 1 fell outside tfar):
//  - a face of opposite normal on the same points (the two sides of a sheet:
//    a label on a binder's spine whose other side is the spine's inner face,
//    graz.mgf; the same polygon modelled twice, once per side) does not hide
//    the end point's side of the sheet;
//  - a tile next to the end point's patch (same plane, sharing an edge) does
//    not block when round-off puts the end point just across the edge;
//  - a face in front of the end point's own face in the same plane is
//    handled before the ray is cast (scene/coplanar.h, `hidden`).
// A face touching the end point from another plane (a wall meeting a floor)
// still blocks: closed cavities stay closed. The plane test: the face's
// geometric normal parallel to the end patch's normal (|cos| >= 1 - 1e-6)
// and its first vertex within `planeTol_` of the end patch's plane, the
// tolerance of scene/coplanar.h (1e-6 of the scene's diagonal) widened to
// the float rounding of the coordinates Embree holds.
//
// Nearest hits (intersect) with an ignored patch apply the same rule to the
// ray's origin patch, and break ties at the hit: when the nearest hit is the
// back of a one-sided face that is one side of a sheet (scene/coplanar.h,
// `inSheet`) and a face whose front meets the ray lies in the same plane at
// the same point, the ray hits that front face (the sheet's side the ray
// arrives at; the Monte Carlo reference reads the same side as the segments
// above). A second query over the window of the plane tolerance decides it;
// back hits on faces that are not in a sheet cost nothing more.
//
// Thread safety: after rtcCommitScene the scene is read-only; rtcOccluded*/
// rtcIntersect1 are thread-safe, and each query has its own context on the stack.
#include "transport/visibility.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "scene/coplanar.h"

namespace hrad::transport {

namespace {

constexpr float kSegmentTfar = 1.0f - 1e-5f;
constexpr size_t kBatch = 256;  // rays per rtcOccluded1M call (stack buffer)

/// Stacked coplanar faces (scene/coplanar.h), as the filters need them.
struct CoplanarData {
    const scene::CoplanarOverlaps* overlaps = nullptr;  ///< null: the scene has none
    const uint32_t* twin = nullptr;  ///< back twin of each front patch (null: no two-sided)
};

/// One Embree geometry's user data: its primID -> patch table and the float
/// vertices Embree holds (nv per primitive), for the end-point plane test.
struct GeometryData {
    const uint32_t* primToPatch = nullptr;
    const float* vertices = nullptr;
    unsigned nv = 3;
};

/// The plane of an end point's patch: unit normal and offset (n . x = d). A
/// zero normal means "no plane" (no end patch).
struct EndPlane {
    float n[3] = {0.0f, 0.0f, 0.0f};
    float d = 0.0f;
};

/// An intersection context carrying one (patchA, patchB) pair per ray.
struct QueryContext {
    RTCIntersectContext ctx;  // must be first: Embree hands us &ctx
    const uint32_t* pairs;    // 2 entries per ray (front patches), indexed by the ray's id
    const EndPlane* planes = nullptr;        // 2 entries per ray: the planes of the end patches
    const uint32_t* planePatches = nullptr;  // 2 entries per ray: those patches, as given
    float planeTol = 0.0f;
    const uint32_t* endpoints = nullptr;  // the same, as given (occlusion with stacked faces)
    const CoplanarData* coplanar = nullptr;
    const scene::Patch* patches = nullptr;  // the scene's patches
    bool nearest = false;     // rtcIntersect1: the nearest hit must be a visible face
    bool frontOnly = false;   // reject hits on the back of a one-sided face
};

/// Whether the primitive `prim` lies in plane `e` (see the header comment):
/// 0 no, +1 facing the same way, -1 facing the other way.
inline int inPlane(const EndPlane& e, float tol, const GeometryData& g, unsigned prim, float ngx,
                   float ngy, float ngz) {
    if (e.n[0] == 0.0f && e.n[1] == 0.0f && e.n[2] == 0.0f) return 0;
    const float dot = ngx * e.n[0] + ngy * e.n[1] + ngz * e.n[2];
    const float len2 = ngx * ngx + ngy * ngy + ngz * ngz;
    if (dot * dot < (1.0f - 2e-6f) * len2) return 0;
    const float* v = g.vertices + 3 * size_t(g.nv) * prim;
    if (std::fabs(v[0] * e.n[0] + v[1] * e.n[1] + v[2] * e.n[2] - e.d) > tol) return 0;
    return dot > 0.0f ? 1 : -1;
}

/// Filter for both occlusion and intersection: reject hits on the ray's own
/// patches. geometryUserPtr is the geometry's primID -> patch table. With
/// stacked coplanar faces, an occlusion ray also ignores the faces lying in
/// the plane of its end points where they overlap them (whether the end
/// point itself is hidden is decided before the ray is cast), and a nearest-
/// hit query rejects a hit on a face at a point where another face is in
/// front of it, so the query returns that face.
void ignoreEndpointsFilter(const RTCFilterFunctionNArguments* args) {
    const auto* qc = reinterpret_cast<const QueryContext*>(args->context);
    const auto& geom = *static_cast<const GeometryData*>(args->geometryUserPtr);
    const uint32_t* primToPatch = geom.primToPatch;
    const unsigned N = args->N;
    for (unsigned i = 0; i < N; ++i) {
        if (args->valid[i] != -1) continue;
        unsigned id = RTCRayN_id(args->ray, N, i);
        unsigned prim = RTCHitN_primID(args->hit, N, i);
        uint32_t patch = primToPatch[prim];
        if (patch == qc->pairs[2 * id] || patch == qc->pairs[2 * id + 1]) {
            args->valid[i] = 0;
            continue;
        }
        if (qc->planes || qc->frontOnly) {
            const float ngx = RTCHitN_Ng_x(args->hit, N, i), ngy = RTCHitN_Ng_y(args->hit, N, i),
                        ngz = RTCHitN_Ng_z(args->hit, N, i);
            bool skip = false;
            for (int k = 0; k < 2 && qc->planes && !skip; ++k) {
                const int side =
                    inPlane(qc->planes[2 * id + k], qc->planeTol, geom, prim, ngx, ngy, ngz);
                // A face stacked on the end patch, facing the same way, is
                // left to the stacked-face rules below (it may hide the end).
                const uint32_t e = qc->planePatches[2 * id + k];
                skip = side < 0 ||
                       (side > 0 && !(qc->coplanar && qc->coplanar->overlaps->partners(e, patch)));
            }
            if (skip) {
                args->valid[i] = 0;
                continue;
            }
            if (qc->frontOnly) {
                const scene::Patch& hp = qc->patches[patch];
                const double dn = hp.normal.x * RTCRayN_dir_x(args->ray, N, i) +
                                  hp.normal.y * RTCRayN_dir_y(args->ray, N, i) +
                                  hp.normal.z * RTCRayN_dir_z(args->ray, N, i);
                if (dn > 0.0 && hp.twin == UINT32_MAX) {
                    args->valid[i] = 0;
                    continue;
                }
            }
        }
        const CoplanarData* cd = qc->coplanar;
        if (!cd) continue;
        const scene::CoplanarOverlaps& ov = *cd->overlaps;
        uint32_t back = cd->twin ? cd->twin[patch] : UINT32_MAX;
        if (qc->endpoints) {
            for (int k = 0; k < 2; ++k) {
                uint32_t e = qc->endpoints[2 * id + k];
                if (e != UINT32_MAX && (ov.partners(e, patch) || (back != UINT32_MAX && ov.partners(e, back))))
                    args->valid[i] = 0;
            }
        }
        if (qc->nearest && args->valid[i] == -1) {
            Vec3 org(RTCRayN_org_x(args->ray, N, i), RTCRayN_org_y(args->ray, N, i),
                     RTCRayN_org_z(args->ray, N, i));
            Vec3 dir(RTCRayN_dir_x(args->ray, N, i), RTCRayN_dir_y(args->ray, N, i),
                     RTCRayN_dir_z(args->ray, N, i));
            const scene::Patch& hp = qc->patches[patch];
            const Vec3& n = hp.normal;
            double dn = glm::dot(n, dir);
            if (dn == 0.0) continue;
            Vec3 x = org + ((glm::dot(n, hp.v[0]) - glm::dot(n, org)) / dn) * dir;
            uint32_t side = dn > 0.0 && back != UINT32_MAX ? back : patch;
            if (ov.hidden(side, x)) args->valid[i] = 0;
        }
    }
}

bool memoryMonitor(void* userPtr, ssize_t bytes, bool /*post*/) {
    auto* counter = static_cast<std::atomic<int64_t>*>(userPtr);
    counter->fetch_add(int64_t(bytes), std::memory_order_relaxed);
    return true;  // never refuse an allocation
}

void errorFunction(void* /*userPtr*/, RTCError code, const char* str) {
    // Errors surface through rtcGetDeviceError checks below; nothing to do here
    // beyond keeping Embree from printing to stderr.
    (void)code;
    (void)str;
}

}  // namespace

struct Visibility::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::atomic<int64_t> bytes{0};
    std::vector<uint32_t> triToPatch, quadToPatch;
    GeometryData triData, quadData;
    // The scene's patches (the scene outlives its Visibility), for the planes
    // of segment end points and the facing of nearest hits.
    const scene::Patch* patches = nullptr;
    float planeTol = 0.0f;
    // Two-sided pairs (empty when the scene has none): the front patch of
    // every patch, and the back twin of every front patch.
    std::vector<uint32_t> front, twin;
    // Stacked coplanar faces (none: `coplanar.overlaps` is null).
    scene::CoplanarOverlaps overlaps;
    CoplanarData coplanar;
    unsigned triGeom = RTC_INVALID_GEOMETRY_ID, quadGeom = RTC_INVALID_GEOMETRY_ID;

    void check(const char* what) const {
        RTCError e = rtcGetDeviceError(device);
        if (e != RTC_ERROR_NONE)
            throw InternalError(std::string("Embree error ") + std::to_string(int(e)) + " in " +
                                what);
    }

    uint32_t patchOf(unsigned geomID, unsigned primID) const {
        if (geomID == triGeom) return triToPatch[primID];
        if (geomID == quadGeom) return quadToPatch[primID];
        return UINT32_MAX;
    }
};

Visibility::Visibility(const scene::Scene& sc) : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.device = rtcNewDevice(nullptr);
    if (!m.device)
        throw InternalError("Embree: rtcNewDevice failed (error " +
                            std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    rtcSetDeviceErrorFunction(m.device, errorFunction, nullptr);
    rtcSetDeviceMemoryMonitorFunction(m.device, memoryMonitor, &m.bytes);

    m.scene = rtcNewScene(m.device);
    rtcSetSceneFlags(m.scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(m.scene, RTC_BUILD_QUALITY_HIGH);

    m.overlaps = scene::CoplanarOverlaps(sc);
    m.patches = sc.patches.data();
    {
        // scene/coplanar.h's plane tolerance, widened to the float rounding of
        // the coordinates Embree holds and of the plane offsets compared.
        scene::Bounds3 b = sc.bounds();
        const double diag = b.diagonal();
        double coord = 0.0;
        if (b.valid())
            for (int k = 0; k < 3; ++k)
                coord = std::max({coord, std::fabs(b.lo[k]), std::fabs(b.hi[k])});
        m.planeTol = float(std::max(1e-6 * diag, 8.0 * double(FLT_EPSILON) * coord));
    }
    if (sc.numBackSides() > 0) {
        m.front.resize(sc.patches.size());
        m.twin.resize(sc.patches.size());
        for (uint32_t i = 0; i < sc.patches.size(); ++i) {
            m.front[i] = sc.frontOf(i);
            m.twin[i] = sc.patches[i].twin;
        }
    }
    if (!m.overlaps.empty()) {
        m.coplanar.overlaps = &m.overlaps;
        m.coplanar.twin = m.twin.empty() ? nullptr : m.twin.data();
    }
    for (uint32_t i = 0; i < sc.patches.size(); ++i)
        if (!sc.patches[i].backSide)
            (sc.patches[i].kind == scene::PatchKind::Quad ? m.quadToPatch : m.triToPatch).push_back(i);

    auto addGeometry = [&](RTCGeometryType type, const std::vector<uint32_t>& prims, int nv,
                           GeometryData& data) {
        RTCGeometry g = rtcNewGeometry(m.device, type);
        auto* verts = static_cast<float*>(rtcSetNewGeometryBuffer(
            g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), prims.size() * nv));
        auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            g, RTC_BUFFER_TYPE_INDEX, 0, nv == 3 ? RTC_FORMAT_UINT3 : RTC_FORMAT_UINT4,
            nv * sizeof(unsigned), prims.size()));
        m.check("rtcSetNewGeometryBuffer");
        for (size_t k = 0; k < prims.size(); ++k) {
            const scene::Patch& p = sc.patches[prims[k]];
            for (int c = 0; c < nv; ++c) {
                verts[3 * (nv * k + c) + 0] = float(p.v[c].x);
                verts[3 * (nv * k + c) + 1] = float(p.v[c].y);
                verts[3 * (nv * k + c) + 2] = float(p.v[c].z);
                idx[nv * k + c] = unsigned(nv * k + c);
            }
        }
        data.primToPatch = prims.data();
        data.vertices = verts;
        data.nv = unsigned(nv);
        rtcSetGeometryUserData(g, &data);
        rtcSetGeometryOccludedFilterFunction(g, ignoreEndpointsFilter);
        rtcSetGeometryIntersectFilterFunction(g, ignoreEndpointsFilter);
        rtcCommitGeometry(g);
        unsigned id = rtcAttachGeometry(m.scene, g);
        rtcReleaseGeometry(g);
        m.check("geometry setup");
        return id;
    };
    if (!m.triToPatch.empty())
        m.triGeom = addGeometry(RTC_GEOMETRY_TYPE_TRIANGLE, m.triToPatch, 3, m.triData);
    if (!m.quadToPatch.empty())
        m.quadGeom = addGeometry(RTC_GEOMETRY_TYPE_QUAD, m.quadToPatch, 4, m.quadData);
    rtcCommitScene(m.scene);
    m.check("rtcCommitScene");
}

Visibility::~Visibility() {
    if (impl_) {
        if (impl_->scene) rtcReleaseScene(impl_->scene);
        if (impl_->device) rtcReleaseDevice(impl_->device);
    }
}

namespace {

EndPlane planeOf(const scene::Patch* patches, uint32_t p) {
    EndPlane e;
    if (p == UINT32_MAX) return e;
    const scene::Patch& q = patches[p];
    e.n[0] = float(q.normal.x);
    e.n[1] = float(q.normal.y);
    e.n[2] = float(q.normal.z);
    e.d = float(glm::dot(q.normal, q.v[0]));
    return e;
}

}  // namespace

uint32_t Visibility::frontOf(uint32_t patch) const {
    return patch < impl_->front.size() ? impl_->front[patch] : patch;
}

void Visibility::occluded(const Segment* segments, size_t count, uint8_t* out) const {
    alignas(16) RTCRay rays[kBatch];
    uint32_t pairs[2 * kBatch], endpoints[2 * kBatch];
    EndPlane planes[2 * kBatch];
    const CoplanarData* cd = impl_->coplanar.overlaps ? &impl_->coplanar : nullptr;
    bool hiddenEnd[kBatch];
    for (size_t base = 0; base < count; base += kBatch) {
        size_t n = std::min(kBatch, count - base);
        for (size_t i = 0; i < n; ++i) {
            const Segment& s = segments[base + i];
            RTCRay& r = rays[i];
            r.org_x = float(s.a.x);
            r.org_y = float(s.a.y);
            r.org_z = float(s.a.z);
            r.dir_x = float(s.b.x - s.a.x);
            r.dir_y = float(s.b.y - s.a.y);
            r.dir_z = float(s.b.z - s.a.z);
            r.tnear = 0.0f;
            r.tfar = kSegmentTfar;
            r.time = 0.0f;
            r.mask = 0xFFFFFFFFu;
            r.id = unsigned(i);
            r.flags = 0;
            pairs[2 * i] = frontOf(s.patchA);
            pairs[2 * i + 1] = frontOf(s.patchB);
            endpoints[2 * i] = s.patchA;
            endpoints[2 * i + 1] = s.patchB;
            planes[2 * i] = planeOf(impl_->patches, s.patchA);
            planes[2 * i + 1] = planeOf(impl_->patches, s.patchB);
            // An end point inside a face stacked in front of its own face is
            // hidden: nothing reaches it (scene/coplanar.h).
            hiddenEnd[i] = cd && ((s.patchA != UINT32_MAX && cd->overlaps->hidden(s.patchA, s.a)) ||
                                  (s.patchB != UINT32_MAX && cd->overlaps->hidden(s.patchB, s.b)));
            if (hiddenEnd[i]) r.tfar = -1.0f;  // Embree skips rays with tfar < tnear
        }
        QueryContext qc;
        rtcInitIntersectContext(&qc.ctx);
        qc.ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        qc.pairs = pairs;
        qc.planes = planes;
        qc.planePatches = endpoints;
        qc.planeTol = impl_->planeTol;
        qc.endpoints = cd ? endpoints : nullptr;
        qc.coplanar = cd;
        qc.patches = impl_->patches;
        rtcOccluded1M(impl_->scene, &qc.ctx, rays, unsigned(n), sizeof(RTCRay));
        // An occluded ray has tfar set to -inf.
        for (size_t i = 0; i < n; ++i) out[base + i] = (hiddenEnd[i] || rays[i].tfar < 0.0f) ? 1 : 0;
    }
}

bool Visibility::occluded(const Segment& s) const {
    uint8_t o = 0;
    occluded(&s, 1, &o);
    return o != 0;
}

RayHit Visibility::intersect(const Vec3& origin, const Vec3& dir, double tmin, double tmax,
                             uint32_t ignorePatch) const {
    RTCRayHit rh;
    rh.ray.org_x = float(origin.x);
    rh.ray.org_y = float(origin.y);
    rh.ray.org_z = float(origin.z);
    rh.ray.dir_x = float(dir.x);
    rh.ray.dir_y = float(dir.y);
    rh.ray.dir_z = float(dir.z);
    rh.ray.tnear = float(std::max(0.0, tmin));
    rh.ray.tfar = tmax >= double(FLT_MAX) ? std::numeric_limits<float>::infinity() : float(tmax);
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    const uint32_t ignore = frontOf(ignorePatch);
    uint32_t pairs[2] = {ignore, ignore};
    EndPlane planes[2] = {planeOf(impl_->patches, ignorePatch), EndPlane{}};
    uint32_t planePatches[2] = {ignorePatch, UINT32_MAX};
    QueryContext qc;
    rtcInitIntersectContext(&qc.ctx);
    qc.pairs = pairs;
    qc.planes = planes;
    qc.planePatches = planePatches;
    qc.planeTol = impl_->planeTol;
    qc.coplanar = impl_->coplanar.overlaps ? &impl_->coplanar : nullptr;
    qc.patches = impl_->patches;
    qc.nearest = true;
    rtcIntersect1(impl_->scene, &qc.ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return RayHit{};
    uint32_t patch = impl_->patchOf(rh.hit.geomID, rh.hit.primID);
    {
        // The back of a one-sided face: a face whose front meets the ray in
        // the same plane at the same point is hit instead (header comment).
        const scene::Patch& hp = impl_->patches[patch];
        const double dn = glm::dot(hp.normal, dir);
        if (hp.twin == UINT32_MAX && dn > 0.0 && impl_->overlaps.inSheet(patch)) {
            const double t = double(rh.ray.tfar);
            const double w = 2.0 * double(impl_->planeTol) / dn;
            RTCRayHit again = rh;
            again.ray.tnear = float(std::max({0.0, tmin, t - w}));
            again.ray.tfar = float(t + w);
            again.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            again.hit.primID = RTC_INVALID_GEOMETRY_ID;
            again.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            QueryContext front = qc;
            rtcInitIntersectContext(&front.ctx);
            front.frontOnly = true;
            rtcIntersect1(impl_->scene, &front.ctx, &again);
            if (again.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
                rh = again;
                patch = impl_->patchOf(rh.hit.geomID, rh.hit.primID);
            }
        }
    }
    RayHit out;
    out.hit = true;
    out.patch = patch;
    if (out.patch < impl_->twin.size() && impl_->twin[out.patch] != UINT32_MAX &&
        glm::dot(impl_->patches[out.patch].normal, dir) > 0.0)
        out.patch = impl_->twin[out.patch];
    out.t = double(rh.ray.tfar);
    out.point = origin + out.t * dir;
    return out;
}

uint64_t Visibility::memoryBytes() const {
    int64_t b = impl_->bytes.load(std::memory_order_relaxed);
    return b > 0 ? uint64_t(b) : 0;
}

}  // namespace hrad::transport
