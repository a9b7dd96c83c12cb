#include "render/image.h"

#include <ImfArray.h>
#include <ImfRgbaFile.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <numeric>

#include "core/error.h"
#include "core/safe_file.h"

namespace hrad::render {

double autoExposure(const std::vector<RGB>& values, const std::vector<double>& weights,
                    double percentile) {
    HRAD_CHECK(weights.empty() || weights.size() == values.size());
    std::vector<std::pair<double, double>> lw;  // (luminance, weight)
    lw.reserve(values.size());
    double total = 0.0;
    for (size_t i = 0; i < values.size(); ++i) {
        double l = luminance(values[i]);
        double w = weights.empty() ? 1.0 : weights[i];
        if (l > 0 && std::isfinite(l) && w > 0) {
            lw.emplace_back(l, w);
            total += w;
        }
    }
    if (lw.empty()) return 1.0;
    std::sort(lw.begin(), lw.end());
    double target = percentile * total, acc = 0.0;
    for (const auto& [l, w] : lw) {
        acc += w;
        if (acc >= target) return 1.0 / l;
    }
    return 1.0 / lw.back().first;
}

namespace {

/// (value, weight) of the values with positive finite luminance.
template <typename F>
std::vector<std::pair<double, double>> weighted(const std::vector<RGB>& values,
                                                const std::vector<double>& weights, F f) {
    HRAD_CHECK(weights.empty() || weights.size() == values.size());
    std::vector<std::pair<double, double>> out;
    out.reserve(values.size());
    for (size_t i = 0; i < values.size(); ++i) {
        double l = luminance(values[i]), w = weights.empty() ? 1.0 : weights[i];
        if (l > 0 && std::isfinite(l) && w > 0) out.emplace_back(f(values[i]), w);
    }
    return out;
}

/// The `q` quantile (weighted) of the firsts of `vw`; sorts vw.
double quantile(std::vector<std::pair<double, double>>& vw, double q) {
    std::sort(vw.begin(), vw.end());
    double total = 0.0;
    for (const auto& e : vw) total += e.second;
    double target = q * total, acc = 0.0;
    for (const auto& [v, w] : vw) {
        acc += w;
        if (acc >= target) return v;
    }
    return vw.back().first;
}

double maxChannel(const RGB& c) { return std::max({c.r, c.g, c.b}); }

}  // namespace

RGB ToneMap::display(const RGB& b) const {
    RGB c = exposure * b;
    if (curve == ToneCurve::Reinhard) {
        // Reinhard et al. 2002, eq. 4, on the largest channel: the hue is
        // kept and no channel passes 1 below the white point.
        double l = maxChannel(c);
        if (!(l > 0)) return RGB(0.0);
        double ld = l * (1.0 + l / (white * white)) / (1.0 + l);
        c *= std::min(ld, 1.0) / l;
    }
    return glm::clamp(c, RGB(0.0), RGB(1.0));
}

bool ToneMap::clips(const RGB& b) const {
    // A value at the white point (or exactly at 1) is white, not clipped: the
    // tolerance absorbs the round-off of the curve there.
    const double limit = 1.0 + 1e-9;
    RGB c = exposure * b;
    if (curve == ToneCurve::Reinhard) {
        double l = maxChannel(c);
        if (!(l > 0)) return false;
        return l * (1.0 + l / (white * white)) / (1.0 + l) > limit;
    }
    return maxChannel(c) > limit;
}

std::array<uint8_t, 3> ToneMap::srgb8(const RGB& b) const {
    RGB d = display(b);
    return {encodeSrgb8(d.r), encodeSrgb8(d.g), encodeSrgb8(d.b)};
}

ToneSettings ToneSettings::fromParams(const Params& params, const std::string& prefix) {
    auto key = [&](const char* k) { return prefix.empty() ? std::string(k) : prefix + "." + k; };
    ToneSettings s;
    s.exposure = params.getDouble(
        {key("exposure"), "image exposure: > 0 multiplies B; 0: automatic (log-average key, "
                          "Reinhard 2002, at most max_clipped clipped)"},
        0.0, 0.0, 1e300);
    s.curve = params.getEnum({key("tone_curve"),
                              "tone curve of PNG, PLY and glTF colours: clip (linear, clamp) or "
                              "reinhard (Reinhard 2002 eq. 4 with a white point)"},
                             "clip", {"clip", "reinhard"}) == "clip"
                  ? ToneCurve::Clip
                  : ToneCurve::Reinhard;
    s.key = params.getDouble(
        {key("key"), "automatic exposure: display value of the log-average luminance"}, s.key,
        1e-6, 1.0);
    s.maxClipped = params.getDouble(
        {key("max_clipped"), "automatic exposure: largest share of non-black pixels that clip"},
        s.maxClipped, 0.0, 1.0);
    return s;
}

ToneMap ToneSettings::choose(const std::vector<RGB>& values, const std::vector<double>& weights) const {
    ToneMap t;
    t.curve = curve;
    auto logs = weighted(values, weights, [](const RGB& c) { return std::log(luminance(c)); });
    if (exposure > 0) t.exposure = exposure;
    else if (logs.empty()) t.exposure = 1.0;
    else {
        // Reinhard et al. 2002, eq. 1-2: the log-average luminance maps to the key.
        double sum = 0.0, total = 0.0;
        for (const auto& [lg, w] : logs) sum += w * lg, total += w;
        t.exposure = key / std::exp(sum / total);
    }
    auto peaks = weighted(values, weights, [](const RGB& c) { return maxChannel(c); });
    if (peaks.empty()) return t;
    const double top = quantile(peaks, 1.0 - maxClipped);  // peaks sorted now
    if (curve == ToneCurve::Reinhard) {
        t.white = std::max(t.exposure * top, 1e-12);
    } else if (!(exposure > 0) && t.exposure * top > 1.0) {
        t.exposure = 1.0 / top;
    }
    return t;
}

ToneMap ToneSettings::choose(const Image& image) const {
    if (image.surface.empty()) return choose(image.pixels);
    // Weighted by the pixels' surface share (header); sky alone: all pixels.
    std::vector<double> w(image.surface.begin(), image.surface.end());
    bool any = false;
    for (size_t i = 0; i < w.size() && !any; ++i) any = w[i] > 0 && luminance(image.pixels[i]) > 0;
    return any ? choose(image.pixels, w) : choose(image.pixels);
}

double clippedShare(const std::vector<RGB>& values, const ToneMap& tone,
                    const std::vector<double>& weights, bool nonBlackOnly) {
    HRAD_CHECK(weights.empty() || weights.size() == values.size());
    double clipped = 0.0, total = 0.0;
    for (size_t i = 0; i < values.size(); ++i) {
        double w = weights.empty() ? 1.0 : weights[i];
        if (nonBlackOnly && !(luminance(values[i]) > 0)) continue;
        total += w;
        if (tone.clips(values[i])) clipped += w;
    }
    return total > 0 ? clipped / total : 0.0;
}

std::vector<FieldLeaf> fieldLeaves(const scene::RadiosityField& field, std::vector<double>* areas) {
    const scene::Scene& sc = field.scene();
    std::vector<FieldLeaf> leaves;
    for (uint32_t p = 0; p < sc.patches.size(); ++p)
        field.forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) {
            leaves.push_back({p, k, b});
            if (areas)
                areas->push_back(
                    scene::elementArea(sc.patches[p], scene::keyDomain(sc.patches[p].kind, k)));
        });
    return leaves;
}

