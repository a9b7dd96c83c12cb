// Texture times irradiance (see texturing.h).
#include "render/texturing.h"

#include <tbb/parallel_for.h>

#include "scene/texture.h"

namespace hrad::render {

TextureShading::TextureShading(const scene::Scene& scene) : scene_(&scene) {
    const size_t n = scene.patches.size();
    inverseMean_.assign(n, RGB(0.0));
    textured_.assign(n, 0);
    if (scene.textures.empty()) return;
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
        const scene::Patch& p = scene.patches[i];
        if (!scene::patchTexture(scene, p)) return;
        const RGB m = scene::patchTextureMean(scene, p);
        for (int c = 0; c < 3; ++c) inverseMean_[i][c] = m[c] > 0 ? 1.0 / m[c] : 0.0;
        textured_[i] = 1;
    });
    for (uint8_t t : textured_) any_ = any_ || t;
}

RGB TextureShading::ratio(uint32_t patch, double u, double v) const {
    if (!textured_[patch]) return RGB(1.0);
    const scene::Patch& p = scene_->patches[patch];
    return scene::textureRho(*scene_, p, u, v) * inverseMean_[patch];
}

RGB TextureShading::shade(uint32_t patch, double u, double v, const RGB& B) const {
    if (!textured_[patch]) return B;
    const RGB& E = scene_->patches[patch].emission;
    return E + (B - E) * ratio(patch, u, v);
}

}  // namespace hrad::render
