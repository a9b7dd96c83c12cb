// glTF solution export: the written .glb is read back with tinygltf and its
// vertices and colours compared with the field they came from.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numbers>

#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <tiny_gltf.h>

#include "core/error.h"
#include "reference/fullmatrix.h"
#include "render/gltf_export.h"
#include "render/render.h"
#include "scene/element.h"
#include "scene/loader.h"
#include "tests/gltf_validate.h"
#include "tests/test_util.h"

namespace hrad::render {
namespace {

tinygltf::Model readBack(const std::string& path) {
    tinygltf::TinyGLTF loader;
    tinygltf::Model m;
    std::string err, warn;
    EXPECT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err;
    return m;
}

/// Float VEC3 attribute values of the only primitive.
std::vector<glm::vec3> attribute(const tinygltf::Model& m, const std::string& name) {
    std::vector<glm::vec3> out;
    const auto& prim = m.meshes.at(0).primitives.at(0);
    auto it = prim.attributes.find(name);
    if (it == prim.attributes.end()) {
        ADD_FAILURE() << "no attribute " << name;
        return out;
    }
    const auto& a = m.accessors.at(size_t(it->second));
    EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
    EXPECT_EQ(a.type, TINYGLTF_TYPE_VEC3);
    const auto& bv = m.bufferViews.at(size_t(a.bufferView));
    const auto& data = m.buffers.at(size_t(bv.buffer)).data;
    EXPECT_LE(bv.byteOffset + a.byteOffset + 12 * a.count, data.size());
    out.resize(a.count);
    std::memcpy(out.data(), data.data() + bv.byteOffset + a.byteOffset, 12 * a.count);
    return out;
}

std::vector<uint32_t> indices(const tinygltf::Model& m) {
    const auto& a = m.accessors.at(size_t(m.meshes.at(0).primitives.at(0).indices));
    EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    const auto& bv = m.bufferViews.at(size_t(a.bufferView));
    std::vector<uint32_t> out(a.count);
    std::memcpy(out.data(), m.buffers.at(0).data.data() + bv.byteOffset + a.byteOffset, 4 * a.count);
    return out;
}

struct Expected {
    std::vector<glm::vec3> pos;  // as stored (float)
    std::vector<RGB> b;           // the field's values (double)
    std::vector<uint32_t> patch;
    size_t triangles = 0;
};

/// The vertices writeGlb must produce, in its order (patches, then leaves).
Expected expectedVertices(const scene::RadiosityField& f, const VertexInterpolation* interp) {
    Expected e;
    const scene::Scene& s = f.scene();
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        f.forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) {
            Vec3 c[4];
            int n = scene::elementCorners(s.patches[p], scene::keyDomain(s.patches[p].kind, k), c);
            for (int i = 0; i < n; ++i) {
                e.pos.emplace_back(c[i]);
                e.b.emplace_back(interp ? interp->cornerValue(p, k, i) : b);
                e.patch.push_back(p);
            }
            e.triangles += size_t(n - 2);
        });
    return e;
}

