// The Mitsuba XML scenes of ../shared/scenes (skipped when absent): the
// bathroom, the modern hall and the Mitsuba Cornell box against `cornell`.
#include <cmath>
#include <iostream>
#include <numbers>

#include <gtest/gtest.h>

#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

constexpr double kPi = std::numbers::pi;

double emitterArea(const Scene& s) {
    double a = 0;
    for (const Patch& p : s.patches)
        if (p.isEmitter()) a += p.area;
    return a;
}

TEST(MitsubaScenes, CornellBoxAgreesWithBuiltin) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes absent";
    Scene builtin = loadScene("cornell");
    Scene rgb = loadScene((*dir / "cornell-box-mitsuba/cbox-rgb.xml").string());
    Scene spectral = loadScene((*dir / "cornell-box-mitsuba/cbox.xml").string());
    std::cout << "[cornell] builtin " << builtin.patches.size() << " patches, mitsuba " << rgb.patches.size()
              << " patches; power builtin (" << builtin.emittedPower().r << ", " << builtin.emittedPower().g << ", "
              << builtin.emittedPower().b << "), cbox-rgb (" << rgb.emittedPower().r << ", " << rgb.emittedPower().g
              << ", " << rgb.emittedPower().b << "), cbox (" << spectral.emittedPower().r << ", "
              << spectral.emittedPower().g << ", " << spectral.emittedPower().b << ")\n";
    // Same measured geometry: bounds and the light's area agree within 1 %.
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(rgb.bounds().lo[k], builtin.bounds().lo[k], 0.01 * builtin.bounds().diagonal());
        EXPECT_NEAR(rgb.bounds().hi[k], builtin.bounds().hi[k], 0.01 * builtin.bounds().diagonal());
    }
    EXPECT_NEAR(emitterArea(rgb), emitterArea(builtin), 0.01 * emitterArea(builtin));
    EXPECT_NEAR(emitterArea(spectral), emitterArea(builtin), 0.01 * emitterArea(builtin));
    // Patch counts differ for a measured reason, not within 1 %: the Mitsuba
    // meshes split every block face into two triangles and close the blocks
    // with bottom faces (2 x 6 x 2 = 24 block triangles against 10 quads),
    // and split the floor, ceiling and red wall into triangles.
    EXPECT_EQ(builtin.patches.size(), 17u);
    EXPECT_EQ(rgb.patches.size(), 32u);
    // Emitted power differs for a measured reason too: the built-in box uses
    // Cardenas & McGuire's Ke = (17, 12, 4) as radiosity, Mitsuba's cbox a
    // radiance L = (18.387, 10.9873, 2.75357), i.e. E = pi L. Power is exactly
    // pi L A on the same area.
    const RGB L(18.387, 10.9873, 2.75357);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(rgb.emittedPower()[c], kPi * L[c] * emitterArea(builtin), 1e-9 * rgb.emittedPower()[c]);
    // The spectral file's radiance spectrum and the RGB file agree in G and B
    // within 1.5 %; R differs by 12 % (Mitsuba's own conversion of that
    // spectrum is not reproduced by a CIE 1931 integration: see the loader).
    EXPECT_NEAR(spectral.emittedPower().g, rgb.emittedPower().g, 0.015 * rgb.emittedPower().g);
    EXPECT_NEAR(spectral.emittedPower().b, rgb.emittedPower().b, 0.015 * rgb.emittedPower().b);
    ASSERT_TRUE(rgb.camera.has_value());
    ASSERT_TRUE(builtin.camera.has_value());
    EXPECT_NEAR(rgb.camera->fovYDegrees, builtin.camera->fovYDegrees, 0.01);
    EXPECT_NEAR(glm::length(rgb.camera->eye - builtin.camera->eye), 0.0, 1e-9);
}

TEST(MitsubaScenes, ModernHallLoadsItsThirteenLights) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes absent";
    Scene s = loadScene((*dir / "modern-hall/staircase2/scene.xml").string());
    size_t emitterMaterials = 0;
    for (const Material& m : s.materials) emitterMaterials += m.isEmitter();
    EXPECT_EQ(emitterMaterials, 13u);  // 5 disks + 8 rectangles, one material each
    EXPECT_GT(s.patches.size(), 30000u);
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.upAxis, 1);
    std::cout << "[scene] modern hall: " << s.patches.size() << " patches, " << s.numEmitters() << " emitters, "
              << s.stats.warnings.size() << " warnings, " << s.stats.loadSeconds << " s\n";
}

TEST(MitsubaScenes, BathroomLoads) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes absent";
    Scene s = loadScene((*dir / "bathroom/scene.present.xml").string());
    // 380,290 triangles in the collector's count, less the glass bulbs
    // (thindielectric: not added) and degenerate faces; two-sided materials
    // double the patches.
    EXPECT_GT(s.stats.inputFaces, 350000u);
    EXPECT_EQ(s.numEmitters(), 1u);  // one rectangle light, front side only
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_NEAR(s.camera->fovYDegrees, 2 * std::atan(std::tan(35 * kPi / 180) * 720 / 1280) * 180 / kPi, 1e-9);
    std::cout << "[scene] bathroom: " << s.patches.size() << " patches, " << s.stats.inputFaces << " input faces, "
              << s.stats.warnings.size() << " warnings, " << s.stats.loadSeconds << " s\n";
}

}  // namespace
}  // namespace hrad::scene
