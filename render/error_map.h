// Per-pixel error maps: a render of a solution against a render of the
// reference, from the same camera with the same settings.
//
// For every pixel with luminance Y_s (solution) and Y_r (reference), Rec. 709
// weights (core/types.h):
//
//   e = (Y_s - Y_r) / max(Y_r, floor),   floor = floor_fraction * mean(Y_r)
//
// where mean(Y_r) is taken over the pixels that show something (Y_r > 0 or
// Y_s > 0). e is the signed relative error: negative where the solution is
// too dark, positive where it is too bright. The floor keeps e finite on
// surfaces the reference shows (almost) black. Pixels where both renders are
// black (rays that miss, black surfaces) carry no error and are NaN, and so
// do pixels that show the sky alone in both (Image::surface 0: rays that
// miss under render.background = environment).
//
// Statistics over the finite pixels: the mean and 95th percentile of |e|, its
// maximum, and the image-space relative errors of luminance
//   l1 = sum |Y_s - Y_r| / sum Y_r,   l2 = sqrt(sum (Y_s - Y_r)^2 / sum Y_r^2).
// These are per pixel (they weight surfaces by their size on screen and
// include the difference of the two reconstructions), unlike the
// area-weighted region errors of reference/metrics.h.
//
// Files:
//  - writeErrorData: the map as a 16-bit grayscale PNG. Value 0 = no data
//    (NaN); 1..65535 encode e in [-1, 1] linearly,
//        v = 1 + round((clamp(e, -1, 1) + 1) / 2 * 65534),
//    so e = 2 (v - 1) / 65534 - 1, a step of 3.1e-5. Errors beyond +-100 %
//    are clipped in the file (not in the statistics). Lossless PNG keeps the
//    file small and any image library reads it (papers/hradplot does).
//  - writeErrorFalseColour: an 8-bit sRGB PNG for looking at directly: a
//    diverging map through the Okabe & Ito (2008) colour-blind-safe blue
//    #0072B2 (e = -range: too dark), white (e = 0) and vermillion #D55E00
//    (e = +range: too bright), interpolated linearly in sRGB values and
//    clamped beyond +-range; no-data pixels are dark grey #404040.
//    papers/hradplot uses the same three colours for its colour bars.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "render/image.h"

namespace hrad::render {

struct ErrorMap {
    int width = 0, height = 0;
    std::vector<float> values;  ///< row-major, row 0 at the top; NaN = no data

    size_t pixels = 0;       ///< finite pixels
    double floor = 0.0;      ///< the luminance floor used in the denominator
    double meanAbs = 0.0;    ///< mean |e|
    double p95Abs = 0.0;     ///< 95th percentile of |e|
    double maxAbs = 0.0;     ///< max |e|
    double l1 = 0.0, l2 = 0.0;  ///< image-space relative luminance errors (above)
};

/// The map of `solution` against `reference` (same size, else hrad::Error).
/// floorFraction > 0.
ErrorMap computeErrorMap(const Image& solution, const Image& reference, double floorFraction = 0.01);

/// 16-bit data PNG (encoding above). Throws InputError naming the path.
void writeErrorData(const ErrorMap& map, const std::string& path);
/// Reads a file written by writeErrorData (values only; statistics are 0).
ErrorMap readErrorData(const std::string& path);

/// sRGB colour of e for a map clamped to +-range (range > 0); NaN: no-data grey.
std::array<uint8_t, 3> errorColour(double e, double range);
/// False-colour 8-bit PNG with colours errorColour(e, range).
void writeErrorFalseColour(const ErrorMap& map, const std::string& path, double range);

}  // namespace hrad::render
