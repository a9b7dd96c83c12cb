// Texture times irradiance (see texturing.h).
#include "render/texturing.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/error.h"
#include "scene/element.h"

namespace hrad::render {

using scene::ElementKey;

namespace {

int wrapped(int i, int n, scene::TextureWrap mode) {
    switch (mode) {
        case scene::TextureWrap::Clamp: return std::clamp(i, 0, n - 1);
        case scene::TextureWrap::Mirror: {
            const int m = ((i % (2 * n)) + 2 * n) % (2 * n);
            return m < n ? m : 2 * n - 1 - m;
        }
        case scene::TextureWrap::Repeat: break;
    }
    return ((i % n) + n) % n;
}

/// The next mip level: each texel the mean of its 2 x 2 block of `fine`.
scene::Texture halve(const scene::Texture& fine) {
    scene::Texture c;
    c.file = fine.file;
    c.wrapU = fine.wrapU;
    c.wrapV = fine.wrapV;
    c.width = (fine.width + 1) / 2;
    c.height = (fine.height + 1) / 2;
    c.texels.assign(size_t(c.width) * size_t(c.height) * 3, 0.0f);
    auto at = [&](int x, int y, int ch) {
        x = wrapped(x, fine.width, fine.wrapU);
        y = wrapped(y, fine.height, fine.wrapV);
        return double(fine.texels[(size_t(y) * size_t(fine.width) + size_t(x)) * 3 + size_t(ch)]);
    };
    // An axis of one texel is not halved: its block is that texel twice.
    const int sx = fine.width > 1 ? 1 : 0, sy = fine.height > 1 ? 1 : 0;
    for (int y = 0; y < c.height; ++y)
        for (int x = 0; x < c.width; ++x)
            for (int ch = 0; ch < 3; ++ch) {
                const int x0 = 2 * x, y0 = 2 * y;
                const double m = 0.25 * (at(x0, y0, ch) + at(x0 + sx, y0, ch) + at(x0, y0 + sy, ch) +
                                         at(x0 + sx, y0 + sy, ch));
                c.texels[(size_t(y) * size_t(c.width) + size_t(x)) * 3 + size_t(ch)] = float(m);
            }
    return c;
}

/// The point where the ray eye + t d meets the plane of p (nullopt: parallel or behind).
std::optional<Vec3> onPlane(const scene::Patch& p, const Vec3& eye, const Vec3& d) {
    const double den = glm::dot(d, p.normal);
    if (!(std::fabs(den) > 1e-12)) return std::nullopt;
    const double t = glm::dot(p.v[0] - eye, p.normal) / den;
    if (!(t > 0)) return std::nullopt;
    return eye + t * d;
}

}  // namespace

MipChain::MipChain(const scene::Texture& base) : base_(&base) {
    const scene::Texture* fine = &base;
    while (fine->width > 1 || fine->height > 1) {
        coarser_.push_back(halve(*fine));
        fine = &coarser_.back();
    }
}

RGB MipChain::lookup(double s, double t, double width) const {
    // Level k's texels are 2^k level-0 texels wide: level = log2(width).
    const double lambda = width > 1 ? std::log2(width) : 0.0;
    const double top = double(numLevels() - 1);
    if (!(lambda < top)) return level(numLevels() - 1).lookup(s, t);
    const size_t k = size_t(lambda);
    const double f = lambda - double(k);
    const RGB a = level(k).lookup(s, t);
    return f > 0 ? (1 - f) * a + f * level(k + 1).lookup(s, t) : a;
}

RGB MipChain::filtered(const Vec2& st, const Vec2& sx, const Vec2& sy) const {
    const double lx = glm::length(sx), ly = glm::length(sy);
    const double major = std::max(lx, ly), minor = std::min(lx, ly);
    if (!std::isfinite(major)) return level(numLevels() - 1).lookup(st.x, st.y);
    if (major <= 1) return base_->lookup(st.x, st.y);  // magnified: bilinear
    // Probes along the major axis, each filtering a minor-axis-wide square.
    const int probes = int(std::min(double(kMaxProbes), std::ceil(major / std::max(minor, 1e-300))));
    const double width = std::max(minor, major / kMaxProbes) / std::sqrt(3.0);
    const Vec2 axis = (lx >= ly ? sx : sy) / Vec2(base_->width, base_->height);
    RGB sum(0.0);
    for (int k = 0; k < probes; ++k) {
        const double o = (k + 0.5) / probes - 0.5;
        sum += lookup(st.x + o * axis.x, st.y + o * axis.y, width);
    }
    return sum / double(probes);
}

ParamFootprint footprintOnPatch(const scene::Patch& p, const Vec3& eye, const Vec3& dirX,
                                const Vec3& dirY, const Vec2& uv) {
    ParamFootprint fp;
    const auto x = onPlane(p, eye, dirX), y = onPlane(p, eye, dirY);
    fp.dx = x ? scene::patchInverse(p, *x) - uv : Vec2(1e30);
    fp.dy = y ? scene::patchInverse(p, *y) - uv : Vec2(1e30);
    return fp;
}

TextureShading::TextureShading(const scene::Scene& scene, TextureFilter filter)
    : scene_(&scene), filter_(filter) {
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
    if (filter_ != TextureFilter::Mip || !any_) return;
    mips_.resize(scene.textures.size());
    tbb::parallel_for(size_t(0), mips_.size(), [&](size_t i) {
        if (scene.textures[i]) mips_[i] = std::make_unique<MipChain>(*scene.textures[i]);
    });
}

RGB TextureShading::ratio(uint32_t patch, double u, double v, const ParamFootprint* fp) const {
    if (!textured_[patch]) return RGB(1.0);
    return texel(patch, u, v, fp) * inverseMean_[patch];
}

RGB TextureShading::texel(uint32_t patch, double u, double v, const ParamFootprint* fp) const {
    const scene::Patch& p = scene_->patches[patch];
    if (!fp || filter_ != TextureFilter::Mip) return scene::textureRho(*scene_, p, u, v);
    const scene::TextureBinding& b = *scene::patchTexture(*scene_, p);
    const MipChain& mip = *mips_[size_t(b.texture)];
    const auto& corners = scene_->cornerUVs[p.uvs];
    const Vec2 st = scene::uvAt(p, corners, u, v);
    // The footprint's two steps through the UV map, in level-0 texels.
    const Vec2 texels(mip.level(0).width, mip.level(0).height);
    const Vec2 sx = (scene::uvAt(p, corners, u + fp->dx.x, v + fp->dx.y) - st) * texels;
    const Vec2 sy = (scene::uvAt(p, corners, u + fp->dy.x, v + fp->dy.y) - st) * texels;
    return b.scale * mip.filtered(st, sx, sy);
}

RGB TextureShading::shade(uint32_t patch, double u, double v, const RGB& B,
                          const ParamFootprint* fp) const {
    if (!textured_[patch]) return B;
    const RGB& E = scene_->patches[patch].emission;
    return E + (B - E) * ratio(patch, u, v, fp);
}

RGB TextureShading::shadeIrradiance(uint32_t patch, double u, double v, const RGB& H,
                                    const ParamFootprint* fp) const {
    const scene::Patch& p = scene_->patches[patch];
    if (!textured_[patch]) return p.emission + p.rho * H;
    return p.emission + H * (ratio(patch, u, v, fp) * p.rho);
}

LeafReflectance::LeafReflectance(const scene::RadiosityField& field) : field_(&field) {
    const scene::Scene& sc = field.scene();
    if (!field.leafTextureRho() || sc.textures.empty()) return;
    rho_.resize(sc.patches.size());
    tbb::parallel_for(size_t(0), sc.patches.size(), [&](size_t i) {
        const scene::Patch& p = sc.patches[i];
        if (!scene::patchTexture(sc, p)) return;
        auto& m = rho_[i];
        field.forEachLeaf(uint32_t(i), [&](ElementKey k, const RGB&) {
            // The root keeps the patch's (clamped) mean, as hr/element_rho.h.
            m.emplace(k, k == scene::kRootKey ? p.rho
                                              : scene::elementRho(sc, p, scene::keyDomain(p.kind, k)));
        });
    });
    for (const auto& m : rho_) any_ = any_ || !m.empty();
}

const RGB& LeafReflectance::rho(uint32_t patch, ElementKey key) const {
    auto it = rho_[patch].find(key);
    HRAD_CHECK_MSG(it != rho_[patch].end(), "key {} is not a leaf of patch {}", key, patch);
    return it->second;
}

ElementKey LeafReflectance::leafAt(uint32_t patch, double u, double v) const {
    const scene::PatchKind kind = field_->scene().patches[patch].kind;
    const auto& m = rho_[patch];
    ElementKey key = scene::kRootKey;
    scene::Domain dom;
    for (int level = 0; level < scene::kMaxLevel && !m.count(key); ++level) {
        const int c = scene::childContaining(kind, dom, u, v);
        dom = scene::childDomain(kind, dom, c);
        key = scene::childKey(key, c);
    }
    return key;
}

RGB LeafReflectance::irradianceAt(uint32_t patch, double u, double v) const {
    const RGB B = field_->at(patch, u, v);
    const RGB& E = field_->scene().patches[patch].emission;
    const auto it = rho_[patch].find(leafAt(patch, u, v));
    if (it == rho_[patch].end()) return RGB(0.0);
    RGB H(0.0);
    for (int c = 0; c < 3; ++c) H[c] = it->second[c] > 0 ? (B[c] - E[c]) / it->second[c] : 0.0;
    return H;
}

}  // namespace hrad::render
