// Diffuse textures (see texture.h).
#include "scene/texture.h"

#include <fmt/format.h>
#include <stb/stb_image.h>

#include <ImfArray.h>
#include <ImfRgbaFile.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "scene/element.h"

namespace hrad::scene {

namespace {

constexpr uint64_t kBytesPerTexel = 3 * sizeof(float);

/// sRGB transfer function inverse (IEC 61966-2-1).
double srgbToLinear(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

int wrapIndex(int i, int n, TextureWrap mode) {
    switch (mode) {
        case TextureWrap::Clamp: return std::clamp(i, 0, n - 1);
        case TextureWrap::Mirror: {
            int m = ((i % (2 * n)) + 2 * n) % (2 * n);
            return m < n ? m : 2 * n - 1 - m;
        }
        case TextureWrap::Repeat: break;
    }
    return ((i % n) + n) % n;
}

/// Prefix sums S(j, i) = sum of the texels of rows < j and columns < i.
std::vector<RGB> summedArea(const Texture& t) {
    const size_t w = size_t(t.width), h = size_t(t.height);
    std::vector<RGB> s((w + 1) * (h + 1), RGB(0.0));
    for (size_t j = 0; j < h; ++j) {
        RGB row(0.0);
        for (size_t i = 0; i < w; ++i) {
            const float* p = &t.texels[(j * w + i) * 3];
            row += RGB(p[0], p[1], p[2]);
            s[(j + 1) * (w + 1) + i + 1] = s[j * (w + 1) + i + 1] + row;
        }
    }
    return s;
}

/// Texel indices [a, b) of one axis, taken `times` times.
struct Run {
    int a = 0, b = 0;
    double times = 0;
};

int64_t floorDiv(int64_t a, int64_t n) { return a >= 0 ? a / n : -((-a + n - 1) / n); }

/// The lattice indices [m0, m1) (m0 < m1) of an axis of n texels as runs of
/// texels under the wrap mode (lookup's wrapIndex for every index): repeat
/// and mirror split into a head, whole periods and a tail (mirror's periods
/// are 2n long, each half a run), clamp into the first texel, the inside and
/// the last texel. At most 6 runs.
int wrapRuns(int64_t m0, int64_t m1, int n, TextureWrap mode, Run out[6]) {
    int k = 0;
    if (mode == TextureWrap::Clamp) {
        if (m0 < 0) out[k++] = {0, 1, double(std::min<int64_t>(m1, 0) - m0)};
        if (std::max<int64_t>(m0, 0) < std::min<int64_t>(m1, n))
            out[k++] = {int(std::max<int64_t>(m0, 0)), int(std::min<int64_t>(m1, n)), 1.0};
        if (m1 > n) out[k++] = {n - 1, n, double(m1 - std::max<int64_t>(m0, n))};
        return k;
    }
    const int64_t period = mode == TextureWrap::Mirror ? 2 * int64_t(n) : n;
    const int64_t q0 = floorDiv(m0, period), q1 = floorDiv(m1 - 1, period);
    const int64_t r0 = m0 - q0 * period, r1 = m1 - q1 * period;  // r1 in [1, period]
    Run pos[3];  // runs of positions within one period
    int np = 0;
    if (q0 == q1) {
        pos[np++] = {int(r0), int(r1), 1.0};
    } else {
        pos[np++] = {int(r0), int(period), 1.0};
        if (q1 - q0 > 1) pos[np++] = {0, int(period), double(q1 - q0 - 1)};
        pos[np++] = {0, int(r1), 1.0};
    }
    for (int i = 0; i < np; ++i) {
        if (mode == TextureWrap::Repeat) {
            out[k++] = pos[i];
            continue;
        }
        // Mirror: position p < n is texel p, p >= n texel 2n - 1 - p.
        const Run& r = pos[i];
        if (r.a < n) out[k++] = {r.a, std::min(r.b, n), r.times};
        if (r.b > n) out[k++] = {2 * n - r.b, 2 * n - std::max(r.a, n), r.times};
    }
    return k;
}

/// One axis of a box as lattice ranges [m0, m1) with weights (coverage per
/// texel, over the box's length): the inner whole texels and the partly
/// covered ones at each end. At most 3.
struct Weighted {
    int64_t m0, m1;
    double w;
};
int axisWeights(double x0, double x1, Weighted out[3]) {
    const double lim = 1e15;  // keeps the indices in int64 range
    x0 = std::clamp(x0, -lim, lim);
    x1 = std::clamp(x1, x0, lim);
    const double len = x1 - x0;
    const int64_t i0 = int64_t(std::floor(x0)), i1 = int64_t(std::floor(x1));
    if (!(len > 1e-12) || i0 == i1) {
        out[0] = {i0, i0 + 1, 1.0};  // one texel holds the whole box
        return 1;
    }
    int k = 0;
    const double head = double(i0 + 1) - x0, tail = x1 - double(i1);
    out[k++] = {i0, i0 + 1, head / len};
    if (i1 > i0 + 1) out[k++] = {i0 + 1, i1, 1.0 / len};
    if (tail > 0) out[k++] = {i1, i1 + 1, tail / len};
    return k;
}

}  // namespace

RGB Texture::boxMean(double x0, double x1, double y0, double y1) const {
    HRAD_CHECK(sums);
    const std::vector<RGB>& s = *sums;
    const size_t stride = size_t(width) + 1;
    auto rect = [&](const Run& x, const Run& y) {  // sum over texels [x.a, x.b) x [y.a, y.b)
        return s[size_t(y.b) * stride + size_t(x.b)] - s[size_t(y.a) * stride + size_t(x.b)] -
               s[size_t(y.b) * stride + size_t(x.a)] + s[size_t(y.a) * stride + size_t(x.a)];
    };
    Weighted wx[3], wy[3];
    const int nx = axisWeights(x0, x1, wx), ny = axisWeights(y0, y1, wy);
    RGB sum(0.0);
    for (int a = 0; a < nx; ++a) {
        Run rx[6];
        const int kx = wrapRuns(wx[a].m0, wx[a].m1, width, wrapU, rx);
        for (int b = 0; b < ny; ++b) {
            Run ry[6];
            const int ky = wrapRuns(wy[b].m0, wy[b].m1, height, wrapV, ry);
            RGB part(0.0);
            for (int i = 0; i < kx; ++i)
                for (int j = 0; j < ky; ++j) part += (rx[i].times * ry[j].times) * rect(rx[i], ry[j]);
            sum += (wx[a].w * wy[b].w) * part;
        }
    }
    return sum;
}

namespace {

void finish(Texture& t) {
    Vec3 sum(0.0);
    const size_t n = size_t(t.width) * size_t(t.height);
    for (size_t i = 0; i < n; ++i)
        sum += Vec3(t.texels[3 * i], t.texels[3 * i + 1], t.texels[3 * i + 2]);
    t.mean = n ? sum / double(n) : RGB(0.0);
}

std::optional<Texture> decodeExr(const std::string& file, TextureBudget& budget,
                                 const SourceLocation& where, std::string& why) {
    std::optional<Imf::RgbaInputFile> in;
    try {
        in.emplace(file.c_str());
    } catch (const std::exception& e) {
        why = std::string("unreadable OpenEXR (") + e.what() + ")";
        return std::nullopt;
    }
    Imath::Box2i dw = in->dataWindow();
    const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > (1 << 20) || h > (1 << 20)) {
        why = fmt::format("image size {} x {} out of range", w, h);
        return std::nullopt;
    }
    budget.reserve(w, h, where);
    Texture t;
    t.file = file;
    t.width = int(w);
    t.height = int(h);
    try {
        Imf::Array2D<Imf::Rgba> px(h, w);
        in->setFrameBuffer(&px[0][0] - dw.min.x - dw.min.y * w, 1, size_t(w));
        in->readPixels(dw.min.y, dw.max.y);
        t.texels.resize(size_t(w * h) * 3);
        for (int64_t y = 0; y < h; ++y)
            for (int64_t x = 0; x < w; ++x) {
                float* o = &t.texels[size_t(y * w + x) * 3];
                o[0] = float(px[y][x].r);
                o[1] = float(px[y][x].g);
                o[2] = float(px[y][x].b);
            }
    } catch (const std::exception& e) {
        budget.used -= uint64_t(w * h) * kBytesPerTexel;
        why = std::string("unreadable OpenEXR (") + e.what() + ")";
        return std::nullopt;
    }
    return t;
}

/// 8-bit, 16-bit or HDR images through stb_image, header first.
std::optional<Texture> decodeStb(const std::string& file, TextureEncoding enc,
                                 TextureBudget& budget, const SourceLocation& where,
                                 std::string& why) {
    std::FILE* f = std::fopen(file.c_str(), "rb");
    if (!f) {
        why = "cannot open";
        return std::nullopt;
    }
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> guard(f, &std::fclose);
    int w = 0, h = 0, comp = 0;
    if (!stbi_info_from_file(f, &w, &h, &comp) || w <= 0 || h <= 0) {
        const char* r = stbi_failure_reason();
        why = std::string("unreadable image (stb_image: ") + (r ? r : "unknown format") + ")";
        return std::nullopt;
    }
    budget.reserve(w, h, where);
    const bool hdr = stbi_is_hdr_from_file(f) != 0;
    const bool wide = !hdr && stbi_is_16_bit_from_file(f) != 0;
    int dw = 0, dh = 0, dc = 0;
    Texture t;
    t.file = file;
    auto failed = [&] {
        budget.used -= uint64_t(w) * uint64_t(h) * kBytesPerTexel;
        const char* r = stbi_failure_reason();
        why = std::string("unreadable image (stb_image: ") + (r ? r : "decoding failed") + ")";
        return std::nullopt;
    };
    if (hdr) {
        // stbi_loadf would apply a 2.2 gamma to LDR files; Radiance HDR is
        // returned as stored: linear.
        std::unique_ptr<float, void (*)(void*)> px(stbi_loadf_from_file(f, &dw, &dh, &dc, 3),
                                                   &stbi_image_free);
        if (!px || dw != w || dh != h) return failed();
        t.width = w;
        t.height = h;
        t.texels.assign(px.get(), px.get() + size_t(w) * size_t(h) * 3);
    } else if (wide) {
        std::unique_ptr<uint16_t, void (*)(void*)> px(stbi_load_from_file_16(f, &dw, &dh, &dc, 3),
                                                      &stbi_image_free);
        if (!px || dw != w || dh != h) return failed();
        t = textureFromPixels(file, w, h, 3, 16, reinterpret_cast<const unsigned char*>(px.get()),
                              enc);
    } else {
        std::unique_ptr<stbi_uc, void (*)(void*)> px(stbi_load_from_file(f, &dw, &dh, &dc, 3),
                                                     &stbi_image_free);
        if (!px || dw != w || dh != h) return failed();
        t = textureFromPixels(file, w, h, 3, 8, px.get(), enc);
    }
    return t;
}

}  // namespace

RGB Texture::lookup(double u, double v) const {
    if (!std::isfinite(u)) u = 0;
    if (!std::isfinite(v)) v = 0;
    // Texel centres at (i + 0.5) / width; v up, row 0 at the top.
    const double x = u * width - 0.5, y = (1.0 - v) * height - 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    // Far outside [0, 1] the index arithmetic must stay in int range.
    const double lim = 1e9;
    const int x0 = int(std::clamp(fx, -lim, lim)), y0 = int(std::clamp(fy, -lim, lim));
    const int xa = wrapIndex(x0, width, wrapU), xb = wrapIndex(x0 + 1, width, wrapU);
    const int ya = wrapIndex(y0, height, wrapV), yb = wrapIndex(y0 + 1, height, wrapV);
    auto at = [&](int xi, int yi) {
        const float* p = &texels[(size_t(yi) * size_t(width) + size_t(xi)) * 3];
        return RGB(p[0], p[1], p[2]);
    };
    return (1 - ay) * ((1 - ax) * at(xa, ya) + ax * at(xb, ya)) +
           ay * ((1 - ax) * at(xa, yb) + ax * at(xb, yb));
}

void TextureBudget::reserve(int64_t width, int64_t height, const SourceLocation& where) {
    const uint64_t need = uint64_t(width) * uint64_t(height) * kBytesPerTexel;
    if (used + need > maxBytes)
        throwInputError(where,
                        "texture of {} x {} texels needs {:.1f} MiB decoded; with the {:.1f} MiB of "
                        "the scene's other textures that is more than texture.max_mb = {}",
                        width, height, double(need) / (1 << 20), double(used) / (1 << 20),
                        maxBytes >> 20);
    used += need;
}

Texture textureFromPixels(const std::string& name, int width, int height, int components,
                          int bits, const unsigned char* data, TextureEncoding enc) {
    Texture t;
    t.file = name;
    t.width = width;
    t.height = height;
    const size_t n = size_t(width) * size_t(height);
    t.texels.resize(3 * n);
    std::vector<float> lut8(256);
    for (int k = 0; k < 256; ++k)
        lut8[size_t(k)] = float(enc == TextureEncoding::Srgb ? srgbToLinear(k / 255.0) : k / 255.0);
    const auto* wide = reinterpret_cast<const uint16_t*>(data);
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            // Grey (1 or 2 components: grey, alpha) counts as r = g = b.
            const size_t src = i * size_t(components) + size_t(components >= 3 ? c : 0);
            float v;
            if (bits == 16) {
                const double x = wide[src] / 65535.0;
                v = float(enc == TextureEncoding::Srgb ? srgbToLinear(x) : x);
            } else {
                v = lut8[data[src]];
            }
            t.texels[3 * i + size_t(c)] = v;
        }
    finish(t);
    return t;
}

