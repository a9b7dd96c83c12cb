// Polygon intake shared by every loader: planar convex quads stay quads,
// everything else becomes triangles.
//
// addPolygon() is the one door through which loaders hand faces to a Scene:
//   1. consecutive duplicate vertices and collinear (or spike) vertices are
//      removed (tolerance relative to the face size);
//   2. 3 vertices -> Scene::addTriangle;
//   3. 4 vertices that are planar (distance to the Newell plane <= 1e-6 times
//      the face diameter) and strictly convex -> Scene::addQuad, vertex order
//      kept so the normal follows the right-hand rule;
//   4. anything else (n-gons, non-planar or non-convex polygons, polygons with
//      MGF-style seams to holes) is projected on its best-fit plane (Newell
//      normal) and triangulated with a CGAL constrained Delaunay triangulation;
//      only triangles inside the polygon are kept (domain marked by the
//      nesting level of constraint crossings, as in the CGAL manual's
//      "Triangulating a Polygonal Domain" example), with the polygon's
//      orientation preserved. stats.triangulatedFaces counts these faces.
// Degenerate faces (fewer than 3 distinct, non-collinear vertices, or zero
// area) are dropped and counted in stats.droppedDegenerate; faces whose area
// overflows a double in stats.overflowFaces (loadScene refuses those scenes).
// Every call counts one stats.inputFaces.
//
// CGAL (Exact_predicates_inexact_constructions_kernel) is included only by
// triangulate.cpp and linked PRIVATE to hrad::scene.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/types.h"
#include "scene/scene.h"

namespace hrad::scene {

/// Adds a polygon (vertices in order, counter-clockwise seen from the front)
/// to the scene; returns the number of patches added (0 when dropped).
/// `uvs`, when given (one per vertex), become each patch's corner UVs
/// (Scene::cornerUVs): a patch corner takes the UV of the input vertex at its
/// position (the nearest one for a point a triangulation inserted).
size_t addPolygon(Scene& scene, const std::vector<Vec3>& vertices, uint32_t material,
                  const std::vector<Vec2>* uvs = nullptr);

/// Removes consecutive duplicates and collinear/spike vertices (relative
/// tolerance `relTol` times the polygon's bounding-box diagonal).
std::vector<Vec3> cleanPolygon(const std::vector<Vec3>& vertices, double relTol = 1e-9);

/// Newell normal (not normalised; length = 2 * area for planar polygons).
Vec3 newellNormal(const std::vector<Vec3>& vertices);

/// Triangulates a polygon (possibly non-convex, non-planar, with seams) on its
/// best-fit plane with a CGAL constrained Delaunay triangulation. Triangles are
/// returned counter-clockwise around the polygon's Newell normal. Returns false
/// when the polygon has no area or CGAL fails.
bool triangulatePolygon(const std::vector<Vec3>& vertices,
                        std::vector<std::array<Vec3, 3>>& triangles);

/// What splitIntersections() did.
struct SplitStats {
    uint64_t crossings = 0;     ///< triangle pairs that cross (one segment each)
    uint64_t splitPatches = 0;  ///< patches replaced by their pieces
    uint64_t candidates = 0;    ///< splitWhereDark: patches that cross or touch (cut kept or not)
    uint64_t pieces = 0;        ///< triangles that replaced them
    uint64_t thinPieces = 0;    ///< pieces thinner than the tolerance, left out
    double thinArea = 0.0;      ///< their area
};

/// Splits the patches that pass through one another (interpenetrating
/// meshes: a frame sunk into a mirror, a leg through a floor) along their
/// lines of intersection, so that the part of a patch inside another object
/// becomes a patch of its own. Radiosity gives a patch one value over all
/// its points: a patch half inside a closed object carries the light of its
/// outer half to the object's inner faces, which then hold light no path can
/// bring there (the bathroom's mirror is a closed two-sided slab 7 mm thick
/// whose wooden frame cuts through it; its inner faces were lit). Split, the
/// inner pieces see only the inside and the reachability pass
/// (transport/reachability.h) leaves them dark. Setting split_intersections
/// (scene/loader.h), off by default.
/// Candidate pairs come from CGAL's box intersection (Zomorodian &
/// Edelsbrunner 2002), each pair's segment from CGAL's triangle-triangle
/// intersection, and each cut patch is retriangulated by a constrained
/// Delaunay triangulation in its plane with the segments as constraints.
/// Segment end points within the tolerance (1e-7 of the scene diagonal) of
/// a corner, an edge or another end point are moved onto it, and pieces
/// still thinner than it (height over the longest edge) are left out and
/// counted (SplitStats::thinPieces): the crossings are computed in floating
/// point, and a piece of no size has singular kernels (graz.mgf: pieces of
/// 1e-20 m^2 took radiosities of 1e16).
/// Only crossings count: a segment along an edge of either patch (a box
/// standing on a floor, meshes sharing an edge) is touching and cuts
/// nothing; parallel patches (coplanar overlaps, scene/coplanar.h) are left
/// alone. Pieces keep the patch's material, reflectance and emission, so
/// areas and emitted power are unchanged. Call before addBackSides().
/// `origin`, when given, receives for each patch of the result the index of
/// the input patch it is (or is a piece of); a patch's pieces are adjacent.
/// `touching` also cuts a patch along an edge of another that lies inside it
/// (the walls of a box standing on a floor cut the floor around the box's
/// footprint; a shared edge cuts nothing): splitWhereDark (loader.h) keeps
/// such a cut where the footprint closes a dark space, as a paper block
/// whose faces stand on a binder's floor.
SplitStats splitIntersections(Scene& scene, std::vector<uint32_t>* origin = nullptr,
                              bool touching = false);

/// What cutConvexPolygon() made of one polygon and its cut segments.
struct PlanarCut {
    std::vector<std::array<Vec2, 3>> triangles;  ///< counter-clockwise
    size_t faces = 0;     ///< bounded faces of the arrangement (the regions the cuts make)
    size_t edges = 0;     ///< arrangement edges (cut and boundary pieces)
    size_t vertices = 0;  ///< arrangement vertices
    size_t thin = 0;      ///< triangles thinner than `tol` left out (rounding slivers)
};

/// Cuts a convex polygon (counter-clockwise, 2D) along `segments` (each
/// already inside it, clipped by the caller): the segments and the boundary
/// go into a CGAL 2D arrangement (exact constructions, so overlapping and
/// crossing cuts merge exactly), and the arrangement's edges, rounded to
/// double, become the constraints of a constrained Delaunay triangulation
/// whose triangles tile the faces (no Steiner points). Triangles whose height
/// over their longest edge is below `tol` are rounding slivers and are
/// dropped (counted in `thin`). Used by discontinuity meshing
/// (transport/discontinuity.h); Lischinski, Tampieri & Greenberg 1992 build
/// the same structure (a 2D mesh conforming to the discontinuity segments)
/// with their own DM-tree. Returns false when CGAL fails.
bool cutConvexPolygon(const std::vector<Vec2>& polygon,
                      const std::vector<std::pair<Vec2, Vec2>>& segments, double tol,
                      PlanarCut& out);

}  // namespace hrad::scene