ToneMap leafToneMap(const scene::RadiosityField& field, const ToneSettings& settings) {
    std::vector<double> areas;
    std::vector<FieldLeaf> leaves = fieldLeaves(field, &areas);
    std::vector<RGB> values(leaves.size());
    for (size_t i = 0; i < leaves.size(); ++i) values[i] = leaves[i].b;
    return settings.choose(values, areas);
}

double pngAutoExposure(const Image& image) { return ToneSettings{}.choose(image).exposure; }

uint8_t encodeSrgb8(double x) {
    if (!(x > 0)) return 0;  // also NaN
    if (x >= 1) return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    return uint8_t(std::lround(s * 255.0));
}

std::array<uint8_t, 3> toneMap(const RGB& c, double exposure) {
    ToneMap t;
    t.exposure = exposure;
    return t.srgb8(c);
}

void writeExr(const Image& image, const std::string& path) {
    HRAD_CHECK(image.width > 0 && image.height > 0 &&
               image.pixels.size() == size_t(image.width) * size_t(image.height));
    std::vector<Imf::Rgba> px(image.pixels.size());
    for (size_t i = 0; i < px.size(); ++i) {
        const RGB& c = image.pixels[i];
        px[i] = Imf::Rgba(half(float(c.r)), half(float(c.g)), half(float(c.b)), half(1.0f));
    }
    writeThroughTemp(path, [&](const std::filesystem::path& tmp) {
        try {
            Imf::RgbaOutputFile file(tmp.c_str(), image.width, image.height, Imf::WRITE_RGB);
            file.setFrameBuffer(px.data(), 1, size_t(image.width));
            file.writePixels(image.height);
        } catch (const std::exception& e) {
            throw IoError(path, std::string("cannot write EXR: ") + e.what());
        }
    });
}

