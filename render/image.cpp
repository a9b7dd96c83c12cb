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

std::vector<FieldLeaf> fieldLeaves(const scene::RadiosityField& field, double& exposure) {
    const scene::Scene& sc = field.scene();
    std::vector<FieldLeaf> leaves;
    std::vector<RGB> values;
    std::vector<double> areas;
    for (uint32_t p = 0; p < sc.patches.size(); ++p)
        field.forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) {
            leaves.push_back({p, k, b});
            values.push_back(b);
            areas.push_back(scene::elementArea(sc.patches[p], scene::keyDomain(sc.patches[p].kind, k)));
        });
    if (!(exposure > 0)) exposure = autoExposure(values, areas);
    return leaves;
}

double pngAutoExposure(const Image& image) {
    return std::max(autoExposure(image.pixels), 0.35 * autoExposure(image.pixels, {}, 0.5));
}

uint8_t encodeSrgb8(double x) {
    if (!(x > 0)) return 0;  // also NaN
    if (x >= 1) return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    return uint8_t(std::lround(s * 255.0));
}

std::array<uint8_t, 3> toneMap(const RGB& c, double exposure) {
    return {encodeSrgb8(exposure * c.r), encodeSrgb8(exposure * c.g), encodeSrgb8(exposure * c.b)};
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
    HRAD_CHECK(image.width > 0 && image.height > 0 &&
               image.pixels.size() == size_t(image.width) * size_t(image.height));
    if (!(exposure > 0)) exposure = pngAutoExposure(image);
    std::vector<uint8_t> buf(image.pixels.size() * 3);
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        auto c = toneMap(image.pixels[i], exposure);
        std::copy(c.begin(), c.end(), buf.begin() + int64_t(3 * i));
    }
    // The data are already sRGB-encoded 8-bit values.
    writePngPixels(path, image.width, image.height, PNG_FORMAT_RGB, buf.data());
}

}  // namespace hrad::render