std::optional<Texture> decodeTextureFile(const std::string& file, TextureEncoding enc,
                                         TextureBudget& budget, const SourceLocation& where,
                                         std::string& why) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
        why = "not found";
        return std::nullopt;
    }
    std::string ext = std::filesystem::path(file).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    std::optional<Texture> t = ext == ".exr" ? decodeExr(file, budget, where, why)
                                             : decodeStb(file, enc, budget, where, why);
    if (!t) return t;
    finish(*t);
    if (!std::isfinite(t->mean.r) || !std::isfinite(t->mean.g) || !std::isfinite(t->mean.b) ||
        t->mean.r < 0 || t->mean.g < 0 || t->mean.b < 0) {
        budget.used -= t->bytes();
        why = "non-finite or negative texel values";
        return std::nullopt;
    }
    return t;
}

int32_t addTexture(Scene& scene, Texture t) {
    t.sums = std::make_shared<const std::vector<RGB>>(summedArea(t));
    scene.textures.push_back(std::make_shared<const Texture>(std::move(t)));
    return int32_t(scene.textures.size() - 1);
}

const std::array<glm::vec2, 4>* patchUVs(const Scene& scene, const Patch& p) {
    return p.uvs < scene.cornerUVs.size() ? &scene.cornerUVs[p.uvs] : nullptr;
}

