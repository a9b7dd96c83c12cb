// Loads the real scenes of ../shared/scenes (skipped when absent).
#include <gtest/gtest.h>

#include <iostream>

#include "scene/loader.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

// Top-level RenderPark scenes; the other .mgf files are includes (hospital/*,
// Materials/* libraries) or have no emitter (examp1 and floor_gloss are MGF
// spec examples).
const char* kMgfScenes[] = {
    "renderpark-mgf/cube.mgf",           "renderpark-mgf/corridor.mgf",
    "renderpark-mgf/office2/office2.mgf", "renderpark-mgf/office3/office.mgf",
    "renderpark-mgf/salon/classroom.mgf", "renderpark-mgf/office1/graz.mgf",
    "renderpark-mgf/hospital/hosp.mgf",   "renderpark-mgf/soda.mgf",
};

void report(const Scene& s, const std::string& rel) {
    std::cout << "[scene] " << rel << ": " << s.patches.size() << " patches ("
              << s.count(PatchKind::Quad) << " quads, " << s.count(PatchKind::Triangle)
              << " triangles), " << s.stats.inputFaces << " input faces, "
              << s.stats.triangulatedFaces << " triangulated, " << s.stats.droppedDegenerate
              << " degenerate dropped, " << s.numEmitters() << " emitters, " << s.materials.size()
              << " materials, " << s.stats.warnings.size() << " warnings, loaded in "
              << s.stats.loadSeconds << " s\n";
    ::testing::Test::RecordProperty(rel + ".patches", std::to_string(s.patches.size()));
    ::testing::Test::RecordProperty(rel + ".seconds", std::to_string(s.stats.loadSeconds));
}

TEST(SharedScenes, RenderParkMgfScenesLoad) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes absent";
    for (const char* rel : kMgfScenes) {
        SCOPED_TRACE(rel);
        Scene s;
        ASSERT_NO_THROW(s = loadScene((*dir / rel).string())) << rel;
        report(s, rel);
        EXPECT_GT(s.patches.size(), 0u);
        EXPECT_GT(s.numEmitters(), 0u);
        EXPECT_GT(s.totalArea(), 0.0);
    }
}

TEST(SharedScenes, CornellBoxObjLoads) {
    auto dir = test::sharedScenesDir();
    if (!dir) GTEST_SKIP() << "../shared/scenes absent";
    const std::string rel = "cornell-box/CornellBox-Original.obj";
    Scene s = loadScene((*dir / rel).string());
    report(s, rel);
    EXPECT_EQ(s.stats.inputFaces, 18u);  // 18 `f` lines (the README counts 36 triangles)
    EXPECT_EQ(s.numEmitters() > 0, true);
    EXPECT_EQ(s.stats.defaultMaterialFaces, 0u);
}

}  // namespace
}  // namespace hrad::scene
