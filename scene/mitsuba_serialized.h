// Reader of Mitsuba's `.serialized` mesh files (the `serialized` shape).
//
// Format (Mitsuba 0.6 documentation, "Serialized mesh loader", and Mitsuba 3
// plugin `serialized`, identical on disk): a file holds one or more meshes;
// each starts with a little-endian header `uint16 0x041C` (format id) and
// `uint16 version` (3 or 4), followed by one zlib stream with
//   uint32 flags        0x0001 vertex normals, 0x0002 texture coordinates,
//                       0x0008 vertex colours, 0x0010 face normals,
//                       0x1000 single precision, 0x2000 double precision
//   [version 4] the mesh name, a NUL-terminated string
//   uint64 vertexCount, uint64 triangleCount
//   positions (3 floats or doubles per vertex), then normals (3), texture
//   coordinates (2), colours (3) when their flags are set,
//   indices: 3 per triangle, uint32 (uint64 when vertexCount > 2^32 - 1).
// The file ends with a table of the meshes' start offsets (uint64 in version 4,
// uint32 in version 3) and a uint32 mesh count, used to find `shape_index`.
//
// hrad keeps positions, triangles and texture coordinates (flag 0x0002, as
// stored: Mitsuba's uv, whose v points down the image; the Mitsuba loader
// turns them into hrad's v-up UVs). Normals and colours are skipped. Every count is checked against a face budget and the
// bytes actually present before anything is allocated; truncated, corrupt or
// inconsistent data is an InputError naming the file and the byte offset.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.h"

namespace hrad::scene {

struct SerializedMesh {
    std::string name;
    std::vector<Vec3> positions;
    std::vector<std::array<uint32_t, 3>> triangles;
    std::vector<Vec2> texcoords;  ///< one per position when the file has them, else empty
    uint64_t inflatedBytes = 0;  ///< bytes the mesh's data inflate to (normals etc. included)
};

/// Reads mesh number `shapeIndex` of a `.serialized` file. At most `maxFaces`
/// triangles are accepted. `context` (e.g. "shape at scene.xml:12") is added
/// to error messages so the user finds the XML element that named the file.
/// The data may inflate to `maxInflatedBytes` at most (mitsuba.max_inflated_mb),
/// checked from the declared counts before anything is inflated.
SerializedMesh readSerialized(const std::string& path, uint64_t shapeIndex, uint64_t maxFaces,
                              const std::string& context = {},
                              uint64_t maxInflatedBytes = UINT64_MAX);

}  // namespace hrad::scene