Vec2 uvAt(const Patch& p, const std::array<glm::vec2, 4>& uv, double u, double v) {
    auto c = [&](int i) { return Vec2(uv[size_t(i)]); };
    if (p.kind == PatchKind::Quad)
        return (1 - u) * (1 - v) * c(0) + u * (1 - v) * c(1) + u * v * c(2) + (1 - u) * v * c(3);
    return c(0) + u * (c(1) - c(0)) + v * (c(2) - c(0));
}

const TextureBinding* patchTexture(const Scene& scene, const Patch& p) {
    if (p.uvs >= scene.cornerUVs.size() || p.material >= scene.materials.size()) return nullptr;
    const TextureBinding& b = scene.materials[p.material].diffuseMap;
    if (b.texture < 0 || size_t(b.texture) >= scene.textures.size() || !scene.textures[size_t(b.texture)])
        return nullptr;
    return &b;
}

RGB textureRho(const Scene& scene, const Patch& p, double u, double v) {
    const TextureBinding& b = *patchTexture(scene, p);
    const Vec2 st = uvAt(p, scene.cornerUVs[p.uvs], u, v);
    return b.scale * scene.textures[size_t(b.texture)]->lookup(st.x, st.y);
}

RGB patchTextureMean(const Scene& scene, const Patch& p) { return elementTextureMean(scene, p, Domain{}); }