TEST(GltfExport, CornellSolutionReadsBackWithItsColours) {
    auto dir = test::tempDir("gltf_export");
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    reference::FullMatrixSettings st;
    st.level = 1;
    auto r = reference::solveFullMatrix(s, vis, st, false);
    const scene::RadiosityField& field = *r.field;

    // The light's radiosity: the largest luminance of the solution.
    double lightB = 0;
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        if (s.patches[p].isEmitter()) field.forEachLeaf(p, [&](scene::ElementKey, const RGB& b) { lightB = std::max(lightB, b.g); });
    ASSERT_GT(lightB, 0);
    const double exposure = 0.5 / lightB;  // the light maps to (about) 0.5: nothing of it is clamped

    for (bool interpolate : {false, true}) {
        SCOPED_TRACE(interpolate ? "interpolated" : "flat");
        std::string path = (dir / (interpolate ? "smooth.glb" : "flat.glb")).string();
        GltfCounts counts = writeGlb(field, path, {exposure, interpolate});
        HRAD_EXPECT_VALID_GLTF(path);
        std::unique_ptr<VertexInterpolation> interp;
        if (interpolate) interp = std::make_unique<VertexInterpolation>(field);
        Expected e = expectedVertices(field, interp.get());
        EXPECT_EQ(counts.vertices, e.pos.size());
        EXPECT_EQ(counts.triangles, e.triangles);
        EXPECT_EQ(counts.exposure, exposure);

        tinygltf::Model m = readBack(path);
        ASSERT_EQ(m.meshes.size(), 1u);
        std::vector<glm::vec3> pos = attribute(m, "POSITION"), col = attribute(m, "COLOR_0"),
                               rad = attribute(m, "_RADIOSITY");
        ASSERT_EQ(pos.size(), e.pos.size());
        ASSERT_EQ(col.size(), e.pos.size());
        ASSERT_EQ(rad.size(), e.pos.size());
        std::vector<uint32_t> idx = indices(m);
        EXPECT_EQ(idx.size(), 3 * e.triangles);
        for (uint32_t i : idx) ASSERT_LT(i, pos.size());
        size_t lightVertices = 0;
        for (size_t i = 0; i < pos.size(); ++i) {
            ASSERT_EQ(pos[i], e.pos[i]) << i;
            // linear, tone mapped as the PNG before its sRGB encoding
            for (int k = 0; k < 3; ++k) {
                EXPECT_EQ(col[i][k], float(std::clamp(exposure * e.b[i][k], 0.0, 1.0))) << i;
                EXPECT_EQ(rad[i][k], float(e.b[i][k])) << i;
            }
            if (s.patches[e.patch[i]].isEmitter()) {
                ++lightVertices;
                // the light: the brightest element, near 0.5 after the exposure
                EXPECT_GT(col[i].g, 0.3f) << i;
                EXPECT_LE(col[i].g, 0.5f + 1e-6f) << i;
            }
        }
        EXPECT_GT(lightVertices, 0u);
        if (!interpolate) {
            // Flat: each leaf's corners carry its own value, so the light's
            // vertices reproduce its radiosity.
            for (size_t i = 0; i < pos.size(); ++i) {
                if (s.patches[e.patch[i]].isEmitter()) {
                    EXPECT_GT(rad[i].g, 0.5 * lightB);
                }
            }
        }
        // The unlit material and the scene camera.
        ASSERT_EQ(m.materials.size(), 1u);
        EXPECT_TRUE(m.materials[0].extensions.count("KHR_materials_unlit"));
        ASSERT_EQ(m.cameras.size(), 1u);
        ASSERT_TRUE(s.camera.has_value());
        EXPECT_NEAR(m.cameras[0].perspective.yfov * 180 / 3.14159265358979, s.camera->fovYDegrees, 1e-9);
        for (const auto& n : m.nodes)
            if (n.camera == 0) {
                ASSERT_EQ(n.matrix.size(), 16u);
                glm::dmat4 mat = glm::make_mat4(n.matrix.data());
                glm::dvec4 eye = mat * glm::dvec4(0, 0, 0, 1), dir = mat * glm::dvec4(0, 0, -1, 0);
                EXPECT_NEAR(glm::length(glm::dvec3(eye) - s.camera->eye), 0.0, 1e-6 * glm::length(s.camera->eye));
                Vec3 want = glm::normalize(s.camera->target - s.camera->eye);
                EXPECT_NEAR(glm::dot(glm::normalize(glm::dvec3(dir)), want), 1.0, 1e-9);
            }
    }
}

