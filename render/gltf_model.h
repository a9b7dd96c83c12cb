// What the two glTF writers share (render/gltf_export.cpp: the solution's
// leaf elements; render/lightmap.cpp: the lightmapped root patches), so that
// both place the scene alike and write alike: the root node that turns the
// scene's up axis into glTF's +Y (glTF 2.0 §3.4: +Y up), little-endian
// packing of buffer data, and the .glb written through core/safe_file.
#pragma once

#include <algorithm>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include <tiny_gltf.h>

#include "scene/scene.h"

namespace hrad::render::gltf {

/// Appends `value` to `out` in little-endian byte order (glTF buffers).
template <typename T>
void putLE(std::vector<unsigned char>& out, T value) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    out.insert(out.end(), b, b + sizeof(T));
}

/// The node "hrad scene" whose matrix maps the scene's up axis to +Y (none
/// when it is already Y); the caller adds its children.
tinygltf::Node yUpRoot(const scene::Scene& sc);

/// Writes `m` as binary glTF to `path` (through a temporary file, renamed);
/// IoError when the write fails.
void writeGlbModel(tinygltf::Model& m, const std::string& path);

}  // namespace hrad::render::gltf
