// Discontinuity meshing from light sources: a meshing stage run by the
// loader before back sides and the hierarchy (scene/loader.h, MeshingFn).
//
// Where an occluder casts a shadow from an area source, radiosity on a
// receiver changes its derivatives across the critical surfaces of the
// visual event: EV events (a source vertex and an occluder edge) and VE
// events (an occluder vertex and a source edge) bound the umbra and the
// penumbra and separate the penumbra's regions (Heckbert 1992, "Discontinuity
// meshing for radiosity"; Lischinski, Tampieri & Greenberg 1992; Drettakis &
// Fiume 1994 classify the same events). A quadtree approximates such a line
// by a staircase of small elements; cut along it, the patch's pieces each
// hold a smooth part of the shadow. Emitters' events only ("primary"
// discontinuities): D1/D2 from polygonal sources; the D0 of contacts and of
// point sources, EEE events and secondary D-levels are not generated.
//
// Per receiver patch r and source s (an emitter, or with mesh.discontinuity =
// emitters+occluders also one of the mesh.secondary_sources reflectors of
// largest area x reflectance):
//  1. candidate occluders: patches whose bounds meet the bounds of the convex
//     hull of s and r (an AABB tree, so a pair costs log n plus its
//     candidates) and that no face of that hull separates (Haines & Wallace's
//     shaft culling, 1991, with the hull's exact faces); the
//     mesh.max_occluders of largest area are kept;
//  2. events: for each source vertex and occluder edge (EV) whose plane is
//     tangent to the source and on which the edge is a silhouette (the faces
//     sharing it lie on one side), and each occluder vertex and source edge
//     (VE) whose plane is tangent to the occluder there, the critical segment
//     is the central projection of the edge onto r's plane (from the vertex,
//     EV; through it, VE), clipped to the heights where the line reaches the
//     plane beyond the occluder, then to r's polygon;
//  3. with mesh.cull_hidden, a segment whose critical lines are blocked by
//     other surfaces at all three sample points (rays receiver -> occluder ->
//     source) is dropped: the event does not happen there;
//  4. the mesh.max_curves longest segments (shorter than mesh.min_curve x
//     r's diameter dropped) cut r through scene::cutConvexPolygon (a CGAL
//     arrangement, then a constrained Delaunay triangulation of its faces).
// Pieces keep their patch's material; Scene::sourcePatch maps them back.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/loader.h"
#include "scene/scene.h"

namespace hrad::transport {

/// Cuts `scene`'s patches (front sides; call before addBackSides) along the
/// discontinuity segments above; `origin` receives, per patch of the result,
/// the index of the input patch it is (or is a piece of).
scene::DiscontinuityStats discontinuityMesh(scene::Scene& scene,
                                            const scene::DiscontinuitySettings& settings,
                                            std::vector<uint32_t>& origin);

/// The stage as the loader's hook (transport::loadScene hands it in).
scene::MeshingFn discontinuityMeshFn();

}  // namespace hrad::transport
