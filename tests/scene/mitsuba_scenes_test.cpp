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
    // The issue asks for equal patch counts and emitted power within 1 %. They
    // are not equal, and hrad loads both correctly: the two scenes hold
    // different data (measured with `hrad info` on both, 2026-11-23).
    //
    // Patches: 17 (built-in) against 32 (Mitsuba). The Mitsuba meshes
    //   - split every block face into two triangles and close each block
    //     with a bottom face on the floor: 2 blocks x 6 faces x 2 = 24
    //     triangles against the built-in's 2 x 5 = 10 quads;
    //   - give cbox_ceiling.obj a second quad, the light's 130 x 105 mm
    //     rectangle facing up (+y, out of the box), besides the full ceiling:
    //     the ceiling is 2 patches against 1.
    //   Both have the light, floor, back and green wall as one quad each and
    //   the non-planar red wall as two triangles. Merging coplanar triangle
    //   pairs would still give 20, not 17: the 2 bottoms and the ceiling's
    //   extra quad are geometry the built-in box does not have.
    EXPECT_EQ(builtin.patches.size(), 17u);
    EXPECT_EQ(rgb.patches.size(), 32u);
    EXPECT_EQ(spectral.patches.size(), 32u);
    EXPECT_EQ(builtin.stats.triangulatedFaces, 1u);  // the red wall, in both
    EXPECT_EQ(rgb.stats.triangulatedFaces, 1u);
    // Area: the Mitsuba box has exactly those three extra faces more: block
    // bottoms 27,633 + 27,626.5 mm^2 (shoelace on the published corners) and
    // the 13,650 mm^2 light-sized ceiling quad, 68,909.5 mm^2 in all.
    EXPECT_NEAR(rgb.totalArea() - builtin.totalArea(), 27633.0 + 27626.5 + 13650.0, 1.0);
    // Emitted power: the built-in box uses Cardenas & McGuire's Ke = (17, 12,
    // 4) of CornellBox-Original.mtl as radiosity E (W/m^2 per unit area, as
    // hrad's OBJ loader reads Ke); Mitsuba's cbox-rgb.xml a radiance L =
    // (18.387, 10.9873, 2.75357), i.e. E = pi L = (57.76, 34.52, 8.65), on the
    // same 13,650 mm^2 light. Per channel the Mitsuba light emits pi L / Ke =
    // 3.40, 2.88, 2.16 times the built-in's power: a different light, redder
    // (R/B 6.7 against 4.25), not a unit slip (reading Ke as radiance would
    // give ratios 1.08, 0.92, 0.69, still not within 1 %).
    // The Mitsuba power is exactly pi L A on the same area.
    const RGB L(18.387, 10.9873, 2.75357);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(rgb.emittedPower()[c], kPi * L[c] * emitterArea(builtin), 1e-9 * rgb.emittedPower()[c]);
        EXPECT_NEAR(builtin.emittedPower()[c], RGB(17, 12, 4)[c] * emitterArea(builtin), 1e-9 * builtin.emittedPower()[c]);
    }
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
