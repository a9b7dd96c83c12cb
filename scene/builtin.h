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
//
// Every built-in sets stats.inputFaces to its patch count and source "builtin".
#pragma once

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
Scene makeOffice(int n);

}  // namespace hrad::scene