TEST(GltfExport, InterpolatedCornersAgreeAcrossLeaves) {
    // Two levels of a uniform field on the furnace box's walls with distinct
    // values: in interpolated mode the vertices at one point of one patch
    // carry one colour; in flat mode they differ.
    auto dir = test::tempDir("gltf_interp");
    scene::Scene s = scene::loadScene("furnace");
    scene::UniformField f(s, scene::uniformLevels(s, 2, 0));
    for (size_t i = 0; i < f.numElements(); ++i) f.value(i) = RGB(0.01 * double(i % 50));
    for (bool interpolate : {false, true}) {
        std::string path = (dir / "a.glb").string();
        writeGlb(f, path, {1.0, interpolate});
        HRAD_EXPECT_VALID_GLTF(path);
        tinygltf::Model m = readBack(path);
        auto pos = attribute(m, "POSITION");
        auto col = attribute(m, "COLOR_0");
        Expected e = expectedVertices(f, nullptr);
        ASSERT_EQ(pos.size(), e.pos.size());
        size_t mismatches = 0, shared = 0;
        for (size_t i = 0; i < pos.size(); ++i)
            for (size_t j = i + 1; j < pos.size() && e.patch[j] == e.patch[i]; ++j)
                if (pos[i] == pos[j]) {
                    ++shared;
                    mismatches += col[i] != col[j];
                }
        EXPECT_GT(shared, 0u);
        if (interpolate) {
            EXPECT_EQ(mismatches, 0u);
        } else {
            EXPECT_GT(mismatches, 0u);
        }
    }
}

TEST(GltfExport, ZUpSceneStandsUpright) {
    auto dir = test::tempDir("gltf_zup");
    scene::Scene s = scene::loadScene("furnace");
    s.upAxis = 2;
    scene::UniformField f(s, scene::uniformLevels(s, 0, 0));
    std::string path = (dir / "z.glb").string();
    writeGlb(f, path);
    HRAD_EXPECT_VALID_GLTF(path);
    tinygltf::Model m = readBack(path);
    ASSERT_EQ(m.scenes.size(), 1u);
    const auto& root = m.nodes.at(size_t(m.scenes[0].nodes.at(0)));
    ASSERT_EQ(root.matrix.size(), 16u);
    glm::dvec4 up = glm::make_mat4(root.matrix.data()) * glm::dvec4(0, 0, 1, 0);
    EXPECT_NEAR(up.y, 1.0, 1e-12);
    EXPECT_NEAR(std::abs(up.x) + std::abs(up.z), 0.0, 1e-12);
}

TEST(GltfExport, CameraWithAFilmWritesItsAspectRatio) {
    auto dir = test::tempDir("gltf_film");
    scene::Scene s = scene::loadScene("furnace");
    scene::UniformField f(s, scene::uniformLevels(s, 0, 0));
    writeGlb(f, (dir / "nofilm.glb").string());
    EXPECT_EQ(readBack((dir / "nofilm.glb").string()).cameras.at(0).perspective.aspectRatio, 0.0);  // absent
    s.camera->filmWidth = 200;
    s.camera->filmHeight = 100;
    scene::UniformField g(s, scene::uniformLevels(s, 0, 0));
    writeGlb(g, (dir / "film.glb").string());
    HRAD_EXPECT_VALID_GLTF((dir / "nofilm.glb").string());
    HRAD_EXPECT_VALID_GLTF((dir / "film.glb").string());
    tinygltf::Model m = readBack((dir / "film.glb").string());
    EXPECT_NEAR(m.cameras.at(0).perspective.aspectRatio, 2.0, 1e-12);
    EXPECT_NEAR(m.cameras.at(0).perspective.yfov, s.camera->fovYDegrees * std::numbers::pi / 180.0, 1e-12);
}

TEST(GltfExport, UnwritablePathIsAnInputError) {
    scene::Scene s = scene::loadScene("furnace");
    scene::UniformField f(s, scene::uniformLevels(s, 0, 0));
    EXPECT_THROW(writeGlb(f, "/nonexistent-folder-hrad/x.glb"), InputError);
}

}  // namespace
}  // namespace hrad::render