namespace {

/// A quad that is a parallelogram in 3D (to 1e-9 of its size) with corner
/// UVs forming a rectangle along the texture's axes (exactly, as floats).
bool axisAlignedParallelogram(const Patch& p, const std::array<glm::vec2, 4>& uv) {
    if (p.kind != PatchKind::Quad) return false;
    const Vec3 skew = (p.v[0] + p.v[2]) - (p.v[1] + p.v[3]);
    const double size = glm::length(p.v[2] - p.v[0]) + glm::length(p.v[3] - p.v[1]);
    if (!(glm::length(skew) <= 1e-9 * size)) return false;
    const bool uFirst = uv[0].y == uv[1].y && uv[1].x == uv[2].x && uv[2].y == uv[3].y && uv[3].x == uv[0].x;
    const bool vFirst = uv[0].x == uv[1].x && uv[1].y == uv[2].y && uv[2].x == uv[3].x && uv[3].y == uv[0].y;
    return uFirst || vFirst;
}

}  // namespace

RGB elementTextureMean(const Scene& scene, const Patch& p, const Domain& d) {
    const TextureBinding& b = *patchTexture(scene, p);
    const Texture& t = *scene.textures[size_t(b.texture)];
    const auto& uv = scene.cornerUVs[p.uvs];
    // The UV footprint in texels (shoelace area of the corner UVs, times the
    // element's share h^2 of the patch's domain) sets the grid: about two
    // cells per texel along each axis, 4 .. 64 per axis (see texture.h).
    double a2 = 0;
    const int n = p.numVertices();
    for (int i = 0; i < n; ++i) {
        const glm::vec2 &q0 = uv[size_t(i)], &q1 = uv[size_t((i + 1) % n)];
        a2 += double(q0.x) * q1.y - double(q1.x) * q0.y;
    }
    const double texels = 0.5 * std::fabs(a2) * t.width * t.height * (d.h * d.h);
    const int k = int(std::clamp(std::ceil(2.0 * std::sqrt(texels)), 4.0, 64.0));
    // Each cell contributes the exact mean of the texel squares over its UV
    // box (Texture::boxMean, a summed-area table): a quad's cells are the k x
    // k squares of the element's local coordinates, boxed by their four
    // corners' UVs, weighted by the bilinear Jacobian at their centre (area
    // measure); a triangle's are its k^2 congruent sub-triangles, equal
    // weights (below). Exact where the UV map is axis-aligned, except on a
    // triangle's k hypotenuse cells (1/k of its area).
    // Local (a, c) map to the patch's (u0 + a h, v0 + c h) (scene/element.h
    // domainParam; h < 0 for an inverted triangle).
    const Vec2 texelsPerUV(t.width, t.height);
    auto uvOf = [&](double a, double c) {
        const Vec2 q = domainParam(d, a, c);
        return uvAt(p, uv, q.x, q.y);
    };
    // The mean over the UV box [lo, hi] (texel y runs down: y = (1 - v) H).
    auto box = [&](const Vec2& lo, const Vec2& hi) {
        return t.boxMean(lo.x * texelsPerUV.x, hi.x * texelsPerUV.x, (1 - hi.y) * texelsPerUV.y,
                         (1 - lo.y) * texelsPerUV.y);
    };
    if (axisAlignedParallelogram(p, uv)) {
        // Constant Jacobian, the element's UV image a rectangle: one box is
        // the grid's sum exactly (Lost Empire's cube faces: 112 k patches).
        const Vec2 x = uvOf(0, 0), y = uvOf(1, 1);
        return b.scale * box(glm::min(x, y), glm::max(x, y));
    }
    RGB sum(0.0);
    double wsum = 0;
    if (p.kind == PatchKind::Quad) {
        for (int j = 0; j < k; ++j)
            for (int i = 0; i < k; ++i) {
                const Vec2 c[4] = {uvOf(double(i) / k, double(j) / k), uvOf(double(i + 1) / k, double(j) / k),
                                   uvOf(double(i + 1) / k, double(j + 1) / k), uvOf(double(i) / k, double(j + 1) / k)};
                const Vec2 lo = glm::min(glm::min(c[0], c[1]), glm::min(c[2], c[3]));
                const Vec2 hi = glm::max(glm::max(c[0], c[1]), glm::max(c[2], c[3]));
                const double w = elementJacobian(p, d, (i + 0.5) / k, (j + 0.5) / k);
                sum += w * box(lo, hi);
                wsum += w;
            }
    } else {
        // Row j of the k^2 sub-triangles: an upright and an inverted one
        // form the square [i, i + 1] x [j, j + 1] / k, boxed by its four
        // corners (weight 2: two sub-triangles); the last upright one of the
        // row, on the hypotenuse, a box of its own area about its centroid
        // (the one approximation where the UV map is axis-aligned).
        const double s = 1.0 / k;
        for (int j = 0; j < k; ++j)
            for (int i = 0; i + j < k; ++i) {
                const Vec2 x = uvOf(i * s, j * s), y = uvOf((i + 1) * s, j * s), z = uvOf(i * s, (j + 1) * s);
                if (i + j + 1 < k) {
                    const Vec2 w = uvOf((i + 1) * s, (j + 1) * s);
                    sum += 2.0 * box(glm::min(glm::min(x, y), glm::min(z, w)),
                                     glm::max(glm::max(x, y), glm::max(z, w)));
                    wsum += 2;
                    continue;
                }
                // Kept inside the triangle's own bounding box.
                const Vec2 blo = glm::min(glm::min(x, y), z), bhi = glm::max(glm::max(x, y), z);
                const Vec2 centroid = (x + y + z) / 3.0, half = (bhi - blo) * (0.5 / std::sqrt(2.0));
                sum += box(glm::max(centroid - half, blo), glm::min(centroid + half, bhi));
                wsum += 1;
            }
    }
    return wsum > 0 ? b.scale * (sum / wsum) : b.scale * t.mean;
}