Image readExr(const std::string& path) {
    try {
        Imf::RgbaInputFile file(path.c_str());
        Imath::Box2i dw = file.dataWindow();
        int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        std::vector<Imf::Rgba> px(size_t(w) * size_t(h));
        file.setFrameBuffer(px.data() - dw.min.x - dw.min.y * w, 1, size_t(w));
        file.readPixels(dw.min.y, dw.max.y);
        Image img(w, h);
        for (size_t i = 0; i < px.size(); ++i)
            img.pixels[i] = RGB(float(px[i].r), float(px[i].g), float(px[i].b));
        return img;
    } catch (const std::exception& e) {
        throw InputError(SourceLocation{path, 0, 0}, std::string("cannot read EXR: ") + e.what());
    }
}

void writePngPixels(const std::string& path, int width, int height, uint32_t format,
                    const void* pixels) {
    // libpng's simplified API (1.6): no setjmp, errors come back in message.
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    png.width = png_uint_32(width);
    png.height = png_uint_32(height);
    png.format = format;
    writeThroughTemp(path, [&](const std::filesystem::path& tmp) {
        if (!png_image_write_to_file(&png, tmp.c_str(), 0, pixels, 0, nullptr)) {
            std::string msg = png.message;
            png_image_free(&png);
            throw IoError(path, "cannot write PNG: " + msg);
        }
    });
}

void writePng(const Image& image, const std::string& path, double exposure) {
    ToneSettings ts;
    ts.exposure = exposure > 0 ? exposure : 0.0;
    writePng(image, path, ts.choose(image));
}

namespace {
/// The image through `tone` as 8-bit sRGB triples (already encoded).
std::vector<uint8_t> toneMappedRgb8(const Image& image, const ToneMap& tone) {
    HRAD_CHECK(image.width > 0 && image.height > 0 &&
               image.pixels.size() == size_t(image.width) * size_t(image.height));
    std::vector<uint8_t> buf(image.pixels.size() * 3);
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        auto c = tone.srgb8(image.pixels[i]);
        std::copy(c.begin(), c.end(), buf.begin() + int64_t(3 * i));
    }
    return buf;
}
}  // namespace

void writePng(const Image& image, const std::string& path, const ToneMap& tone) {
    writePngPixels(path, image.width, image.height, PNG_FORMAT_RGB,
                   toneMappedRgb8(image, tone).data());
}

std::vector<unsigned char> encodePng(const Image& image, const ToneMap& tone) {
    const std::vector<uint8_t> px = toneMappedRgb8(image, tone);
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    png.width = png_uint_32(image.width);
    png.height = png_uint_32(image.height);
    png.format = PNG_FORMAT_RGB;
    png_alloc_size_t bytes = 0;
    HRAD_CHECK(png_image_write_to_memory(&png, nullptr, &bytes, 0, px.data(), 0, nullptr));
    std::vector<unsigned char> out(bytes);
    HRAD_CHECK(png_image_write_to_memory(&png, out.data(), &bytes, 0, px.data(), 0, nullptr));
    out.resize(bytes);
    return out;
}

}  // namespace hrad::render
