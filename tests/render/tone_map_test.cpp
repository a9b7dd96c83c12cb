// The tone map shared by the PNG, PLY and glTF outputs (render/image.h):
// automatic exposure from the log-average luminance (Reinhard et al. 2002)
// with a bounded clipped share, and the two curves.
#include <gtest/gtest.h>

#include <random>

#include "core/params.h"
#include "render/image.h"

namespace hrad::render {
namespace {

TEST(ToneMap, LogAverageMapsToTheKey) {
    std::vector<RGB> v(100, RGB(2.0));
    v.push_back(RGB(0.0));  // black values do not count
    ToneMap t = ToneSettings{}.choose(v);
    EXPECT_NEAR(t.exposure, 0.18 / 2.0, 1e-12);
    EXPECT_EQ(clippedShare(v, t), 0.0);
}

TEST(ToneMap, ClippedShareStaysUnderTheBound) {
    // A room at about 1 with lamps at 200 on 6 % of the pixels: the key
    // alone would clip the lamps, and the old 99th-percentile / median rule
    // clipped all of them. Both curves keep clipping under max_clipped.
    std::mt19937 rng(3);
    std::lognormal_distribution<double> room(0.0, 0.8);
    std::vector<RGB> v;
    for (int i = 0; i < 10000; ++i) v.push_back(i % 100 < 6 ? RGB(200.0) : RGB(room(rng), room(rng), room(rng)));
    for (ToneCurve c : {ToneCurve::Clip, ToneCurve::Reinhard}) {
        ToneSettings ts;
        ts.curve = c;
        ToneMap t = ts.choose(v);
        EXPECT_LE(clippedShare(v, t, {}, true), ts.maxClipped + 1e-12);
        for (const RGB& x : v) {
            RGB d = t.display(x);
            EXPECT_TRUE(d.r >= 0 && d.r <= 1 && d.g >= 0 && d.g <= 1 && d.b >= 0 && d.b <= 1);
        }
    }
    ToneSettings fixed;
    fixed.exposure = 1.0;  // a fixed exposure is kept, whatever clips
    EXPECT_EQ(fixed.choose(v).exposure, 1.0);
}

TEST(ToneMap, ReinhardIsMonotoneAndReachesWhite) {
    ToneMap t;
    t.curve = ToneCurve::Reinhard;
    t.white = 4.0;
    double last = -1.0;
    for (double l = 0.01; l < 4.0; l *= 1.3) {
        double d = luminance(t.display(RGB(l)));
        EXPECT_GT(d, last);
        last = d;
    }
    EXPECT_NEAR(luminance(t.display(RGB(4.0))), 1.0, 1e-12);
    EXPECT_TRUE(t.clips(RGB(4.5)));
    EXPECT_FALSE(t.clips(RGB(3.5)));
}

TEST(ToneMap, SettingsAreRead) {
    Params p;
    p.set("render.tone_curve", std::string("reinhard"));
    p.set("render.exposure", 2.0);
    p.set("render.max_clipped", 0.005);
    ToneSettings s = ToneSettings::fromParams(p);
    EXPECT_EQ(s.curve, ToneCurve::Reinhard);
    EXPECT_EQ(s.exposure, 2.0);
    EXPECT_EQ(s.maxClipped, 0.005);
    Params bad;
    bad.set("render.tone_curve", std::string("filmic"));
    EXPECT_THROW(ToneSettings::fromParams(bad), InputError);
}

}  // namespace
}  // namespace hrad::render
