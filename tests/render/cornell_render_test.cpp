// Rendering the built-in Cornell box with its own camera (needs scene loaders).
#include <gtest/gtest.h>

#include <algorithm>

#include "reference/fullmatrix.h"
#include "render/camera.h"
#include "render/render.h"
#include "scene/loader.h"

namespace hrad::render {
namespace {

TEST(RenderCornell, SceneCameraSeesTheLitBox) {
    scene::Scene s = scene::loadScene("cornell");
    transport::Visibility vis(s);
    reference::FullMatrixSettings st;
    st.level = 2;
    auto r = reference::solveFullMatrix(s, vis, st, false);
    RenderSettings rs;
    rs.width = rs.height = 64;
    rs.interpolate = false;  // flat first, smooth below
    Image img = renderField(s, vis, *r.field, cameraFor(s), rs);
    int lit = 0;
    for (const RGB& p : img.pixels) lit += luminance(p) > 0;
    // The published camera looks through the open front: the box fills
    // almost the whole frame.
    EXPECT_GT(lit, 64 * 64 * 8 / 10);
    // Red wall on the left of the image, green on the right (x = 0 wall).
    RGB left = img.at(3, 32), right = img.at(60, 32);
    EXPECT_GT(left.r, left.g);
    EXPECT_GT(right.g, right.r);
    // Interpolated and constant images have the same mean within a few percent.
    rs.interpolate = true;
    Image smooth = renderField(s, vis, *r.field, cameraFor(s), rs);
    double a = 0, b = 0;
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        a += luminance(img.pixels[i]);
        b += luminance(smooth.pixels[i]);
    }
    EXPECT_NEAR(b / a, 1.0, 0.05);
}

}  // namespace
}  // namespace hrad::render
