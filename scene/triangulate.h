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
// area) are dropped and counted in stats.droppedDegenerate. Every call counts
// one stats.inputFaces.
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
size_t addPolygon(Scene& scene, const std::vector<Vec3>& vertices, uint32_t material);

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

}  // namespace hrad::scene
