// Lightmap atlas: packing, baking and the glTF output (see lightmap.h).
#include "render/lightmap.h"

#include <optional>
#include <stb/stb_rect_pack.h>
#include <tbb/parallel_for.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "core/error.h"
#include "render/gltf_model.h"
#include "render/texturing.h"
#include "scene/element.h"
#include "scene/texture.h"

namespace hrad::render {

using scene::PatchKind;

LightmapSettings LightmapSettings::fromParams(const Params& params, const std::string& prefix) {
    auto key = [&](const char* k) { return prefix.empty() ? std::string(k) : prefix + "." + k; };
    LightmapSettings s;
    s.size = int(params.getInt(
        {key("lightmap_size"), "lightmap atlas width = height in texels (--lightmap RES)"}, s.size,
        16, 16384));
    s.density = params.getDouble(
        {key("lightmap_density"),
         "lightmap texels per scene unit (metre); 0: the largest that fits the atlas"},
        s.density, 0.0, 1e9);
    s.gutter = int(params.getInt(
        {key("lightmap_gutter"), "lightmap texels around each chart (against bleeding)"}, s.gutter,
        0, 64));
    s.texels = params.getEnum({key("lightmap_texels"),
                               "lightmap texels of textured patches: radiosity (E + texel x "
                               "irradiance) or irradiance (for a base texture multiplied later)"},
                              "radiosity", {"radiosity", "irradiance"}) == "irradiance"
                   ? Texels::Irradiance
                   : Texels::Radiosity;
    s.textures = params.getEnum({key("textures"), kTexturesDoc}, "on", {"on", "off"}) == "on";
    s.filter = params.getEnum({key("texture_filter"), kTextureFilterDoc}, "mip", {"bilinear", "mip"}) == "mip"
                   ? TextureFilter::Mip
                   : TextureFilter::Bilinear;
    return s;
}

namespace {

/// Chart sizes at density d (domain texels, gutters not included).
std::vector<Lightmap::Chart> chartSizes(const scene::Scene& sc, double d) {
    std::vector<Lightmap::Chart> c(sc.patches.size());
    for (size_t p = 0; p < c.size(); ++p) {
        const scene::Patch& pa = sc.patches[p];
        const Vec3 side = pa.kind == PatchKind::Quad ? pa.v[3] : pa.v[2];
        auto texels = [&](double len) {
            return int(std::clamp(std::ceil(len * d), 1.0, 16384.0));
        };
        c[p].w = texels(glm::length(pa.v[1] - pa.v[0]));
        c[p].h = texels(glm::length(side - pa.v[0]));
    }
    return c;
}

/// Packs the charts into size x size; false when some do not fit.
bool pack(std::vector<Lightmap::Chart>& charts, int size, int gutter) {
    std::vector<stbrp_rect> rects(charts.size());
    for (size_t i = 0; i < charts.size(); ++i) {
        rects[i].id = int(i);
        rects[i].w = charts[i].w + 2 * gutter;
        rects[i].h = charts[i].h + 2 * gutter;
        if (rects[i].w > size || rects[i].h > size) return false;
    }
    std::vector<stbrp_node> nodes(static_cast<size_t>(size));
    stbrp_context ctx;
    stbrp_init_target(&ctx, size, size, nodes.data(), int(nodes.size()));
    if (!stbrp_pack_rects(&ctx, rects.data(), int(rects.size()))) return false;
    for (const stbrp_rect& r : rects) {
        charts[size_t(r.id)].x = r.x + gutter;
        charts[size_t(r.id)].y = r.y + gutter;
    }
    return true;
}

/// Phase 1: the charts' layout (density fixed or bisected).
void layout(const scene::Scene& sc, const LightmapSettings& s, Lightmap& lm) {
    lm.gutter = s.gutter;
    lm.size = s.size;
    if (s.density > 0) {
        lm.density = s.density;
        for (;;) {
            lm.charts = chartSizes(sc, s.density);
            if (pack(lm.charts, lm.size, s.gutter)) return;
            if (lm.size >= 16384)
                throwInputError({"render.lightmap_density", 0, 0},
                                "{} texels per unit need an atlas over 16384 x 16384; lower "
                                "render.lightmap_density",
                                s.density);
            lm.size *= 2;
        }
    }
    double area = 0.0;
    for (const scene::Patch& p : sc.patches) area += p.area;
    double lo = 0.0, hi = double(s.size) / std::sqrt(std::max(area, 1e-300));
    std::vector<Lightmap::Chart> best = chartSizes(sc, 0.0);
    if (!pack(best, s.size, s.gutter))
        throwInputError({"render.lightmap_size", 0, 0},
                        "{} charts of one texel and {} gutter texels do not fit {} x {}; raise "
                        "the lightmap size (--lightmap RES) or lower render.lightmap_gutter",
                        sc.patches.size(), s.gutter, s.size, s.size);
    for (int it = 0; it < 24; ++it) {
        double mid = 0.5 * (lo + hi);
        std::vector<Lightmap::Chart> c = chartSizes(sc, mid);
        if (pack(c, s.size, s.gutter)) {
            lo = mid;
            best = std::move(c);
        } else {
            hi = mid;
        }
    }
    lm.density = lo;
    lm.charts = std::move(best);
}

}  // namespace

Vec2 Lightmap::uv(uint32_t patch, double u, double v) const {
    const Chart& c = charts[patch];
    return {(c.x + u * c.w) / size, (c.y + v * c.h) / size};
}

RGB Lightmap::sample(const Vec2& t) const {
    double x = t.x * size - 0.5, y = t.y * size - 0.5;
    int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    double fx = x - x0, fy = y - y0;
    auto px = [&](int i, int j) {
        return atlas.at(std::clamp(i, 0, size - 1), std::clamp(j, 0, size - 1));
    };
    return (1 - fx) * (1 - fy) * px(x0, y0) + fx * (1 - fy) * px(x0 + 1, y0) +
           (1 - fx) * fy * px(x0, y0 + 1) + fx * fy * px(x0 + 1, y0 + 1);
}

double Lightmap::fill() const {
    double used = 0.0;
    for (const Chart& c : charts) used += double(c.w) * c.h;
    return used / (double(size) * size);
}

Lightmap bakeLightmap(const scene::RadiosityField& field, const LightmapSettings& settings,
                      const VertexInterpolation* smooth) {
    const scene::Scene& sc = field.scene();
    Lightmap lm;
    layout(sc, settings, lm);
    // Phase 2: every chart's texels, gutters included, from the clamped domain.
    lm.atlas = Image(lm.size, lm.size);
    const int g = lm.gutter;
    std::optional<TextureShading> shading;
    if (settings.textures && !sc.textures.empty()) shading.emplace(sc, settings.filter);
    const bool irradiance = settings.texels == LightmapSettings::Texels::Irradiance;
    // Leaves with their own reflectance (render/texturing.h): texels from H,
    // smoothed as H (a `smooth` built without them is rebuilt with them).
    std::optional<LeafReflectance> leafRho;
    std::unique_ptr<VertexInterpolation> ownSmooth;
    if (shading && field.leafTextureRho()) {
        leafRho.emplace(field);
        if (!leafRho->any()) leafRho.reset();
    }
    if (smooth && smooth->interpolatesIrradiance() != bool(leafRho)) {
        ownSmooth = std::make_unique<VertexInterpolation>(field, smooth->settings(),
                                                          leafRho ? &*leafRho : nullptr);
        smooth = ownSmooth.get();
    }
    tbb::parallel_for(size_t(0), sc.patches.size(), [&](size_t p) {
        const Lightmap::Chart& c = lm.charts[p];
        const scene::Patch& patch = sc.patches[p];
        const bool textured = shading && scene::patchTexture(sc, patch);
        const bool ownRho = leafRho && leafRho->covers(uint32_t(p));
        // One atlas texel's footprint in the patch's (u, v): the texture is
        // filtered over it (render.texture_filter = mip; texturing.h).
        ParamFootprint texelStep;
        texelStep.dx = Vec2(1.0 / c.w, 0.0);
        texelStep.dy = Vec2(0.0, 1.0 / c.h);
        for (int j = -g; j < c.h + g; ++j)
            for (int i = -g; i < c.w + g; ++i) {
                Vec2 uv = scene::clampToPatchDomain(patch.kind, Vec2((i + 0.5) / c.w, (j + 0.5) / c.h));
                if (ownRho) {
                    const RGB H = smooth ? smooth->at(uint32_t(p), uv.x, uv.y)
                                         : leafRho->irradianceAt(uint32_t(p), uv.x, uv.y);
                    lm.atlas.at(c.x + i, c.y + j) =
                        irradiance ? H : shading->shadeIrradiance(uint32_t(p), uv.x, uv.y, H, &texelStep);
                    continue;
                }
                RGB B = smooth ? smooth->at(uint32_t(p), uv.x, uv.y) : field.at(uint32_t(p), uv.x, uv.y);
                if (textured && irradiance) {
                    // H = (B - E) / rho_bar per channel (0 where rho_bar is 0).
                    const RGB rho = patch.rho;
                    for (int k = 0; k < 3; ++k) B[k] = rho[k] > 0 ? (B[k] - patch.emission[k]) / rho[k] : 0.0;
                } else if (textured) {
                    B = shading->shade(uint32_t(p), uv.x, uv.y, B, &texelStep);
                }
                lm.atlas.at(c.x + i, c.y + j) = B;
            }
    });
    return lm;
}

namespace {

using gltf::putLE;

/// A buffer view over the bytes appended to buffer 0, and (type >= 0) an
/// accessor over it; returns the accessor (or the view when type < 0).
int addView(tinygltf::Model& m, const std::vector<unsigned char>& bytes, int target, int componentType = -1,
            int type = -1, size_t count = 0) {
    auto& data = m.buffers[0].data;
    while (data.size() % 4) data.push_back(0);  // accessors are 4-byte aligned
    tinygltf::BufferView bv;
    bv.buffer = 0;
    bv.byteOffset = data.size();
    bv.byteLength = bytes.size();
    bv.target = target;
    data.insert(data.end(), bytes.begin(), bytes.end());
    m.bufferViews.push_back(bv);
    if (type < 0) return int(m.bufferViews.size()) - 1;
    tinygltf::Accessor a;
    a.bufferView = int(m.bufferViews.size()) - 1;
    a.componentType = componentType;
    a.type = type;
    a.count = count;
    m.accessors.push_back(a);
    return int(m.accessors.size()) - 1;
}

/// Phase 1 of the glb: one mesh of the root patches (own corners each).
tinygltf::Primitive lightmapMesh(tinygltf::Model& m, const scene::Scene& sc, const Lightmap& lm) {
    std::vector<unsigned char> pos, uv0, uv1, idx;
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    uint32_t base = 0;
    for (uint32_t p = 0; p < sc.patches.size(); ++p) {
        const scene::Patch& pa = sc.patches[p];
        const int n = pa.numVertices();
        for (int i = 0; i < n; ++i) {
            glm::vec3 f(pa.v[size_t(i)]);
            lo = glm::min(lo, glm::dvec3(f));
            hi = glm::max(hi, glm::dvec3(f));
            for (int k = 0; k < 3; ++k) putLE(pos, f[k]);
            Vec2 a = scene::cornerLocal(pa.kind, i), t = lm.uv(p, a.x, a.y);
            putLE(uv0, float(a.x));
            putLE(uv0, float(a.y));
            putLE(uv1, float(t.x));
            putLE(uv1, float(t.y));
        }
        for (uint32_t i : {0u, 1u, 2u}) putLE(idx, base + i);
        if (n == 4)
            for (uint32_t i : {0u, 2u, 3u}) putLE(idx, base + i);
        base += uint32_t(n);
    }
    const size_t nv = base;
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = 0;
    prim.attributes["POSITION"] = addView(m, pos, TINYGLTF_TARGET_ARRAY_BUFFER,
                                          TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
    if (nv > 0) {
        m.accessors.back().minValues = {lo.x, lo.y, lo.z};
        m.accessors.back().maxValues = {hi.x, hi.y, hi.z};
    }
    prim.attributes["TEXCOORD_0"] = addView(m, uv0, TINYGLTF_TARGET_ARRAY_BUFFER,
                                            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
    prim.attributes["TEXCOORD_1"] = addView(m, uv1, TINYGLTF_TARGET_ARRAY_BUFFER,
                                            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
    prim.indices = addView(m, idx, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER,
                           TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, idx.size() / 4);
    return prim;
}

}  // namespace

void writeLightmapGlb(const scene::RadiosityField& field, const Lightmap& lm, const ToneMap& tone,
                      const std::string& path) {
    const scene::Scene& sc = field.scene();
    tinygltf::Model m;
    m.asset.version = "2.0";
    m.asset.generator = "hrad";
    tinygltf::Value::Object extras;
    extras["scene"] = tinygltf::Value(sc.name);
    extras["lightmap"] = tinygltf::Value(std::string(
        "baseColorTexture (TEXCOORD_1) = the lightmap atlas, tone mapped as image.png "
        "(tone_curve(exposure * B), sRGB); lightmap.exr holds the linear B"));
    extras["exposure"] = tinygltf::Value(tone.exposure);
    extras["tone_curve"] = tinygltf::Value(tone.curveName());
    extras["atlas_size"] = tinygltf::Value(lm.size);
    extras["texels_per_unit"] = tinygltf::Value(lm.density);
    m.asset.extras = tinygltf::Value(extras);
    m.extensionsUsed.push_back("KHR_materials_unlit");
    m.buffers.emplace_back();

    tinygltf::Mesh mesh;
    mesh.name = "root patches (lightmapped)";
    mesh.primitives.push_back(lightmapMesh(m, sc, lm));
    m.meshes.push_back(mesh);

    // Phase 2: the atlas as an embedded PNG, read linearly and clamped.
    tinygltf::Image image;
    image.name = "lightmap";
    image.mimeType = "image/png";
    image.bufferView = addView(m, encodePng(lm.atlas, tone), -1);
    m.images.push_back(image);
    tinygltf::Sampler sampler;
    sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
    sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
    sampler.wrapS = sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    m.samplers.push_back(sampler);
    tinygltf::Texture tex;
    tex.source = 0;
    tex.sampler = 0;
    m.textures.push_back(tex);
    tinygltf::Material mat;
    mat.name = "hrad lightmap (unlit)";
    mat.pbrMetallicRoughness.baseColorTexture.index = 0;
    mat.pbrMetallicRoughness.baseColorTexture.texCoord = 1;
    mat.pbrMetallicRoughness.metallicFactor = 0.0;
    mat.pbrMetallicRoughness.roughnessFactor = 1.0;
    mat.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
    m.materials.push_back(mat);

    // Phase 3: nodes (the scene's up axis -> +Y, as render/gltf_export.cpp).
    tinygltf::Node root = gltf::yUpRoot(sc);
    root.children.push_back(1);
    tinygltf::Node meshNode;
    meshNode.name = "lightmapped";
    meshNode.mesh = 0;
    m.nodes.push_back(root);
    m.nodes.push_back(meshNode);
    tinygltf::Scene scene;
    scene.name = sc.name;
    scene.nodes.push_back(0);
    m.scenes.push_back(scene);
    m.defaultScene = 0;

    gltf::writeGlbModel(m, path);
}

Lightmap writeLightmapFiles(const scene::RadiosityField& field, const LightmapSettings& settings,
                            const VertexInterpolation* smooth, const ToneMap& tone,
                            const std::string& dir) {
    Lightmap lm = bakeLightmap(field, settings, smooth);
    writeExr(lm.atlas, dir + "/lightmap.exr");
    writePng(lm.atlas, dir + "/lightmap.png", tone);
    if (settings.texels == LightmapSettings::Texels::Irradiance && settings.textures &&
        !field.scene().textures.empty()) {
        // The glb shows radiosity (texture x irradiance baked per texel).
        LightmapSettings shown = settings;
        shown.texels = LightmapSettings::Texels::Radiosity;
        writeLightmapGlb(field, bakeLightmap(field, shown, smooth), tone, dir + "/lightmap.glb");
    } else {
        writeLightmapGlb(field, lm, tone, dir + "/lightmap.glb");
    }
    return lm;
}

}  // namespace hrad::render
