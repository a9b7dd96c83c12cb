// PLY export of a radiosity field's leaf elements, for MeshLab / Blender.
//
// Binary little-endian PLY. Every leaf element becomes one face (a triangle
// or a quad) with its own corner vertices (not shared, so each face keeps its
// constant radiosity). Vertices carry float x, y, z and uchar red, green, blue
// (the face's radiosity tone mapped as in render/image.h: exposure, clamp,
// sRGB); faces carry "list uchar int vertex_indices" and float radiosity_r,
// radiosity_g, radiosity_b (linear B in W/m^2), which MeshLab and Blender
// ignore but scripts can read.
#pragma once

#include <cstdint>
#include <string>

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

}  // namespace hrad::render
