// glTF solution export (see gltf_export.h).
#include "render/gltf_export.h"

#include <algorithm>
#include <bit>
#include <fstream>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <tiny_gltf.h>

#include "core/error.h"
#include "core/safe_file.h"
#include "render/gltf_model.h"
#include "render/image.h"
#include "render/render.h"
#include "scene/element.h"

namespace hrad::render {

namespace {

using gltf::putLE;

/// A tightly packed accessor over bytes [offset, offset + length) of buffer 0.
int addAccessor(tinygltf::Model& m, size_t offset, size_t length, int componentType, int type, size_t count,
                int target) {
    tinygltf::BufferView bv;
    bv.buffer = 0;
    bv.byteOffset = offset;
    bv.byteLength = length;
    bv.target = target;
    m.bufferViews.push_back(bv);
    tinygltf::Accessor a;
    a.bufferView = int(m.bufferViews.size()) - 1;
    a.componentType = componentType;
    a.type = type;
    a.count = count;
    m.accessors.push_back(a);
    return int(m.accessors.size()) - 1;
}

std::vector<double> columnMajor(const glm::dmat4& mat) {
    const double* p = glm::value_ptr(mat);
    return std::vector<double>(p, p + 16);
}

}  // namespace

GltfCounts writeGlb(const scene::RadiosityField& field, const std::string& path, const GltfExportOptions& options) {
    const scene::Scene& sc = field.scene();
    GltfCounts counts;
    ToneMap tone;
    if (options.tone) {
        tone = *options.tone;
    } else {
        ToneSettings ts;
        ts.exposure = options.exposure > 0 ? options.exposure : 0.0;
        tone = leafToneMap(field, ts);
    }
    counts.exposure = tone.exposure;
    const std::vector<FieldLeaf> leaves = fieldLeaves(field);
    counts.leaves = leaves.size();
    std::unique_ptr<VertexInterpolation> interp;
    if (options.interpolate) interp = std::make_unique<VertexInterpolation>(field, options.smooth);

    for (const FieldLeaf& l : leaves) {
        int n = sc.patches[l.patch].numVertices();
        counts.vertices += uint64_t(n);
        counts.triangles += uint64_t(n - 2);
    }
    // GLB stores its lengths in 32 bits (§4.4): positions, colours, radiosity
    // (36 bytes per vertex) and indices (12 bytes per triangle) must fit.
    uint64_t bytes = 36 * counts.vertices + 12 * counts.triangles;
    if (bytes > uint64_t(std::numeric_limits<uint32_t>::max()) - (uint64_t(1) << 20))
        throwInputError(SourceLocation{path, 0, 0}, "the solution ({} leaves, {} bytes of vertex data) exceeds the "
                        "4 GiB a GLB file can hold; use the PLY export", counts.leaves, bytes);

    std::vector<unsigned char> pos, col, rad, idx;
    pos.reserve(size_t(12 * counts.vertices));
    col.reserve(size_t(12 * counts.vertices));
    rad.reserve(size_t(12 * counts.vertices));
    idx.reserve(size_t(12 * counts.triangles));
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    uint32_t base = 0;
    for (const FieldLeaf& l : leaves) {
        const scene::Patch& p = sc.patches[l.patch];
        Vec3 c[4];
        int n = scene::elementCorners(p, scene::keyDomain(p.kind, l.key), c);
        for (int i = 0; i < n; ++i) {
            glm::vec3 f(c[i]);  // positions are stored as float; min/max are of the stored values
            lo = glm::min(lo, glm::dvec3(f));
            hi = glm::max(hi, glm::dvec3(f));
            for (int k = 0; k < 3; ++k) putLE(pos, f[k]);
            RGB b = interp ? interp->cornerValue(l.patch, l.key, i)
                           : field.leafPoint(l.patch, l.key, l.b, scene::cornerLocal(p.kind, i).x, scene::cornerLocal(p.kind, i).y);
            // The PNG/PLY tone map (render/image.h) without its sRGB encoding.
            RGB d = tone.display(b);
            for (int k = 0; k < 3; ++k) putLE(col, float(d[k]));
            for (int k = 0; k < 3; ++k) putLE(rad, float(b[k]));
        }
        // Corners are counter-clockwise seen from the front (elementCorners),
        // which is glTF's front face (§3.7.2.1).
        for (uint32_t i : {0u, 1u, 2u}) putLE(idx, base + i);
        if (n == 4)
            for (uint32_t i : {0u, 2u, 3u}) putLE(idx, base + i);
        base += uint32_t(n);
    }

    tinygltf::Model m;
    m.asset.version = "2.0";
    m.asset.generator = "hrad";
    tinygltf::Value::Object extras;
    extras["scene"] = tinygltf::Value(sc.name);
    extras["exposure"] = tinygltf::Value(counts.exposure);
    extras["tone_curve"] = tinygltf::Value(tone.curveName());
    if (tone.curve == ToneCurve::Reinhard) extras["white"] = tinygltf::Value(tone.white);
    extras["interpolated"] = tinygltf::Value(options.interpolate);
    extras["COLOR_0"] = tinygltf::Value(std::string(
        "linear tone_curve(exposure * B) in [0, 1]: the PNG's tone map before sRGB encoding"));
    extras["_RADIOSITY"] = tinygltf::Value(std::string("linear radiosity B (W/m^2), RGB"));
    m.asset.extras = tinygltf::Value(extras);
    m.extensionsUsed.push_back("KHR_materials_unlit");

    tinygltf::Buffer buffer;
    buffer.data.reserve(pos.size() + col.size() + rad.size() + idx.size());
    auto append = [&](const std::vector<unsigned char>& v) {
        size_t at = buffer.data.size();
        buffer.data.insert(buffer.data.end(), v.begin(), v.end());
        return at;
    };
    size_t pOff = append(pos), cOff = append(col), rOff = append(rad), iOff = append(idx);
    m.buffers.push_back(std::move(buffer));
    const size_t nv = size_t(counts.vertices);
    int aPos = addAccessor(m, pOff, pos.size(), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv,
                           TINYGLTF_TARGET_ARRAY_BUFFER);
    if (nv > 0) {  // POSITION needs min and max (§3.7.2.1)
        m.accessors[size_t(aPos)].minValues = {lo.x, lo.y, lo.z};
        m.accessors[size_t(aPos)].maxValues = {hi.x, hi.y, hi.z};
    }
    int aCol = addAccessor(m, cOff, col.size(), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv,
                           TINYGLTF_TARGET_ARRAY_BUFFER);
    int aRad = addAccessor(m, rOff, rad.size(), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv,
                           TINYGLTF_TARGET_ARRAY_BUFFER);
    int aIdx = addAccessor(m, iOff, idx.size(), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                           size_t(3 * counts.triangles), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);

    tinygltf::Material mat;
    mat.name = "hrad radiosity (unlit vertex colours)";
    mat.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
    mat.pbrMetallicRoughness.metallicFactor = 0.0;
    mat.pbrMetallicRoughness.roughnessFactor = 1.0;
    mat.doubleSided = false;
    mat.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
    m.materials.push_back(mat);

    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = 0;
    prim.indices = aIdx;
    prim.attributes["POSITION"] = aPos;
    prim.attributes["COLOR_0"] = aCol;
    prim.attributes["_RADIOSITY"] = aRad;
    tinygltf::Mesh mesh;
    mesh.name = "leaf elements";
    mesh.primitives.push_back(prim);
    m.meshes.push_back(mesh);

    tinygltf::Node root = gltf::yUpRoot(sc);
    tinygltf::Node meshNode;
    meshNode.name = "radiosity";
    meshNode.mesh = 0;
    m.nodes.push_back(root);
    m.nodes.push_back(meshNode);
    m.nodes[0].children.push_back(1);
    if (sc.camera) {
        const scene::Camera& c = *sc.camera;
        tinygltf::Camera cam;
        cam.type = "perspective";
        cam.perspective.yfov = c.fovYDegrees * std::numbers::pi / 180.0;
        // A scene file's film (Mitsuba): yfov holds at its aspect (§5.13).
        if (c.filmWidth > 0 && c.filmHeight > 0) cam.perspective.aspectRatio = double(c.filmWidth) / c.filmHeight;
        cam.perspective.znear = std::max(1e-6, 1e-4 * sc.bounds().diagonal());
        // tinygltf writes zfar even when 0 (which glTF forbids): a far plane well
        // beyond the scene seen from the eye.
        cam.perspective.zfar = 10.0 * (sc.bounds().diagonal() + glm::length(c.eye - sc.bounds().center())) +
                               1.0 + cam.perspective.znear;
        m.cameras.push_back(cam);
        tinygltf::Node camNode;
        camNode.name = "scene camera";
        camNode.camera = 0;
        // glm::lookAt is the view matrix of a camera looking down -Z with +Y up;
        // its inverse places such a camera, as glTF's (§3.10.1).
        camNode.matrix = columnMajor(glm::inverse(glm::lookAt(c.eye, c.target, c.up)));
        m.nodes.push_back(camNode);
        m.nodes[0].children.push_back(2);
    }
    tinygltf::Scene scene;
    scene.name = sc.name;
    scene.nodes.push_back(0);
    m.scenes.push_back(scene);
    m.defaultScene = 0;

    gltf::writeGlbModel(m, path);
    return counts;
}

namespace gltf {

tinygltf::Node yUpRoot(const scene::Scene& sc) {
    glm::dmat4 toYUp(1.0);
    if (sc.upAxis == 2) toYUp = glm::rotate(glm::dmat4(1.0), -std::numbers::pi / 2, glm::dvec3(1, 0, 0));  // z -> y
    if (sc.upAxis == 0) toYUp = glm::rotate(glm::dmat4(1.0), std::numbers::pi / 2, glm::dvec3(0, 0, 1));   // x -> y
    tinygltf::Node root;
    root.name = "hrad scene";
    if (sc.upAxis != 1) root.matrix = columnMajor(toYUp);
    return root;
}

void writeGlbModel(tinygltf::Model& m, const std::string& path) {
    // Our own stream, so that a failed open or write (full disk) is reported.
    writeThroughTemp(path, [&](const std::filesystem::path& tmp) {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        tinygltf::TinyGLTF writer;
        bool ok = writer.WriteGltfSceneToStream(&m, out, /*prettyPrint=*/false, /*writeBinary=*/true);
        out.close();
        if (!ok || !out) throw IoError(path, "cannot write the glTF file (disk full?)");
    });
}

}  // namespace gltf

}  // namespace hrad::render
