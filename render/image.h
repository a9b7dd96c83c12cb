// Linear RGB images and their output: OpenEXR (linear, half float) and PNG
// (tone mapped, sRGB encoded, 8 bit), and the one tone map that the PNG, the
// PLY vertex colours and the glTF COLOR_0 share (issue 60).
//
// Tone map (ToneMap): display = curve(exposure * B), then the sRGB transfer
// function (IEC 61966-2-1) for 8-bit output; glTF's COLOR_0 is the linear
// display value (viewers encode it). Curves: `clip` clamps each channel to
// [0, 1] (linear up to white: pixel ratios stay radiosity ratios); `reinhard`
// is Reinhard et al. 2002 eq. 4, L_d = L (1 + L / L_w^2) / (1 + L), applied to
// the largest channel L (so the hue is kept and no channel passes 1 below the
// white point), RGB scaled by L_d / L, L_w the white point.
// Automatic exposure (ToneSettings::choose): Reinhard 2002 eq. 1-2, the
// log-average luminance L_avg = exp(mean log L) over the non-black values maps
// to the key a (0.18, "middle grey"): exposure = a / L_avg. With `clip`, when
// more than max_clipped of the values would then clip (any channel > 1), the
// exposure drops until exactly the (1 - max_clipped) quantile of the largest
// channel maps to 1; with `reinhard`, L_w is that quantile (exposed). So at
// most max_clipped (1 %) of the non-black pixels clip either way. Values are
// weighted (by area for a field's leaves). An image that shows the sky
// (Image::surface set) weights each pixel by its share of surface samples:
// a bright sky would otherwise set both the key and the clip quantile and
// leave the surfaces dark; so the exposure is about the one of the
// surfaces alone (as with render.background = black) and the sky may clip, as a
// photograph exposed for the ground does. An image of sky alone is
// exposed for the sky.
//
// Settings (ToneSettings::fromParams, below "render"):
//   exposure     double 0       > 0: fixed; 0: automatic as above
//   tone_curve   string "clip"  clip | reinhard
//   key          double 0.18    the log-average's display value (automatic)
//   max_clipped  double 0.01    largest share of non-black values that clip
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/types.h"
#include "scene/element.h"
#include "scene/field.h"

namespace hrad::render {

struct Image {
    int width = 0, height = 0;
    std::vector<RGB> pixels;  ///< row-major, row 0 at the top
    /// Empty, or per pixel the share of its samples that hit a surface, set
    /// by a render that shows the environment on the other samples
    /// (render.background, render/render.h); empty means every pixel is surface.
    std::vector<float> surface;

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

enum class ToneCurve { Clip, Reinhard };

/// One tone map, as chosen once per output set (see above).
struct ToneMap {
    double exposure = 1.0;
    ToneCurve curve = ToneCurve::Clip;
    double white = 1.0;  ///< reinhard: the exposed largest channel that maps to 1
    /// Linear display value in [0, 1] per channel (before sRGB encoding).
    RGB display(const RGB& b) const;
    /// display(b), sRGB encoded to 8 bits.
    std::array<uint8_t, 3> srgb8(const RGB& b) const;
    /// Whether some channel of display(b) is at 1 because of the curve's clamp.
    bool clips(const RGB& b) const;
    std::string curveName() const { return curve == ToneCurve::Clip ? "clip" : "reinhard"; }
};

struct ToneSettings {
    double exposure = 0.0;  ///< render.exposure (> 0 fixed, 0 automatic)
    ToneCurve curve = ToneCurve::Clip;
    double key = 0.18;
    double maxClipped = 0.01;

    static ToneSettings fromParams(const Params& params, const std::string& prefix = "render");
    /// The tone map for `values` (weighted when `weights` is given).
    ToneMap choose(const std::vector<RGB>& values, const std::vector<double>& weights = {}) const;
    ToneMap choose(const Image& image) const;
};

/// Share of `values` (weighted) that clip under `tone`, over all values
/// (black ones included) or, with nonBlackOnly, over those with positive
/// luminance.
double clippedShare(const std::vector<RGB>& values, const ToneMap& tone,
                    const std::vector<double>& weights = {}, bool nonBlackOnly = false);

/// One leaf element of a radiosity field and its radiosity.
struct FieldLeaf {
    uint32_t patch;
    scene::ElementKey key;
    RGB b;
};
/// The leaves of `field` in patch order (what the PLY and glTF exports
/// write), and in `areas` (when given) their areas.
std::vector<FieldLeaf> fieldLeaves(const scene::RadiosityField& field,
                                   std::vector<double>* areas = nullptr);
/// The tone map of `settings` over the leaves of `field`, area-weighted: what
/// the exports use when no image fixed the tone map.
ToneMap leafToneMap(const scene::RadiosityField& field, const ToneSettings& settings);

/// The exposure of ToneSettings{}.choose(image) (the automatic rule with the
/// clip curve), which writePng uses when it is not given a tone map.
double pngAutoExposure(const Image& image);

/// sRGB transfer function of a linear value, clamped to [0,1], to 8 bits.
uint8_t encodeSrgb8(double linear);
/// exposure * c, clamped, sRGB encoded (ToneMap{exposure}.srgb8(c)).
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

/// Tone-mapped 8-bit sRGB PNG. exposure > 0 multiplies the linear values
/// (clip curve); exposure <= 0 uses ToneSettings{}.choose(image). Throws
/// hrad::InputError naming the path when the file cannot be written.
void writePng(const Image& image, const std::string& path, double exposure = 0.0);
/// The same with an explicit tone map.
void writePng(const Image& image, const std::string& path, const ToneMap& tone);
/// The PNG file's bytes writePng would write with `tone` (for embedding, e.g.
/// a glTF image).
std::vector<unsigned char> encodePng(const Image& image, const ToneMap& tone);

}  // namespace hrad::render
