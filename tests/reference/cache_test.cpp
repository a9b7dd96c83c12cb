// Reference cache: round trip, keys (settings and scene contents), damaged
// files, and the compute-or-load helpers.
#include "reference/cache.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/log.h"
#include "tests/reference/box_scenes.h"

namespace hrad::reference {
namespace {

namespace fs = std::filesystem;

/// A fresh directory under the system temp dir, removed at the end of the test.
class TempDir {
  public:
    TempDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::temp_directory_path() /
                (std::string("hrad-cache-test-") + info->name() + "-" + std::to_string(::getpid()));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    const fs::path& path() const { return path_; }

  private:
    fs::path path_;
};

bool sameBits(const std::vector<RGB>& a, const std::vector<RGB>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(RGB)) == 0;
}

/// A field with distinct, non-round values (levels 0..2 over the patches).
std::unique_ptr<scene::UniformField> testField(const scene::Scene& s) {
    std::vector<uint8_t> levels(s.patches.size());
    for (size_t p = 0; p < levels.size(); ++p) levels[p] = uint8_t(p % 3);
    auto f = std::make_unique<scene::UniformField>(s, levels);
    for (size_t i = 0; i < f->numElements(); ++i)
        f->value(i) = RGB(1.0 / (3.0 + double(i)), std::sqrt(double(i) + 0.5), -1e-300 * double(i));
    return f;
}

std::vector<RGB> testErrors(size_t n) {
    std::vector<RGB> e(n);
    for (size_t i = 0; i < n; ++i) e[i] = RGB(1e-3 / (1.0 + double(i)), 0.1, std::exp(-double(i)));
    return e;
}

TEST(ReferenceCache, SaveThenLoadIsBitwiseIdentical) {
    TempDir dir;
    scene::Scene s = test::blockerBox();
    auto field = testField(s);
    auto errors = testErrors(field->numElements());
    std::string key = referenceCacheKey(s, "test/1", "level=1");
    std::string path = (dir.path() / "sub" / "ref.bin").string();  // parent created on save
    saveReference(path, *field, &errors, key, "note=hello\n");
    auto loaded = loadReference(path, s, key);
    ASSERT_TRUE(loaded.has_value());
    ASSERT_TRUE(loaded->field);
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        EXPECT_EQ(loaded->field->level(p), field->level(p));
    EXPECT_TRUE(sameBits(loaded->field->values(), field->values()));
    ASSERT_TRUE(loaded->stdError.has_value());
    EXPECT_TRUE(sameBits(*loaded->stdError, errors));
    EXPECT_EQ(loaded->metadata, "note=hello\n");
    EXPECT_EQ(&loaded->field->scene(), &s);

    // Without standard errors.
    saveReference(path, *field, nullptr, key, "");
    loaded = loadReference(path, s, key);
    ASSERT_TRUE(loaded.has_value());
    EXPECT_FALSE(loaded->stdError.has_value());
    EXPECT_TRUE(sameBits(loaded->field->values(), field->values()));
}

// Solution files: a field whose patches are cut at mixed depths (a uniform
// level on some, an uneven quadtree on others) round-trips bitwise; its
// averages over any key and its point values equal the original's; a file
// for another scene, a damaged file and a bad tiling are clear errors.
TEST(SolutionFile, RoundTripAndErrors) {
    TempDir dir;
    scene::Scene s = test::blockerBox();
    auto uniform = testField(s);
    // Uneven cut of patch 0: three children at level 1, the fourth split again.
    std::vector<std::vector<scene::LeafField::Leaf>> leaves(s.patches.size());
    for (uint32_t p = 0; p < s.patches.size(); ++p)
        uniform->forEachLeaf(p, [&](scene::ElementKey k, const RGB& b) { leaves[p].push_back({k, b}); });
    leaves[0] = {{4, RGB(1, 2, 3)}, {5, RGB(0.5)}, {6, RGB(0.25, 0, 1)},
                 {28, RGB(7)}, {29, RGB(8)}, {30, RGB(9)}, {31, RGB(1e-9)}};
    scene::LeafField field(s, leaves);
    std::string path = (dir.path() / "run" / "solution.hrsol").string();
    saveSolution(path, field);
    auto back = loadSolution(path, s);
    ASSERT_TRUE(back);
    EXPECT_EQ(back->numLeaves(), field.numLeaves());
    for (uint32_t p = 0; p < s.patches.size(); ++p) {
        ASSERT_EQ(back->leaves(p).size(), field.leaves(p).size());
        for (size_t i = 0; i < field.leaves(p).size(); ++i) {
            EXPECT_EQ(back->leaves(p)[i].key, field.leaves(p)[i].key);
            EXPECT_EQ(std::memcmp(&back->leaves(p)[i].value, &field.leaves(p)[i].value, sizeof(RGB)), 0);
        }
    }
    // Averages: a leaf, a key below a leaf, the interior node 7 and the root.
    EXPECT_EQ(back->average(0, 4), RGB(1, 2, 3));
    EXPECT_EQ(back->average(0, 17), RGB(1, 2, 3));  // 17 = 4 * 4 + 1: inside leaf 4
    EXPECT_EQ(back->average(0, 21), RGB(0.5));      // 21 = 5 * 4 + 1: inside leaf 5
    const scene::Patch& p0 = s.patches[0];
    auto area = [&](scene::ElementKey k) { return scene::elementArea(p0, scene::keyDomain(p0.kind, k)); };
    RGB in7 = (RGB(7) * area(28) + RGB(8) * area(29) + RGB(9) * area(30) + RGB(1e-9) * area(31)) /
              (area(28) + area(29) + area(30) + area(31));
    RGB a7 = back->average(0, 7);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a7[c], in7[c], 1e-12 * (1 + std::abs(in7[c])));
    RGB root = (RGB(1, 2, 3) * area(4) + RGB(0.5) * area(5) + RGB(0.25, 0, 1) * area(6) + in7 * area(7)) /
               p0.area;
    RGB a1 = back->average(0, 1);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a1[c], root[c], 1e-12 * (1 + std::abs(root[c])));
    EXPECT_NEAR(luminance(back->totalPower()), luminance(field.totalPower()), 1e-12 * luminance(field.totalPower()));
    // Point values agree with the uniform field on patches that kept its leaves.
    for (uint32_t p = 1; p < s.patches.size(); ++p)
        for (double u : {0.1, 0.37, 0.8})
            for (double v : {0.05, 0.5}) {
                if (s.patches[p].kind == scene::PatchKind::Quad || u + v < 1) {
                    EXPECT_EQ(back->at(p, u, v), uniform->at(p, u, v)) << p << " " << u << " " << v;
                }
            }

    // Another scene: a clear error naming the file.
    scene::Scene other = test::furnaceBox();
    try {
        loadSolution(path, other);
        FAIL() << "expected an error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("another scene"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("solution.hrsol"), std::string::npos) << e.what();
    }
    // Damaged: one flipped byte in the body, and a truncated file.
    std::string bytes;
    {
        std::ifstream in(path, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    std::string flipped = bytes;
    flipped[flipped.size() / 2] ^= 0x10;
    std::ofstream((dir.path() / "flipped.hrsol").string(), std::ios::binary) << flipped;
    EXPECT_THROW(loadSolution((dir.path() / "flipped.hrsol").string(), s), InputError);
    std::ofstream((dir.path() / "short.hrsol").string(), std::ios::binary) << bytes.substr(0, bytes.size() - 9);
    EXPECT_THROW(loadSolution((dir.path() / "short.hrsol").string(), s), InputError);
    EXPECT_THROW(loadSolution((dir.path() / "missing.hrsol").string(), s), InputError);
    // Leaves that do not tile a patch.
    auto bad = leaves;
    bad[0].pop_back();  // a hole
    EXPECT_THROW(scene::LeafField(s, bad), Error);
    bad = leaves;
    bad[0].push_back({1, RGB(0)});  // the root over its own leaves
    EXPECT_THROW(scene::LeafField(s, bad), Error);
}

TEST(ReferenceCache, KeyDependsOnSettingsKindAndSceneContents) {
    TempDir dir;
    scene::Scene s = test::blockerBox();
    auto field = testField(s);
    const std::string key = referenceCacheKey(s, "test/1", "level=1 samples=256");
    EXPECT_EQ(key.size(), 32u);
    EXPECT_EQ(key, referenceCacheKey(test::blockerBox(), "test/1", "level=1 samples=256"));
    std::string path = (dir.path() / "ref.bin").string();
    saveReference(path, *field, nullptr, key, "");

    // Different settings or kind: different key, and the stored file is a miss.
    std::string otherSettings = referenceCacheKey(s, "test/1", "level=1 samples=512");
    std::string otherKind = referenceCacheKey(s, "test/2", "level=1 samples=256");
    EXPECT_NE(otherSettings, key);
    EXPECT_NE(otherKind, key);
    EXPECT_FALSE(loadReference(path, s, otherSettings).has_value());
    EXPECT_FALSE(loadReference(path, s, otherKind).has_value());

    // Moving one vertex of one patch (by one ulp-ish step) changes the scene hash.
    scene::Scene moved = test::blockerBox();
    moved.patches[7].v[2].x += 1e-9;
    EXPECT_NE(sceneContentHash(moved), sceneContentHash(s));
    std::string movedKey = referenceCacheKey(moved, "test/1", "level=1 samples=256");
    EXPECT_NE(movedKey, key);
    EXPECT_FALSE(loadReference(path, moved, movedKey).has_value());
    // So does a material change (reflectance or emission of one patch).
    scene::Scene recoloured = test::blockerBox();
    recoloured.patches[0].rho.g += 0.01;
    EXPECT_NE(sceneContentHash(recoloured), sceneContentHash(s));
    scene::Scene brighter = test::blockerBox();
    brighter.patches[9].emission.r *= 2.0;
    EXPECT_NE(sceneContentHash(brighter), sceneContentHash(s));
    // The name is not content.
    scene::Scene renamed = test::blockerBox();
    renamed.name = "elsewhere";
    EXPECT_EQ(sceneContentHash(renamed), sceneContentHash(s));

    // A missing file is a miss.
    EXPECT_FALSE(loadReference((dir.path() / "none.bin").string(), s, key).has_value());
    // The right key on a scene with a different patch count is a miss, not a crash.
    scene::Scene furnace = test::furnaceBox();
    EXPECT_FALSE(loadReference(path, furnace, key).has_value());
}

TEST(ReferenceCache, DamagedFilesAreMissesNotCrashes) {
    TempDir dir;
    scene::Scene s = test::blockerBox();
    auto field = testField(s);
    auto errors = testErrors(field->numElements());
    std::string key = referenceCacheKey(s, "test/1", "x");
    fs::path good = dir.path() / "good.bin";
    saveReference(good.string(), *field, &errors, key, "meta=1\n");
    std::string bytes;
    {
        std::ifstream in(good, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    ASSERT_GT(bytes.size(), 100u);
    // Each damaged file below logs a warning by design; keep the output short.
    auto level = spdlog::default_logger()->level();
    spdlog::set_level(spdlog::level::err);
    auto writeAndLoad = [&](const std::string& content) {
        fs::path p = dir.path() / "bad.bin";
        std::ofstream(p, std::ios::binary | std::ios::trunc)
            .write(content.data(), std::streamsize(content.size()));
        return loadReference(p.string(), s, key).has_value();
    };
    // Truncated at every length in the header and at a few in the data.
    for (size_t len = 0; len < 200 && len < bytes.size(); ++len)
        EXPECT_FALSE(writeAndLoad(bytes.substr(0, len))) << "truncated to " << len;
    for (size_t len : {bytes.size() / 2, bytes.size() - 9, bytes.size() - 1})
        EXPECT_FALSE(writeAndLoad(bytes.substr(0, len))) << "truncated to " << len;
    // Trailing garbage, one flipped bit in the values, a wrong magic.
    EXPECT_FALSE(writeAndLoad(bytes + "x"));
    std::string flipped = bytes;
    flipped[bytes.size() - 100] ^= 0x10;
    EXPECT_FALSE(writeAndLoad(flipped));
    std::string magic = bytes;
    magic[0] = 'X';
    EXPECT_FALSE(writeAndLoad(magic));
    // An absurd element count in a header with a valid key is rejected before
    // any allocation (the size check): overwrite the level of patch 0.
    // Layout: magic 8, version 4, key (4 + 32), metadata (4 + 7), count 8.
    std::string bigLevel = bytes;
    size_t levelsAt = 8 + 4 + 4 + key.size() + 4 + 7 + 8;
    ASSERT_EQ(uint8_t(bigLevel[levelsAt]), field->level(0));
    bigLevel[levelsAt] = char(15);
    EXPECT_FALSE(writeAndLoad(bigLevel));
    bigLevel[levelsAt] = char(200);
    EXPECT_FALSE(writeAndLoad(bigLevel));
    // The intact file still loads.
    EXPECT_TRUE(writeAndLoad(bytes));
    spdlog::set_level(level);
}

TEST(ReferenceCache, CachedMonteCarloComputesOnceThenLoads) {
    TempDir dir;
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    MonteCarloSettings st;
    st.level = 1;
    st.samples = 32;
    bool hit = true;
    MonteCarloResult first = cachedMonteCarlo(s, vis, st, dir.path(), &hit, false);
    EXPECT_FALSE(hit);
    MonteCarloResult second = cachedMonteCarlo(s, vis, st, dir.path(), &hit, false);
    EXPECT_TRUE(hit);
    EXPECT_TRUE(sameBits(first.field->values(), second.field->values()));
    EXPECT_TRUE(sameBits(first.stdError, second.stdError));
    EXPECT_EQ(second.stats.paths, first.stats.paths);
    EXPECT_EQ(second.stats.rays, first.stats.rays);
    EXPECT_EQ(second.stats.rounds, 1);
    // Other settings: a miss.
    st.seed = 2;
    cachedMonteCarlo(s, vis, st, dir.path(), &hit, false);
    EXPECT_FALSE(hit);
}

TEST(ReferenceCache, CachedFullMatrixComputesOnceThenLoads) {
    TempDir dir;
    scene::Scene s = test::furnaceBox();
    transport::Visibility vis(s);
    FullMatrixSettings st;
    st.level = 1;
    bool hit = true;
    FullMatrixResult first = cachedFullMatrix(s, vis, st, dir.path(), &hit, false);
    EXPECT_FALSE(hit);
    ASSERT_TRUE(first.stats.converged);
    FullMatrixResult second = cachedFullMatrix(s, vis, st, dir.path(), &hit, false);
    EXPECT_TRUE(hit);
    EXPECT_TRUE(sameBits(first.field->values(), second.field->values()));
    EXPECT_EQ(second.stats.elements, first.stats.elements);
    EXPECT_EQ(second.stats.formFactors, first.stats.formFactors);
    EXPECT_EQ(second.stats.iterations, first.stats.iterations);
    // A modified scene (one vertex moved) is a miss.
    scene::Scene moved = test::furnaceBox();
    moved.patches[0].v[0].x -= 1e-6;
    transport::Visibility vis2(moved);
    cachedFullMatrix(moved, vis2, st, dir.path(), &hit, false);
    EXPECT_FALSE(hit);
}

TEST(ReferenceCache, DefaultCacheDirFollowsEnvironment) {
    const char* old = std::getenv("HRAD_CACHE");
    std::string saved = old ? old : "";
    ::setenv("HRAD_CACHE", "/tmp/hrad-cache-env-test", 1);
    EXPECT_EQ(defaultCacheDir(), fs::path("/tmp/hrad-cache-env-test"));
    ::setenv("HRAD_CACHE", "", 1);
    if (const char* home = std::getenv("HOME"); home && *home) {
        EXPECT_EQ(defaultCacheDir(), fs::path(home) / ".cache" / "hrad");
    }
    if (old)
        ::setenv("HRAD_CACHE", saved.c_str(), 1);
    else
        ::unsetenv("HRAD_CACHE");
}

}  // namespace
}  // namespace hrad::reference