RGB elementRho(const Scene& scene, const Patch& p, const Domain& d) {
    const TextureBinding& b = *patchTexture(scene, p);
    RGB m = elementTextureMean(scene, p, d);
    // An element brighter than 1 keeps the loader's clamp, or, where the
    // binding clamps with 0 (the patch mean < 1 was checked on load), the
    // patch's own mean in that channel.
    for (int c = 0; c < 3; ++c)
        if (m[c] >= 1.0) m[c] = b.clampRho > 0 ? b.clampRho : p.rho[c];
    return m;
}

size_t applyTextureMeans(Scene& scene) {
    size_t textured = 0, clamped = 0;
    for (Patch& p : scene.patches) {
        const TextureBinding* b = patchTexture(scene, p);
        if (!b) continue;
        RGB m = patchTextureMean(scene, p);
        bool over = false;
        for (int c = 0; c < 3; ++c)
            if (m[c] >= 1.0) {
                if (!(b->clampRho > 0))
                    throwInputError(SourceLocation{scene.textures[size_t(b->texture)]->file, 0, 0},
                                    "material '{}': the texture's mean on a patch is {:.4g} >= 1 "
                                    "(set {}, e.g. 0.99, to clamp)",
                                    scene.materials[p.material].name, m[c], b->clampKey);
                m[c] = b->clampRho;
                over = true;
            }
        clamped += over ? 1 : 0;
        p.rho = m;
        ++textured;
    }
    if (clamped)
        scene.stats.warnings.push_back(fmt::format(
            "{}: {} textured patches have a mean reflectance >= 1 in a channel, clamped (clamp_rho)",
            scene.name, clamped));
    return textured;
}

}  // namespace hrad::scene
