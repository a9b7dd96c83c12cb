// loadScene dispatch and settings (scene/loader.h).
#include "scene/loader.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "tests/test_util.h"

namespace hrad::scene {
namespace {

TEST(Loader, UnknownExtensionIsAnInputErrorNamingTheFile) {
    auto dir = test::tempDir("loader_ext");
    auto path = test::writeFile(dir / "scene.xyz", "hello\n");
    try {
        loadScene(path.string());
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos);
        EXPECT_NE(std::string(e.what()).find(".xyz"), std::string::npos);
    }
}

TEST(Loader, ReadsEveryKeyEvenWhenNotApplicable) {
    Params p;
    p.set("mgf.resolution", int64_t(8));
    p.set("obj.default_rho", 0.3);
    p.set("ply.emission", 2.0);
    p.set("validate", true);
    Scene s = loadScene("furnace", p);
    EXPECT_TRUE(p.unusedKeys().empty());
    EXPECT_NO_THROW(p.reportUnused());
    EXPECT_GE(s.stats.loadSeconds, 0.0);
    EXPECT_EQ(s.name, "furnace");
    Params bad;
    bad.set("mgf.resolution", int64_t(1));
    EXPECT_THROW(loadScene("furnace", bad), InputError);
}

TEST(Loader, OverlongPathIsAnInputError) {
    std::string name = std::string(5000, 'a') + ".obj";
    EXPECT_THROW(loadScene(name), InputError);
    auto dir = test::tempDir("loader_mgf_long");
    auto path = test::writeFile(dir / "l.mgf", "i " + std::string(5000, 'b') + ".mgf\n");
    EXPECT_THROW(loadScene(path.string()), InputError);
}

TEST(Loader, ValidateFalseSkipsTheEmitterCheck) {
    Params p;
    p.set("validate", false);
    Scene s = loadScene("furnace:0.5:0", p);
    EXPECT_EQ(s.numEmitters(), 0u);
    EXPECT_THROW(loadScene("furnace:0.5:0"), InputError);
}

TEST(Loader, SplitIntersectionsIsASetting) {
    // office:N:T's furniture meshes pass through one another (legs through
    // seats); split_intersections cuts them, keeping area and emission.
    Params off;
    Scene whole = loadScene("office:1:1", off);
    EXPECT_EQ(whole.stats.splitPatches, 0u);
    Params on;
    on.set("split_intersections", true);
    Scene cut = loadScene("office:1:1", on);
    EXPECT_GT(cut.stats.splitPatches, 0u);
    EXPECT_EQ(cut.patches.size(),
              whole.patches.size() - cut.stats.splitPatches + cut.stats.splitPieces);
    EXPECT_NEAR(cut.totalArea() / whole.totalArea(), 1.0, 1e-9);
    EXPECT_NEAR(cut.emittedPower().g / whole.emittedPower().g, 1.0, 1e-9);
}

TEST(Loader, UniformRhoIsASetting) {
    Params p;
    p.set("uniform_rho", 0.3);
    Scene s = loadScene("office:1", p);
    Scene plain = loadScene("office:1", Params{});
    ASSERT_EQ(s.patches.size(), plain.patches.size());
    for (const Patch& q : s.patches) EXPECT_EQ(q.rho, RGB(0.3));
    for (const Material& m : s.materials) EXPECT_EQ(m.rho, RGB(0.3));
    EXPECT_NEAR(s.emittedPower().g, plain.emittedPower().g, 1e-12 * plain.emittedPower().g);
    Params bad;
    bad.set("uniform_rho", 1.0);
    EXPECT_THROW(loadScene("office:1", bad), InputError);
}

}  // namespace
}  // namespace hrad::scene
