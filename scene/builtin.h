// Built-in procedural scenes, addressed by name (DESIGN.md "Command line").
//
//   cornell                        the Cornell box (Cornell Program of Computer
//                                  Graphics measured geometry, mm)
//   furnace[:rho[:E[:side]]]       closed cube, 6 inward quads, all rho and E
//                                  equal (defaults 0.5, 1, 1); B = E/(1-rho)
//   plates:parallel:W:H:D          two opposed W x H rectangles at distance D
//   plates:perpendicular:W:H:L     two rectangles (widths W and H) sharing an
//                                  edge of length L at a right angle
//   plates:occluded:W:H:D:S:Z      plates:parallel:W:H:D plus a black S x S
//                                  square occluder at height Z (0 < Z < D)
//                                  centred over the receiver, facing it
//   office:N                       N x N grid of furnished rooms with doors
//                                  (225 N^2 quads)
//   office:N:T                     office:N with finely tessellated furniture at
//                                  level T (integer, 1..64): per room the desk
//                                  (top, 4 cylinder legs), the chair (cushioned
//                                  seat, back bent on an arc, 4 cylinder legs),
//                                  3 cups and a potted plant (tapered pot, 3
//                                  bumpy spheres) are 18 closed, connected,
//                                  outward-oriented triangle meshes with shared
//                                  (bit-identical) vertices, 1888 T^2 + 404 T
//                                  triangles per room, 8 T segments around
//                                  every round part; with the 176 quads of the
//                                  room shell, luminaire and bookcase:
//                                  N^2 (1888 T^2 + 404 T + 176) patches.
//                                  office:2:T spans 100x: T = 1: 9,872,
//                                  T = 4: 128,000, T = 12: 1,107,584 patches.
//                                  At most kOfficeMaxPatches patches.
//
// Every built-in sets stats.inputFaces to its patch count and source "builtin".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace hrad::scene {

/// Names accepted before the first ':' of a built-in spec.
const std::vector<std::string>& builtinNames();

/// Builds the built-in scene `spec`; throws InputError for unknown names or
/// malformed arguments (the message lists the valid forms).
Scene makeBuiltin(const std::string& spec);

Scene makeCornellBox();
Scene makeFurnace(double rho = 0.5, double emission = 1.0, double side = 1.0);
Scene makeParallelPlates(double width, double height, double distance);
Scene makePerpendicularPlates(double width, double height, double length);
Scene makeOccludedPlates(double width, double height, double distance, double side, double z);
/// office:N (tess = 0) or office:N:T (tess = T >= 1); see above.
Scene makeOffice(int n, int tess = 0);

/// Exact patch count of office:N (tess = 0) or office:N:T (formula above).
uint64_t officePatches(int n, int tess = 0);
/// Number of closed triangle meshes per room of office:N:T.
inline constexpr int kOfficeMeshesPerRoom = 18;
inline constexpr int kOfficeMaxTessellation = 64;
/// office:N:T specs with more patches are refused (InputError) before
/// anything is built: a patch takes about 200 bytes before solving.
inline constexpr uint64_t kOfficeMaxPatches = 20'000'000;

}  // namespace hrad::scene
