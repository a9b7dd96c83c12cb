// PLY loader (Turk's polygon file format): ASCII, binary_little_endian and
// binary_big_endian.
//
// Reads element `vertex` (x, y, z as any numeric type; optional red, green,
// blue: integer types are divided by 255, float types taken as is; optional
// texture coordinates, the first pair present of (u, v), (s, t), (texture_u,
// texture_v), (texture_s, texture_t), the names Mitsuba 3's PLY reader takes,
// src/shapes/ply.cpp, plus texture_s/t) and element
// `face` (list property `vertex_indices` or `vertex_index`, any count/index
// types; optional face red, green, blue). Other elements and properties are
// skipped. Faces go through addPolygon.
//
// Materials, one per distinct colour (named "ply_RRGGBB"):
//   - the face's colour if the face has one, else the mean of its vertices'
//     colours, else a grey "default" with rho = PlyOptions::defaultRho;
//   - rho = colour, each channel clamped to at most 0.99 (rho must be < 1);
//   - PLY has no emission: a face whose colour is pure white (255, 255, 255,
//     or 1.0 for float colours) is an emitter ("ply_emitter") with rho = 0 and
//     E = PlyOptions::emission (grey, Params key ply.emission).
// Errors name the file and line (ASCII: the data line; binary: the byte
// offset is in the message).
#pragma once

#include <string>

#include "scene/scene.h"

namespace hrad::scene {

struct PlyOptions {
    double emission = 1.0;    ///< E of pure white faces
    double defaultRho = 0.5;  ///< rho of faces without colour
    double clampRho = 0.99;   ///< colour channels >= 1 become this (scene.clamp_rho; 0: an error)
    /// Keep the vertices' texture coordinates as corner UVs (Scene::cornerUVs),
    /// as stored in the file. A PLY names no texture, so only a loader that
    /// gives the mesh one (Mitsuba's bitmap) asks for them.
    bool keepUVs = false;
};

Scene loadPly(const std::string& path, const PlyOptions& options = {});

}  // namespace hrad::scene
