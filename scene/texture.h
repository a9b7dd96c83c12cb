// Diffuse textures: decoded once per scene (Scene::textures), UVs per patch
// corner (Scene::cornerUVs, Patch::uvs), and the texture's mean per root patch.
//
// A texture stores linear RGB texels (float, image row 0 at the top). UVs are
// kept in the OBJ/OpenGL convention, v up: texel row = (1 - v) * height (glTF's
// v points down; its loader stores 1 - v). Lookups are bilinear between texel
// centres with the texture's wrap mode per axis (glTF sampler wrapS/wrapT:
// REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT, §3.8.4; OBJ and Mitsuba repeat).
// Decoding: 8/16-bit images are sRGB-decoded per texel (IEC 61966-2-1) unless
// the format says they are linear (Mitsuba bitmap `raw`), HDR and OpenEXR are
// linear as stored; alpha is ignored.
//
// Reflectance where a material has a texture: rho(x) = scale * texel(uv(x)),
// scale = OBJ Kd (the MTL spec: map_Kd is multiplied by Kd), glTF
// baseColorFactor, 1 for Mitsuba. The solve uses per root patch the mean of
// rho(x) over the patch by area (patchTextureMean), clamped like the loader's
// other reflectances: a k x k grid of cells in the patch's domain (k about
// two per texel of the UV footprint, 4..64), each contributing the exact
// mean of the texels, taken as the squares they cover, over its UV box
// (Texture::boxMean, a summed-area table: Crow 1984), so a footprint of
// thousands of texels per cell is box-filtered, not point-sampled (the old
// point grid aliased by some 30 %: papers/notes/2026-12-02-textures.md,
// 2026-12-04). Exact where the UV map is axis-aligned (quads; triangles up
// to their k hypotenuse cells); the bilinear picture's own mean differs
// within half a texel of a patch's UV border. The table costs 24 bytes per
// texel (RGB doubles) besides the 12 of the texels. With
// hr.texture_rho = element the hierarchy gives each sub-element the same
// quadrature over its own domain (elementTextureMean, elementRho;
// hr/element_rho.h); the default keeps the patch mean
// (papers/notes/2026-12-02-textures.md). The renderer shows rho(x) H(x)
// (render/texturing.h).
//
// Memory: decoded texels count against texture.max_mb (12 bytes per texel),
// checked from the image's header before it is decoded.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/types.h"
#include "scene/element.h"
#include "scene/scene.h"

namespace hrad::scene {


enum class TextureWrap : uint8_t { Repeat, Clamp, Mirror };

struct Texture {
    std::string file;  ///< where it came from (file, or file + "#image N"), for messages
    int width = 0, height = 0;
    std::vector<float> texels;  ///< linear RGB, row-major, row 0 at the top (v = 1)
    TextureWrap wrapU = TextureWrap::Repeat, wrapV = TextureWrap::Repeat;
    RGB mean{0.0};  ///< mean over all texels
    /// Summed-area table of the texels (Crow 1984): (width + 1) x (height + 1)
    /// prefix sums in double, row-major; built by addTexture (boxMean).
    std::shared_ptr<const std::vector<RGB>> sums;

    /// Bilinear lookup at (u, v), v up (see above).
    RGB lookup(double u, double v) const;
    /// Exact mean of the texels as little squares (texel i covers texel
    /// coordinates [i, i + 1)) over the box [x0, x1] x [y0, y1] in texel
    /// coordinates (x = u width, y = (1 - v) height), with the wrap modes;
    /// a box of zero extent on an axis takes the texel it lies in. Requires
    /// `sums` (addTexture).
    RGB boxMean(double x0, double x1, double y0, double y1) const;
    uint64_t bytes() const { return uint64_t(texels.size()) * sizeof(float); }
};

/// The budget of decoded texels (texture.max_mb), shared by a scene's loads.
struct TextureBudget {
    uint64_t maxBytes = uint64_t(2048) << 20;
    uint64_t used = 0;
    /// Throws InputError at `where` naming texture.max_mb when a texture of
    /// width x height would pass the budget; else books it.
    void reserve(int64_t width, int64_t height, const SourceLocation& where);
};

enum class TextureEncoding { Srgb, Linear };

/// Decodes an image file (PNG, JPEG, BMP, TGA, HDR, ... through stb_image;
/// .exr through OpenEXR). Returns nullopt and `why` when it is missing or
/// cannot be decoded (the caller warns and falls back); throws when the budget
/// is exceeded (checked from the header first).
std::optional<Texture> decodeTextureFile(const std::string& file, TextureEncoding enc,
                                         TextureBudget& budget, const SourceLocation& where,
                                         std::string& why);
/// A texture from decoded 8- or 16-bit texels (tinygltf's image) with 1..4
/// components; the budget is the caller's (checked before decoding).
Texture textureFromPixels(const std::string& name, int width, int height, int components,
                          int bits, const unsigned char* data, TextureEncoding enc);

/// Adds a texture to the scene's table, with its summed-area table; returns its index.
int32_t addTexture(Scene& scene, Texture t);

/// Corner UVs of patch p (nullptr when it has none).
const std::array<glm::vec2, 4>* patchUVs(const Scene& scene, const Patch& p);
/// UV at the patch's parametric (u, v) (scene/scene.h Patch::point).
Vec2 uvAt(const Patch& p, const std::array<glm::vec2, 4>& uv, double u, double v);
/// The texture binding of patch p when it has UVs and a decoded texture.
const TextureBinding* patchTexture(const Scene& scene, const Patch& p);
/// scale * texel at the patch's parametric (u, v); requires patchTexture.
RGB textureRho(const Scene& scene, const Patch& p, double u, double v);
/// Area mean of scale * texel over the patch (not clamped).
RGB patchTextureMean(const Scene& scene, const Patch& p);
/// Area mean of scale * texel over the element of domain d (scene/element.h),
/// by the same quadrature as the patch mean (which is the root domain's);
/// not clamped. Requires patchTexture.
RGB elementTextureMean(const Scene& scene, const Patch& p, const Domain& d);
/// elementTextureMean clamped as the loader clamps patch means: a channel
/// >= 1 becomes the binding's clampRho (the patch's rho where that is 0).
/// The reflectance hr.texture_rho = element gives a sub-element.
RGB elementRho(const Scene& scene, const Patch& p, const Domain& d);
/// Sets every textured patch's rho to its clamped patchTextureMean; returns
/// the number of textured patches. Throws InputError for a mean >= 1 whose
/// binding clamps with 0.
size_t applyTextureMeans(Scene& scene);

}  // namespace hrad::scene
