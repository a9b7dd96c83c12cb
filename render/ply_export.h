// PLY export of a radiosity field's leaf elements, for MeshLab / Blender.
//
// Binary little-endian PLY. Every leaf element becomes one face (a triangle
// or a quad) with its own corner vertices (not shared, so each face keeps its
// constant radiosity). Vertices carry float x, y, z and uchar red, green, blue
// (the radiosity at that corner tone mapped by the ToneMap of render/image.h,
// the PNG's: curve(exposure * B), sRGB; with `interpolate`, the corner values
// of render::VertexInterpolation, the smooth reconstruction); faces carry "list uchar int vertex_indices" and float radiosity_r,
// radiosity_g, radiosity_b (linear B in W/m^2), which MeshLab and Blender
// ignore but scripts can read.
#pragma once

#include <cstdint>
#include <string>

#include "render/image.h"
#include "render/smooth.h"
#include "scene/field.h"

namespace hrad::render {

struct PlyCounts {
    uint64_t vertices = 0, faces = 0;
};

/// Writes the leaves of `field`. exposure > 0 multiplies B before tone
/// mapping; exposure <= 0 picks it automatically (autoExposure over the leaves,
/// area-weighted). Throws hrad::InputError naming the path on I/O failure.
PlyCounts writePly(const scene::RadiosityField& field, const std::string& path,
                   double exposure = 0.0);
/// The same with the tone map of the PNG (one tone map for every output).
PlyCounts writePly(const scene::RadiosityField& field, const std::string& path,
                   const ToneMap& tone, bool interpolate = false,
                   const SmoothSettings& smooth = {});

}  // namespace hrad::render
