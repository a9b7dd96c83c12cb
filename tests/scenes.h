// Small scenes built in code for tests (independent of the loaders).
#pragma once

#include <array>
#include <optional>

#include "scene/scene.h"
#include "scene/texture.h"

namespace hrad::test {

/// Adds a quad, flipping its vertex order if needed so that its normal points
/// towards `inside`.
inline void addQuadFacing(scene::Scene& s, Vec3 a, Vec3 b, Vec3 c, Vec3 d, uint32_t mat,
                          const Vec3& inside) {
    Vec3 n = glm::cross(b - a, c - a);
    Vec3 centre = 0.25 * (a + b + c + d);
    if (glm::dot(n, inside - centre) < 0) std::swap(b, d);
    s.addQuad(a, b, c, d, mat);
}

/// A unit floor quad (z = 0, facing +z, patch 0, material "floor" of rho 0.5)
/// under a black emitting unit square at z = 1 facing down (E = 1, patch 1).
/// Returns the floor's material.
inline uint32_t addFloorUnderLamp(scene::Scene& s) {
    const uint32_t floor = s.addMaterial({"floor", RGB(0.5), RGB(0.0)});
    const uint32_t lamp = s.addMaterial({"lamp", RGB(0.0), RGB(1.0)});
    s.addQuad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), floor);
    s.addQuad(Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), lamp);
    return floor;
}

/// addFloorUnderLamp's scene, its floor of reflectance `rho` with `tex` as
/// its texture (UV = (x, y)) when given.
inline scene::Scene floorUnderLamp(std::optional<scene::Texture> tex, double rho = 0.5) {
    scene::Scene s;
    s.name = "floor";
    const uint32_t floor = addFloorUnderLamp(s);
    s.materials[floor].rho = RGB(rho);
    s.patches[0].rho = RGB(rho);
    if (tex) {
        s.materials[floor].diffuseMap.texture = scene::addTexture(s, std::move(*tex));
        s.patches[0].uvs = 0;
        s.cornerUVs.push_back({glm::vec2(0, 0), {1, 0}, {1, 1}, {0, 1}});
        scene::applyTextureMeans(s);
    }
    return s;
}

/// 256 x 2 texels, clamped: 0 in the columns u < 1/2, `bright` in the
/// others (bilinear: 0 for u <= 0.5 - 1/512, `bright` for u >= 0.5 + 1/512).
inline scene::Texture halfBlackTexture(float bright) {
    scene::Texture t;
    t.file = "half";
    t.width = 256;
    t.height = 2;
    for (int j = 0; j < t.height; ++j)
        for (int i = 0; i < t.width; ++i)
            for (int c = 0; c < 3; ++c) t.texels.push_back(i < 128 ? 0.f : bright);
    t.wrapU = t.wrapV = scene::TextureWrap::Clamp;
    return t;
}

/// Adds the six faces of the axis-aligned box [lo, hi], facing inwards
/// (inward=true) or outwards. mats[i] is the material of face i in the order
/// -x, +x, -y, +y, -z, +z.
inline void addBox(scene::Scene& s, Vec3 lo, Vec3 hi, const std::array<uint32_t, 6>& mats,
                   bool inward) {
    Vec3 c = 0.5 * (lo + hi);
    auto P = [&](int x, int y, int z) {
        return Vec3(x ? hi.x : lo.x, y ? hi.y : lo.y, z ? hi.z : lo.z);
    };
    // For an outward face, aim the normal at a point beyond the face.
    auto target = [&](const Vec3& faceCentre) { return inward ? c : faceCentre + (faceCentre - c); };
    Vec3 f;
    f = Vec3(lo.x, c.y, c.z);
    addQuadFacing(s, P(0, 0, 0), P(0, 1, 0), P(0, 1, 1), P(0, 0, 1), mats[0], target(f));
    f = Vec3(hi.x, c.y, c.z);
    addQuadFacing(s, P(1, 0, 0), P(1, 1, 0), P(1, 1, 1), P(1, 0, 1), mats[1], target(f));
    f = Vec3(c.x, lo.y, c.z);
    addQuadFacing(s, P(0, 0, 0), P(1, 0, 0), P(1, 0, 1), P(0, 0, 1), mats[2], target(f));
    f = Vec3(c.x, hi.y, c.z);
    addQuadFacing(s, P(0, 1, 0), P(1, 1, 0), P(1, 1, 1), P(0, 1, 1), mats[3], target(f));
    f = Vec3(c.x, c.y, lo.z);
    addQuadFacing(s, P(0, 0, 0), P(1, 0, 0), P(1, 1, 0), P(0, 1, 0), mats[4], target(f));
    f = Vec3(c.x, c.y, hi.z);
    addQuadFacing(s, P(0, 0, 1), P(1, 0, 1), P(1, 1, 1), P(0, 1, 1), mats[5], target(f));
}

/// Closed unit box, every face with emission E and reflectance rho.
inline scene::Scene furnaceBox(double E = 1.0, double rho = 0.5) {
    scene::Scene s;
    s.name = "test-furnace";
    uint32_t m = s.addMaterial({"furnace", RGB(rho), RGB(E)});
    addBox(s, Vec3(0), Vec3(1), {m, m, m, m, m, m}, true);
    return s;
}

/// Closed box (2 x 1 x 1.5) with differently coloured walls, an emitting
/// ceiling tile and an interior block standing on the floor: a non-trivial
/// closed scene. The ceiling is tiled so the emitter is part of the closed
/// shell, and the block's footprint (x 0.5..1, y 0.25..0.75) lies on the
/// dyadic grid of the floor's quadtree, so elements need not straddle it.
inline scene::Scene closedRoom() {
    scene::Scene s;
    s.name = "test-room";
    uint32_t white = s.addMaterial({"white", RGB(0.7, 0.7, 0.7), RGB(0.0)});
    uint32_t red = s.addMaterial({"red", RGB(0.6, 0.1, 0.1), RGB(0.0)});
    uint32_t green = s.addMaterial({"green", RGB(0.15, 0.5, 0.1), RGB(0.0)});
    uint32_t light = s.addMaterial({"light", RGB(0.3), RGB(2.0, 1.8, 1.4)});
    uint32_t block = s.addMaterial({"block", RGB(0.5, 0.5, 0.3), RGB(0.0)});
    Vec3 lo(0), hi(2, 1, 1.5), c = 0.5 * (lo + hi);
    // Walls and floor (the ceiling is added as tiles below).
    scene::Scene shell;
    uint32_t mats[6] = {red, green, white, white, white, white};
    shell.materials = s.materials;
    addBox(shell, lo, hi, {mats[0], mats[1], mats[2], mats[3], mats[4], mats[5]}, true);
    for (int i = 0; i < 5; ++i) s.patches.push_back(shell.patches[i]);
    // Ceiling z = 1.5 as four tiles; tile (1..2, 0.5..1) emits.
    for (int tx = 0; tx < 2; ++tx)
        for (int ty = 0; ty < 2; ++ty) {
            double x0 = tx, y0 = 0.5 * ty;
            uint32_t m = (tx == 1 && ty == 1) ? light : white;
            addQuadFacing(s, Vec3(x0, y0, 1.5), Vec3(x0 + 1, y0, 1.5), Vec3(x0 + 1, y0 + 0.5, 1.5),
                          Vec3(x0, y0 + 0.5, 1.5), m, c);
        }
    addBox(s, Vec3(0.5, 0.25, 0.0), Vec3(1.0, 0.75, 0.75),
           {block, block, block, block, block, block}, false);
    return s;
}

}  // namespace hrad::test
