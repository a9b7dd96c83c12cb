// Built-in scenes (scene/builtin.h).
#include "scene/builtin.h"

#include <gtest/gtest.h>

#include <map>
#include <numeric>
#include <unordered_map>

#include "core/error.h"
#include "scene/loader.h"

namespace hrad::scene {
namespace {

// Sum over patches of area * normal: zero for a closed, consistently oriented
// surface (divergence theorem), whatever the orientation convention.
Vec3 orientedAreaSum(const Scene& s) {
    Vec3 sum(0.0);
    for (const auto& p : s.patches) sum += p.area * p.normal;
    return sum;
}

// Every edge of a closed mesh is used by faces on both sides: count edges
// (by exact endpoint pairs) that appear only once.
size_t boundaryEdges(const Scene& s) {
    std::map<std::pair<std::array<double, 3>, std::array<double, 3>>, int> count;
    for (const auto& p : s.patches) {
        int n = p.numVertices();
        for (int i = 0; i < n; ++i) {
            Vec3 a = p.v[size_t(i)], b = p.v[size_t((i + 1) % n)];
            std::array<double, 3> ka{a.x, a.y, a.z}, kb{b.x, b.y, b.z};
            if (kb < ka) std::swap(ka, kb);
            ++count[{ka, kb}];
        }
    }
    size_t once = 0;
    for (auto& [e, c] : count) once += c == 1;
    return once;
}

TEST(Builtin, CornellBoxGeometryMaterialsAndCamera) {
    Scene s = loadScene("cornell");
    // 1 light + floor, ceiling, back, green wall (quads) + red wall (2 triangles,
    // the measured wall is not planar) + 5 + 5 block faces.
    EXPECT_EQ(s.patches.size(), 17u);
    EXPECT_EQ(s.count(PatchKind::Triangle), 2u);
    EXPECT_EQ(s.numEmitters(), 1u);
    EXPECT_EQ(s.source, "builtin");
    // Light 130 x 105 mm.
    for (const auto& p : s.patches)
        if (p.isEmitter()) {
            EXPECT_NEAR(p.area, 130.0 * 105.0, 1e-9);
            EXPECT_NEAR(p.normal.y, -1.0, 1e-12);
            EXPECT_EQ(p.emission, RGB(17, 12, 4));
        }
    // Total area computed independently from the published data: floor
    // (trapezoid), ceiling, back, right wall, red wall (two triangles), blocks.
    double floorA = 0.5 * (552.8 + 549.6) * 559.2;
    double ceilA = 556.0 * 559.2, backA = 0.5 * (549.6 + 556.0) * 548.8, rightA = 559.2 * 548.8;
    Vec3 r0(552.8, 0, 0), r1(549.6, 0, 559.2), r2(556, 548.8, 559.2), r3(556, 548.8, 0);
    // The red wall is split along one diagonal by the CDT; either split is
    // within 1e-4 relative of the other, so compare loosely on the total.
    double redA = 0.5 * glm::length(glm::cross(r1 - r0, r2 - r0)) + 0.5 * glm::length(glm::cross(r2 - r0, r3 - r0));
    auto quadA = [](Vec3 a, Vec3 b, Vec3 c, Vec3 d) { return 0.5 * glm::length(glm::cross(c - a, d - b)); };
    double shortTop = quadA({130, 0, 65}, {82, 0, 225}, {240, 0, 272}, {290, 0, 114});
    double shortSides = 165.0 * (glm::length(Vec3(290 - 240, 0, 114 - 272)) + glm::length(Vec3(160, 0, 49)) +
                                 glm::length(Vec3(48, 0, 160)) + glm::length(Vec3(158, 0, 47)));
    double tallTop = quadA({423, 0, 247}, {265, 0, 296}, {314, 0, 456}, {472, 0, 406});
    double tallSides = 330.0 * (glm::length(Vec3(49, 0, 159)) + glm::length(Vec3(158, 0, 50)) +
                                glm::length(Vec3(49, 0, 160)) + glm::length(Vec3(158, 0, 49)));
    double expected = 130.0 * 105.0 + floorA + ceilA + backA + rightA + redA + shortTop + shortSides + tallTop + tallSides;
    EXPECT_NEAR(s.totalArea(), expected, 1e-4 * expected);
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.camera->eye, Vec3(278, 273, -800));
    EXPECT_NEAR(s.camera->fovYDegrees, 39.3077, 1e-3);
    // Walls face into the box: their normals point towards the box centre.
    Vec3 centre(278, 274.4, 279.6);
    for (const auto& p : s.patches) {
        if (p.area > 1e5) {  // the room's walls, floor and ceiling
            EXPECT_GT(glm::dot(p.normal, centre - p.centroid()), 0.0);
        }
    }
    EXPECT_EQ(s.materials[1].name, "red");
    EXPECT_EQ(s.materials[1].rho, RGB(0.63, 0.065, 0.05));
}

TEST(Builtin, FurnaceIsAClosedInwardCube) {
    Scene s = loadScene("furnace");
    EXPECT_EQ(s.patches.size(), 6u);
    EXPECT_EQ(s.count(PatchKind::Quad), 6u);
    EXPECT_NEAR(s.totalArea(), 6.0, 1e-12);
    EXPECT_EQ(boundaryEdges(s), 0u);
    EXPECT_NEAR(glm::length(orientedAreaSum(s)), 0.0, 1e-12);
    for (const auto& p : s.patches) {
        EXPECT_GT(glm::dot(p.normal, Vec3(0.5) - p.centroid()), 0.0);  // inward
        EXPECT_EQ(p.rho, RGB(0.5));
        EXPECT_EQ(p.emission, RGB(1.0));
    }
    Scene t = loadScene("furnace:0.8:2:3");
    EXPECT_NEAR(t.totalArea(), 54.0, 1e-9);
    EXPECT_EQ(t.patches[0].rho, RGB(0.8));
    EXPECT_EQ(t.patches[0].emission, RGB(2.0));
    EXPECT_THROW(loadScene("furnace:1.0:1"), InputError);  // rho must be < 1
    EXPECT_THROW(loadScene("furnace:abc"), InputError);
}

TEST(Builtin, ParallelPlatesDimensions) {
    Scene s = loadScene("plates:parallel:2:3:0.5");
    ASSERT_EQ(s.patches.size(), 2u);
    EXPECT_NEAR(s.patches[0].area, 6.0, 1e-12);
    EXPECT_NEAR(s.patches[1].area, 6.0, 1e-12);
    EXPECT_NEAR(glm::dot(s.patches[0].normal, s.patches[1].normal), -1.0, 1e-12);  // opposed
    EXPECT_NEAR(s.patches[1].centroid().z - s.patches[0].centroid().z, 0.5, 1e-12);
    EXPECT_GT(glm::dot(s.patches[0].normal, s.patches[1].centroid() - s.patches[0].centroid()), 0.0);
    EXPECT_EQ(s.numEmitters(), 1u);
}

TEST(Builtin, PerpendicularPlatesShareAnEdge) {
    Scene s = loadScene("plates:perpendicular:1:2:3");
    ASSERT_EQ(s.patches.size(), 2u);
    EXPECT_NEAR(s.patches[0].area, 3.0, 1e-12);  // W x L
    EXPECT_NEAR(s.patches[1].area, 6.0, 1e-12);  // H x L
    EXPECT_NEAR(glm::dot(s.patches[0].normal, s.patches[1].normal), 0.0, 1e-12);
    // Each faces the other.
    EXPECT_GT(glm::dot(s.patches[0].normal, s.patches[1].centroid() - s.patches[0].centroid()), 0.0);
    EXPECT_GT(glm::dot(s.patches[1].normal, s.patches[0].centroid() - s.patches[1].centroid()), 0.0);
    EXPECT_THROW(loadScene("plates:perpendicular:1:2"), InputError);
    EXPECT_THROW(loadScene("plates:diagonal:1:2:3"), InputError);
}

TEST(Builtin, OccludedPlatesAddACentredBlackOccluder) {
    Scene s = loadScene("plates:occluded:2:3:1:0.2:0.1");
    ASSERT_EQ(s.patches.size(), 3u);
    Scene p = loadScene("plates:parallel:2:3:1");
    for (uint32_t i = 0; i < 2; ++i) {  // receiver and sender as in plates:parallel
        EXPECT_EQ(s.patches[i].normal, p.patches[i].normal);
        EXPECT_EQ(s.patches[i].centroid(), p.patches[i].centroid());
        EXPECT_EQ(s.patches[i].area, p.patches[i].area);
    }
    const Patch& o = s.patches[2];
    EXPECT_NEAR(o.area, 0.04, 1e-12);
    EXPECT_NEAR(o.centroid().x, 1.0, 1e-12);
    EXPECT_NEAR(o.centroid().y, 1.5, 1e-12);
    EXPECT_NEAR(o.centroid().z, 0.1, 1e-12);
    EXPECT_NEAR(o.normal.z, -1.0, 1e-12);  // faces the receiver
    EXPECT_EQ(o.rho, RGB(0.0));
    EXPECT_EQ(o.emission, RGB(0.0));
    EXPECT_EQ(s.name, "plates:occluded:2:3:1:0.2:0.1");
    EXPECT_THROW(loadScene("plates:occluded:1:1:1:0.2"), InputError);
    EXPECT_THROW(loadScene("plates:occluded:1:1:1:0.2:1"), InputError);  // Z must be < D
    EXPECT_THROW(loadScene("plates:occluded:1:1:1:0:0.5"), InputError);
}

TEST(Builtin, OfficePatchCountScalesWithRooms) {
    Scene one = loadScene("office:1");
    Scene four = loadScene("office:4");
    std::cout << "[scene] office:1 " << one.patches.size() << " patches, office:4 " << four.patches.size()
              << " patches\n";
    EXPECT_GE(one.patches.size(), 100u);
    EXPECT_LE(one.patches.size(), 300u);
    double ratio = double(four.patches.size()) / double(one.patches.size());
    EXPECT_GT(ratio, 15.0);
    EXPECT_LT(ratio, 17.5);
    EXPECT_EQ(four.numEmitters(), 16u);
    // The room shells (walls, floors with door thresholds, ceilings, door
    // jambs: materials 0..2) form closed surfaces: their oriented areas cancel.
    // (Furniture boxes omit faces resting on other surfaces, so they are not.)
    Scene shell = four;
    std::erase_if(shell.patches, [](const Patch& p) { return p.material > 2; });
    EXPECT_NEAR(glm::length(orientedAreaSum(shell)), 0.0, 1e-9 * shell.totalArea());
    // Room surfaces face into their room: floors up, ceilings down.
    for (const auto& p : shell.patches) {
        if (p.material == 1) {
            EXPECT_NEAR(p.normal.y, 1.0, 1e-12);
        }
        if (p.material == 2) {
            EXPECT_NEAR(p.normal.y, -1.0, 1e-12);
        }
    }
    // Deterministic.
    Scene again = loadScene("office:4");
    ASSERT_EQ(again.patches.size(), four.patches.size());
    for (size_t i = 0; i < four.patches.size(); ++i) EXPECT_EQ(again.patches[i].v, four.patches[i].v);
}

// office:N:T (scene/builtin.h): exact patch counts, closed connected meshes.

// FNV-1a over every patch's kind, material and corner coordinates (bits).
uint64_t sceneDigest(const Scene& s) {
    uint64_t h = 1469598103934665603ull;
    auto mix = [&](const void* p, size_t n) {
        const auto* b = static_cast<const unsigned char*>(p);
        for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    };
    for (const auto& p : s.patches) {
        mix(&p.kind, sizeof p.kind);
        mix(&p.material, sizeof p.material);
        for (const auto& v : p.v) mix(&v[0], 3 * sizeof(double));
    }
    return h;
}

TEST(Builtin, OfficeWithoutTessellationIsUnchanged) {
    // office:N is 225 N^2 quads, and office:2 and office:3 are bit for bit what it was
    // before office:N:T existed (digests recorded from commit bf6e95e).
    for (int n : {1, 2, 3}) {
        Scene s = loadScene("office:" + std::to_string(n));
        EXPECT_EQ(s.patches.size(), officePatches(n));
        EXPECT_EQ(s.patches.size(), size_t(225 * n * n));
        EXPECT_EQ(s.count(PatchKind::Triangle), 0u);
        EXPECT_EQ(s.materials.size(), 11u);
    }
    EXPECT_EQ(sceneDigest(loadScene("office:2")), 0x36bd9f4206a73cc1ull);
    EXPECT_EQ(sceneDigest(loadScene("office:3")), 0x1265df5069ff22ebull);
}

TEST(Builtin, OfficeTessellatedPatchCountsAreAsDocumented) {
    // The numbers quoted in builtin.h.
    EXPECT_EQ(officePatches(2, 1), 9'872u);
    EXPECT_EQ(officePatches(2, 4), 128'000u);
    EXPECT_EQ(officePatches(2, 12), 1'107'584u);
    EXPECT_GE(double(officePatches(2, 12)) / double(officePatches(2, 1)), 100.0);
    for (auto [n, t] : {std::pair{1, 1}, std::pair{1, 2}, std::pair{2, 1}, std::pair{1, 3}}) {
        Scene s = loadScene(fmt::format("office:{}:{}", n, t));
        SCOPED_TRACE(s.name);
        const size_t rooms = size_t(n * n), tt = size_t(t);
        EXPECT_EQ(s.name, fmt::format("office:{}:{}", n, t));
        EXPECT_EQ(s.patches.size(), officePatches(n, t));
        EXPECT_EQ(s.count(PatchKind::Triangle), rooms * (1888 * tt * tt + 404 * tt));
        EXPECT_EQ(s.count(PatchKind::Quad), rooms * 176);
        EXPECT_EQ(s.stats.inputFaces, s.patches.size());
        EXPECT_EQ(s.stats.droppedDegenerate, 0u);
        EXPECT_EQ(s.numEmitters(), rooms);
        EXPECT_NO_THROW(s.validate());
    }
    // Deterministic.
    EXPECT_EQ(sceneDigest(loadScene("office:1:2")), sceneDigest(loadScene("office:1:2")));
}

TEST(Builtin, OfficeTessellatedFurnitureIsClosedConnectedMeshes) {
    for (auto [n, t] : {std::pair{1, 1}, std::pair{2, 2}}) {
        Scene s = loadScene(fmt::format("office:{}:{}", n, t));
        SCOPED_TRACE(s.name);
        // Weld vertices by exact position: meshes share bit-identical corners.
        std::map<std::array<double, 3>, uint32_t> ids;
        std::vector<std::array<uint32_t, 3>> tris;
        for (const auto& p : s.patches) {
            if (p.kind != PatchKind::Triangle) continue;
            std::array<uint32_t, 3> t3{};
            for (int k = 0; k < 3; ++k) {
                const Vec3& v = p.v[size_t(k)];
                auto [it, fresh] = ids.try_emplace({v.x, v.y, v.z}, uint32_t(ids.size()));
                t3[size_t(k)] = it->second;
            }
            tris.push_back(t3);
        }
        // Closed, manifold and consistently oriented: every directed edge
        // appears exactly once and so does its reverse.
        std::map<std::pair<uint32_t, uint32_t>, int> directed;
        for (const auto& t3 : tris)
            for (int k = 0; k < 3; ++k) ++directed[{t3[size_t(k)], t3[size_t((k + 1) % 3)]}];
        size_t bad = 0;
        for (const auto& [e, c] : directed) {
            auto rev = directed.find({e.second, e.first});
            bad += c != 1 || rev == directed.end() || rev->second != 1;
        }
        EXPECT_EQ(bad, 0u);
        // Connected components through shared vertices (union-find).
        std::vector<uint32_t> parent(ids.size());
        std::iota(parent.begin(), parent.end(), 0u);
        auto find = [&](uint32_t x) {
            while (parent[x] != x) x = parent[x] = parent[parent[x]];
            return x;
        };
        for (const auto& t3 : tris) {
            parent[find(t3[1])] = find(t3[0]);
            parent[find(t3[2])] = find(t3[0]);
        }
        // Per component: Euler characteristic V - E + F = 2 (sphere topology)
        // and positive enclosed volume (outward normals).
        std::unordered_map<uint32_t, std::array<double, 4>> comp;  // V, E, F, volume*6
        for (uint32_t v = 0; v < parent.size(); ++v) comp[find(v)][0] += 1;
        for (const auto& t3 : tris) {
            auto& c = comp[find(t3[0])];
            c[1] += 1.5;
            c[2] += 1;
        }
        for (const auto& p : s.patches)
            if (p.kind == PatchKind::Triangle) {
                const Vec3 &a = p.v[0], &b = p.v[1], &c = p.v[2];
                comp[find(ids.at({a.x, a.y, a.z}))][3] += glm::dot(a, glm::cross(b, c));
            }
        EXPECT_EQ(comp.size(), size_t(n * n * kOfficeMeshesPerRoom));
        for (const auto& [root, c] : comp) {
            EXPECT_EQ(c[0] - c[1] + c[2], 2.0);
            EXPECT_GT(c[3] / 6.0, 1e-6);  // the smallest (a chair leg) is ~5e-4 m^3
        }
        // Rooms' furniture stays inside the room, above the floor.
        for (const auto& p : s.patches)
            for (int k = 0; k < p.numVertices(); ++k) {
                EXPECT_GT(p.v[size_t(k)].y, -1e-12);
                EXPECT_LT(p.v[size_t(k)].y, 3.0 + 1e-12);
            }
    }
}

TEST(Builtin, OfficeTessellationBadOptionsAreInputErrors) {
    auto message = [](const std::string& spec) -> std::string {
        try {
            loadScene(spec);
        } catch (const InputError& e) {
            return e.what();
        }
        return "no error";
    };
    for (const char* spec : {"office:2:0", "office:2:1.5", "office:2:x", "office:2:", "office:2:65",
                             "office:2:-1", "office:2:3:4", "office:64:64"}) {
        std::string m = message(spec);
        SCOPED_TRACE(spec);
        // FILE:LINE-style: the spec stands where a file name would.
        EXPECT_EQ(m.rfind(std::string(spec) + ": error: ", 0), 0u) << m;
    }
    EXPECT_NE(message("office:2:65").find("[1, 64]"), std::string::npos);
    EXPECT_NE(message("office:64:64").find("20000000"), std::string::npos);
}

TEST(Builtin, UnknownNameListsTheValidOnes) {
    EXPECT_TRUE(isBuiltinName("office:3"));
    EXPECT_FALSE(isBuiltinName("scene.obj"));
    try {
        makeBuiltin("nosuch");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("cornell"), std::string::npos);
    }
    EXPECT_THROW(loadScene("office:0"), InputError);
}

}  // namespace
}  // namespace hrad::scene
