#include "render/error_map.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"

namespace hrad::render {

ErrorMap computeErrorMap(const Image& solution, const Image& reference, double floorFraction) {
    if (solution.width != reference.width || solution.height != reference.height)
        throw Error(fmt::format("error map: solution image is {}x{}, reference {}x{}", solution.width,
                                solution.height, reference.width, reference.height));
    HRAD_CHECK(floorFraction > 0);
    ErrorMap m;
    m.width = solution.width;
    m.height = solution.height;
    const size_t n = solution.pixels.size();
    std::vector<double> ys(n), yr(n);
    double sumRef = 0.0;
    size_t shown = 0;
    // Pixels of sky alone in both renders (Image::surface, render.background)
    // carry no error, as the black misses did before the sky was shown.
    const bool masks = solution.surface.size() == n && reference.surface.size() == n;
    for (size_t i = 0; i < n; ++i) {
        const bool sky = masks && solution.surface[i] == 0 && reference.surface[i] == 0;
        ys[i] = sky ? 0.0 : luminance(solution.pixels[i]);
        yr[i] = sky ? 0.0 : luminance(reference.pixels[i]);
        if (yr[i] > 0 || ys[i] > 0) {
            sumRef += yr[i];
            ++shown;
        }
    }
    m.floor = shown ? floorFraction * sumRef / double(shown) : 0.0;

    m.values.assign(n, std::numeric_limits<float>::quiet_NaN());
    std::vector<double> absE;
    absE.reserve(shown);
    double num1 = 0, den1 = 0, num2 = 0, den2 = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!(yr[i] > 0 || ys[i] > 0)) continue;
        double d = ys[i] - yr[i];
        double denom = std::max(yr[i], m.floor);
        double e = denom > 0 ? d / denom : 0.0;  // floor 0: the reference is black everywhere
        if (!std::isfinite(e)) continue;          // a NaN/inf pixel in either render
        m.values[i] = float(e);
        absE.push_back(std::abs(e));
        num1 += std::abs(d);
        den1 += yr[i];
        num2 += d * d;
        den2 += yr[i] * yr[i];
    }
    m.pixels = absE.size();
    if (!absE.empty()) {
        double sum = 0;
        for (double a : absE) sum += a;
        m.meanAbs = sum / double(absE.size());
        m.maxAbs = *std::max_element(absE.begin(), absE.end());
        size_t k = std::min(absE.size() - 1, size_t(std::ceil(0.95 * double(absE.size()))) - 1);
        std::nth_element(absE.begin(), absE.begin() + int64_t(k), absE.end());
        m.p95Abs = absE[k];
    }
    auto ratio = [](double num, double den) { return den > 0 ? num / den : (num > 0 ? INFINITY : 0.0); };
    m.l1 = ratio(num1, den1);
    m.l2 = std::sqrt(ratio(num2, den2));
    return m;
}

void writeErrorData(const ErrorMap& map, const std::string& path) {
    HRAD_CHECK(map.width > 0 && map.height > 0 &&
               map.values.size() == size_t(map.width) * size_t(map.height));
    std::vector<png_uint_16> buf(map.values.size());
    for (size_t i = 0; i < buf.size(); ++i) {
        float e = map.values[i];
        if (std::isnan(e)) {
            buf[i] = 0;
            continue;
        }
        double t = (std::clamp(double(e), -1.0, 1.0) + 1.0) / 2.0;
        buf[i] = png_uint_16(1 + std::lround(t * 65534.0));
    }
    // PNG_FORMAT_LINEAR_Y: 16-bit gray written as is (gAMA 1.0, no transfer curve).
    writePngPixels(path, map.width, map.height, PNG_FORMAT_LINEAR_Y, buf.data());
}

ErrorMap readErrorData(const std::string& path) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, path.c_str()))
        throw InputError(SourceLocation{path, 0, 0}, std::string("cannot read PNG: ") + png.message);
    if ((png.format & PNG_FORMAT_FLAG_COLOR) || !(png.format & PNG_FORMAT_FLAG_LINEAR)) {
        png_image_free(&png);
        throw InputError(SourceLocation{path, 0, 0}, "not an hrad error map (expected 16-bit gray PNG)");
    }
    png.format = PNG_FORMAT_LINEAR_Y;
    std::vector<png_uint_16> buf(size_t(png.width) * size_t(png.height));
    if (!png_image_finish_read(&png, nullptr, buf.data(), 0, nullptr)) {
        std::string msg = png.message;
        png_image_free(&png);
        throw InputError(SourceLocation{path, 0, 0}, "cannot read PNG: " + msg);
    }
    ErrorMap m;
    m.width = int(png.width);
    m.height = int(png.height);
    m.values.resize(buf.size());
    for (size_t i = 0; i < buf.size(); ++i)
        m.values[i] = buf[i] == 0 ? std::numeric_limits<float>::quiet_NaN()
                                  : float(2.0 * double(buf[i] - 1) / 65534.0 - 1.0);
    return m;
}

std::array<uint8_t, 3> errorColour(double e, double range) {
    HRAD_CHECK(range > 0);
    if (std::isnan(e)) return {0x40, 0x40, 0x40};
    // Okabe & Ito (2008): blue #0072B2 and vermillion #D55E00, through white.
    static constexpr double kBlue[3] = {0x00, 0x72, 0xB2}, kVermillion[3] = {0xD5, 0x5E, 0x00};
    double t = std::clamp(e / range, -1.0, 1.0);
    const double* end = t < 0 ? kBlue : kVermillion;
    double a = std::abs(t);
    std::array<uint8_t, 3> c{};
    for (int k = 0; k < 3; ++k) c[size_t(k)] = uint8_t(std::lround(255.0 + a * (end[k] - 255.0)));
    return c;
}

void writeErrorFalseColour(const ErrorMap& map, const std::string& path, double range) {
    HRAD_CHECK(map.width > 0 && map.height > 0 &&
               map.values.size() == size_t(map.width) * size_t(map.height));
    std::vector<uint8_t> buf(map.values.size() * 3);
    for (size_t i = 0; i < map.values.size(); ++i) {
        auto c = errorColour(double(map.values[i]), range);
        std::copy(c.begin(), c.end(), buf.begin() + int64_t(3 * i));
    }
    writePngPixels(path, map.width, map.height, PNG_FORMAT_RGB, buf.data());
}

}  // namespace hrad::render
