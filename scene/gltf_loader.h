// glTF 2.0 loader (.gltf JSON with external or data-URI buffers, and binary
// .glb), parsed by tinygltf (Debian libtinygltf-dev: a shared library that
// already contains the implementation, nlohmann-json and stb_image).
//
// What is read (glTF 2.0 specification, Khronos 2021, sections cited as §):
//   - the default scene (`scene`, else scenes[0]; a file without scenes uses
//     every node that has no parent, with a warning) and its node trees with
//     their transforms: `matrix` (column-major) or T * R * S (§3.5.2),
//     composed parent * child. A node with two parents, a child index that
//     names no node and a scene root that is someone's child are errors; the
//     traversal uses an explicit stack, so deep chains cannot overflow it.
//   - meshes: TRIANGLES, indexed or not; TRIANGLE_STRIP and TRIANGLE_FAN are
//     unrolled with the winding rules of §3.7.2.1; POINTS and LINES* are
//     skipped with one warning per file. A node whose world matrix has a
//     negative determinant has its winding reversed (§3.7.2.1), so normals
//     still point to the front. POSITION may be float or (KHR_mesh_quantization)
//     normalised / plain integers. Every triangle goes through addPolygon
//     (scene/triangulate.h), which drops degenerate ones.
//   - materials (one hrad material per glTF material used):
//       rho = baseColorFactor.rgb * mean(baseColorTexture)
//       E   = pi * emissiveFactor * emissiveStrength * mean(emissiveTexture)
//             * gltf.emission_scale
//     glTF's emissive term is the emitted radiance of the surface in the
//     scene's linear RGB units (§3.9.3; KHR_materials_emissive_strength
//     multiplies it); a Lambertian emitter of radiance L has radiosity
//     E = pi L (Cohen & Wallace 1993, eq. 2.12), so E = pi * emissive.
//     baseColorTexture is kept (scene/texture.h): sRGB-decoded (§3.9.2),
//     the sampler's wrap modes, TEXCOORD_n of its texCoord (v flipped to
//     hrad's v up); rho above (the mean over all texels) is the fallback of
//     primitives without UVs, and each textured patch gets its own mean.
//     An emissive texture is replaced by its mean, with one warning per
//     material. An image tinygltf's stb loader cannot decode (or an external
//     image file that is missing) leaves the factor alone and warns; decoded
//     texels count against texture.max_mb, checked from the image's header
//     before decoding (an error naming the setting). metallic/roughness, alpha, normal and occlusion maps
//     are ignored: the diffuse albedo is baseColor, as a path tracer that
//     treats the surface as Lambertian would see it.
//     Reflectance channels >= 1 (glTF's default baseColorFactor is 1, so
//     white is common) become scene.clamp_rho with one warning per material;
//     with scene.clamp_rho = 0 they are an error, as in every format.
//     `doubleSided` -> Material::twoSided and emitsBothSides (glTF materials
//     are the same on both faces). A primitive without material gets a grey
//     "default" (gltf.default_rho), with one warning.
//   - the camera: cameras[0] where a node of the scene places it (else the
//     first camera placed in the scene), perspective `yfov` and the node's
//     world transform; glTF cameras look down -Z with +Y up (§3.10).
//     Orthographic cameras are reported and ignored (automatic view).
//   - up axis Y (glTF convention, §3.4).
// Not supported, each reported once: KHR_lights_punctual lights, sparse
// accessors (error), skins / morph targets / animations (the rest pose is
// loaded), vertex colours. A file that *requires* an extension other than
// KHR_materials_emissive_strength, KHR_mesh_quantization,
// KHR_texture_transform and KHR_materials_unlit (e.g. Draco) is an error.
//
// Errors: `.gltf` JSON syntax errors carry the line tinygltf (nlohmann-json)
// reports; a truncated or malformed `.glb` names the byte offset; every
// accessor is validated (index, buffer view, buffer, byte ranges, strides,
// component types, each index against the vertex count) before a byte is
// read. A problem hrad finds names its JSON path (e.g. accessors[3] (used as
// meshes[0].primitives[1].indices)), which is looked up in the JSON text again
// (tinygltf keeps no positions): the line of that value in a .gltf, its byte
// offset in a .glb. Checks tinygltf makes itself carry no line (line 0).
//
// Settings (Params keys, read in scene/loader.cpp):
//   gltf.default_rho    double 0.5   grey reflectance of primitives without material
//   (reflectance >= 1: scene.clamp_rho, scene/loader.h, as for every format)
//   gltf.emission_scale double 1.0   multiplies every emission (unit conversion)
//   gltf.max_faces      int    2e7   most triangles the scene may yield after
//                                    instancing (meshes used by many nodes)
#pragma once

#include <cstddef>
#include <string>

#include "scene/scene.h"

namespace hrad::scene {

struct GltfOptions {
    double defaultRho = 0.5;
    double clampRho = 0.99;  ///< scene.clamp_rho (scene.h clampReflectance)
    double emissionScale = 1.0;
    size_t maxFaces = 20000000;
    uint64_t textureBudget = uint64_t(2048) << 20;  ///< texture.max_mb, decoded bytes
};

/// Loads a .gltf or .glb file; throws InputError with file:line (JSON) or the
/// byte offset (binary) on malformed input.
Scene loadGltf(const std::string& path, const GltfOptions& options = {});

}  // namespace hrad::scene
