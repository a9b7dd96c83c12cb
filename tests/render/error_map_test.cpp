// Per-pixel error maps: the formula, statistics, the 16-bit data encoding and
// the false colours (render/error_map.h).
#include "render/error_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core/error.h"
#include "tests/test_util.h"

namespace hrad::render {
namespace {

/// 4x1 image with the given luminances (grey, so luminance = value).
Image greys(std::initializer_list<double> ys) {
    Image img(int(ys.size()), 1);
    size_t i = 0;
    for (double y : ys) img.pixels[i++] = RGB(y);
    return img;
}

TEST(ErrorMap, SignedRelativeErrorWithFloor) {
    // Reference 2, 1, 0, 0.001, 0; solution 1, 1.5, 0, 0.101, 0.5.
    Image ref = greys({2.0, 1.0, 0.0, 0.001, 0.0});
    Image sol = greys({1.0, 1.5, 0.0, 0.101, 0.5});
    ErrorMap m = computeErrorMap(sol, ref, 0.1);
    // Shown pixels: all but #2 (both black). mean Y_r over them = 3.001 / 4.
    double floor = 0.1 * 3.001 / 4.0;
    EXPECT_NEAR(m.floor, floor, 1e-12);
    EXPECT_NEAR(m.values[0], -0.5, 1e-7);
    EXPECT_NEAR(m.values[1], 0.5, 1e-7);
    EXPECT_TRUE(std::isnan(m.values[2]));
    EXPECT_NEAR(m.values[3], 0.1 / floor, 1e-5);  // the floor, not 0.001, divides
    EXPECT_NEAR(m.values[4], 0.5 / floor, 1e-5);  // reference black, solution not
    EXPECT_EQ(m.pixels, 4u);
    double a3 = 0.1 / floor, a4 = 0.5 / floor;
    EXPECT_NEAR(m.meanAbs, (0.5 + 0.5 + a3 + a4) / 4.0, 1e-5);
    EXPECT_NEAR(m.maxAbs, a4, 1e-5);
    EXPECT_NEAR(m.p95Abs, a4, 1e-5);  // ceil(0.95 * 4) = 4th of 4 sorted values
    EXPECT_NEAR(m.l1, (1.0 + 0.5 + 0.1 + 0.5) / 3.001, 1e-12);
    EXPECT_NEAR(m.l2, std::sqrt((1.0 + 0.25 + 0.01 + 0.25) / (4.0 + 1.0 + 1e-6)), 1e-12);
}

TEST(ErrorMap, IdenticalImagesHaveZeroError) {
    Image a(8, 6);
    for (size_t i = 0; i < a.pixels.size(); ++i) a.pixels[i] = RGB(0.1 * double(i % 5), 0.3, 0.0);
    ErrorMap m = computeErrorMap(a, a);
    EXPECT_EQ(m.pixels, a.pixels.size());
    EXPECT_EQ(m.meanAbs, 0.0);
    EXPECT_EQ(m.maxAbs, 0.0);
    EXPECT_EQ(m.l1, 0.0);
    EXPECT_EQ(m.l2, 0.0);
    EXPECT_THROW(computeErrorMap(a, Image(6, 8)), Error);
}

TEST(ErrorMap, DataPngRoundTripsWithinOneStep) {
    auto dir = test::tempDir("errmap");
    ErrorMap m;
    m.width = 7;
    m.height = 3;
    const double values[7] = {-1.0, -0.25, 0.0, 1e-4, 0.3333, 1.0, 5.0};
    for (int y = 0; y < 3; ++y)
        for (double v : values) m.values.push_back(float(y == 1 ? -v : v));
    m.values[3] = NAN;
    std::string path = (dir / "error.png").string();
    writeErrorData(m, path);
    ErrorMap back = readErrorData(path);
    ASSERT_EQ(back.width, 7);
    ASSERT_EQ(back.height, 3);
    const double step = 2.0 / 65534.0;
    for (size_t i = 0; i < m.values.size(); ++i) {
        if (std::isnan(m.values[i])) {
            EXPECT_TRUE(std::isnan(back.values[i])) << i;
            continue;
        }
        double expect = std::clamp(double(m.values[i]), -1.0, 1.0);  // +-5 is clipped
        EXPECT_NEAR(back.values[i], expect, 0.5 * step + 1e-7) << i;
    }
    EXPECT_EQ(back.values[2], 0.0f);  // 0 is exactly representable (v = 32768)
    // An 8-bit colour PNG is not an error map.
    Image img(2, 2);
    writePng(img, (dir / "colour.png").string(), 1.0);
    EXPECT_THROW(readErrorData((dir / "colour.png").string()), InputError);
    EXPECT_THROW(readErrorData((dir / "missing.png").string()), InputError);
    EXPECT_THROW(writeErrorData(m, (dir / "no/such/dir/e.png").string()), InputError);
}

TEST(ErrorMap, FalseColoursAreOkabeItoDiverging) {
    using C = std::array<uint8_t, 3>;
    EXPECT_EQ(errorColour(0.0, 0.2), (C{255, 255, 255}));
    EXPECT_EQ(errorColour(-0.2, 0.2), (C{0x00, 0x72, 0xB2}));
    EXPECT_EQ(errorColour(-3.0, 0.2), (C{0x00, 0x72, 0xB2}));
    EXPECT_EQ(errorColour(0.2, 0.2), (C{0xD5, 0x5E, 0x00}));
    EXPECT_EQ(errorColour(0.1, 0.2), (C{234, 175, 128}));  // halfway: (255 + c) / 2, rounded
    EXPECT_EQ(errorColour(NAN, 0.2), (C{0x40, 0x40, 0x40}));
    auto dir = test::tempDir("errmap_fc");
    ErrorMap m = computeErrorMap(greys({1, 2}), greys({1, 1}));
    writeErrorFalseColour(m, (dir / "fc.png").string(), 0.25);
    EXPECT_TRUE(std::ifstream(dir / "fc.png").good());
}

}  // namespace
}  // namespace hrad::render
