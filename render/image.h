// Linear RGB images and their output: OpenEXR (linear, half float) and PNG
// (tone mapped, sRGB encoded, 8 bit).
//
// Tone mapping for PNG/PLY colours is deliberately simple and documented:
// multiply by an exposure, clamp each channel to [0,1], encode with the sRGB
// transfer function (IEC 61966-2-1). The automatic exposure maps the 99th
// percentile of the luminance of the non-black values to 1 (so a few bright
// pixels, typically the light source, clip and the rest keeps its contrast).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.h"
#include "scene/element.h"
#include "scene/field.h"

namespace hrad::render {

struct Image {
    int width = 0, height = 0;
    std::vector<RGB> pixels;  ///< row-major, row 0 at the top

    Image() = default;
    Image(int w, int h) : width(w), height(h), pixels(size_t(w) * size_t(h), RGB(0.0)) {}
    RGB& at(int x, int y) { return pixels[size_t(y) * size_t(width) + size_t(x)]; }
    const RGB& at(int x, int y) const { return pixels[size_t(y) * size_t(width) + size_t(x)]; }
};

/// 1 / (the `percentile` quantile of the luminance of the values with positive
/// luminance), weighted by `weights` when given (same size as values); 1 when
/// no value is positive.
double autoExposure(const std::vector<RGB>& values, const std::vector<double>& weights = {},
                    double percentile = 0.99);

/// One leaf element of a radiosity field and its radiosity.
struct FieldLeaf {
    uint32_t patch;
    scene::ElementKey key;
    RGB b;
};
/// The leaves of `field` in patch order (what the PLY and glTF exports
/// write), and in `exposure` the exposure their colours use: unchanged when
/// > 0, else autoExposure over the leaves weighted by their areas.
std::vector<FieldLeaf> fieldLeaves(const scene::RadiosityField& field, double& exposure);

/// The exposure writePng uses when it is not given one: the 99th percentile
/// of the luminance maps to 1, unless that leaves the median darker than 0.35
/// (scenes whose lamps fill more than 1 % of the frame): then the median maps
/// to 0.35 and the lamps clip.
double pngAutoExposure(const Image& image);

/// sRGB transfer function of a linear value, clamped to [0,1], to 8 bits.
uint8_t encodeSrgb8(double linear);
/// exposure * c, clamped, sRGB encoded.
std::array<uint8_t, 3> toneMap(const RGB& c, double exposure);

/// Linear RGB as half-float OpenEXR (RGB channels, no alpha). Throws
/// hrad::InputError naming the path when the file cannot be written.
void writeExr(const Image& image, const std::string& path);
/// Reads the R, G, B channels of an OpenEXR file (missing channels are 0).
Image readExr(const std::string& path);

/// Writes `pixels` (rows top first, tightly packed) as a PNG through libpng's
/// simplified API; `format` is a PNG_FORMAT_* value of <png.h> (e.g.
/// PNG_FORMAT_RGB for 8-bit sRGB, PNG_FORMAT_LINEAR_Y for 16-bit gray).
/// Throws hrad::InputError naming the path when the file cannot be written.
void writePngPixels(const std::string& path, int width, int height, uint32_t format,
                    const void* pixels);

/// Tone-mapped 8-bit sRGB PNG. exposure > 0 multiplies the linear values;
/// exposure <= 0 uses pngAutoExposure(image). Throws hrad::InputError
/// naming the path when the file cannot be written.
void writePng(const Image& image, const std::string& path, double exposure = 0.0);

}  // namespace hrad::render
