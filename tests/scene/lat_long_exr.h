// Test helper: writes a w x h lat-long environment map as half-float
// OpenEXR from a function of the texel (i, j), for the envmap tests
// (tests/scene/envmap_test.cpp, tests/render/environment_test.cpp). Values
// the tests use are dyadic, so exact in half.
#pragma once

#include <ImfRgbaFile.h>

#include <filesystem>
#include <functional>
#include <vector>

#include "core/types.h"

namespace hrad::test {

inline std::filesystem::path writeLatLongExr(const std::filesystem::path& file, int w, int h,
                                             const std::function<RGB(int i, int j)>& f) {
    std::vector<Imf::Rgba> px(size_t(w) * size_t(h));
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const RGB c = f(i, j);
            px[size_t(j) * size_t(w) + size_t(i)] =
                Imf::Rgba(half(float(c.r)), half(float(c.g)), half(float(c.b)));
        }
    Imf::RgbaOutputFile out(file.c_str(), w, h, Imf::WRITE_RGB);
    out.setFrameBuffer(px.data(), 1, size_t(w));
    out.writePixels(h);
    return file;
}

}  // namespace hrad::test
