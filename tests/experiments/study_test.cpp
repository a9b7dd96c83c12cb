// Study files: expansion of products and zips, and validation errors that
// name the study file and line.
#include <gtest/gtest.h>

#include <set>

#include <fmt/format.h>

#include "experiments/study.h"
#include "tests/test_util.h"

namespace hrad::experiments {
namespace {

Study parse(const std::string& text) { return parseStudy(text, "study.toml", "."); }

/// The InputError message of validating (or parsing) `text`, "" if none.
std::string errorOf(const std::string& text, const std::filesystem::path& base = ".") {
    try {
        Study s = parseStudy(text, "study.toml", base);
        validateStudy(s);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(Study, ProductOfAxesTimesScenes) {
    Study s = parse(R"(
scenes = ["furnace", "cornell"]
[solver]
"hr.max_iterations" = 5
[sweep]
"oracle.eps" = [0.1, 0.01, 0.001]
"ff.vis_rays" = [4, 16]
)");
    ASSERT_EQ(s.pointCount(), 2u * 3u * 2u);
    // Scene-major, then axes in file order, last fastest.
    EXPECT_EQ(s.point(0).sceneLabel, "furnace");
    EXPECT_EQ(s.point(6).sceneLabel, "cornell");
    EXPECT_DOUBLE_EQ(s.point(0).settings.getDouble("oracle.eps", 0), 0.1);
    EXPECT_EQ(s.point(0).settings.getInt("ff.vis_rays", 0), 4);
    EXPECT_EQ(s.point(1).settings.getInt("ff.vis_rays", 0), 16);
    EXPECT_DOUBLE_EQ(s.point(1).settings.getDouble("oracle.eps", 0), 0.1);
    EXPECT_DOUBLE_EQ(s.point(5).settings.getDouble("oracle.eps", 0), 0.001);
    EXPECT_EQ(s.point(11).settings.getInt("hr.max_iterations", 0), 5);
    // All (scene, eps, rays) combinations are distinct points with distinct keys.
    std::set<std::string> keys;
    for (const auto& p : s.points()) keys.insert(pointKey(p));
    EXPECT_EQ(keys.size(), s.pointCount());
    EXPECT_EQ(s.point(3).index, 3u);
}

TEST(Study, ZipGroupsVaryTogetherAndCrossWithSweep) {
    Study s = parse(R"(
scenes = ["furnace"]
[sweep]
"ff.vis_rays" = [4, 8]
[[zip]]
"hr.oracle" = ["bfa", "ff", "uniform"]
oracle = { level = [1, 2, 3] }
[[zip]]
"hr.max_level" = [3, 4]
"hr.min_iterations" = [1, 2]
)");
    // 2 (sweep) x 3 (first zip) x 2 (second zip)
    ASSERT_EQ(s.pointCount(), 12u);
    for (const auto& p : s.points()) {
        std::string o = p.settings.getString("hr.oracle", "");
        int64_t level = p.settings.getInt("oracle.level", 0);
        EXPECT_EQ(level, o == "bfa" ? 1 : o == "ff" ? 2 : 3) << o;
        EXPECT_EQ(p.settings.getInt("hr.min_iterations", 0), p.settings.getInt("hr.max_level", 0) - 2);
    }
    EXPECT_EQ(s.point(0).varying.size(), 5u);
}

TEST(Study, NestedTablesFlattenAndReferenceKeysSeparate) {
    Study s = parse(R"(
scenes = "furnace"
[solver.hr]
oracle = "ff"
[solver.oracle]
eps = 0.05
[reference]
kind = "full-matrix"
fm.level = 1
[sweep]
"reference.fm.tolerance" = [1e-5, 1e-6]
)");
    ASSERT_EQ(s.pointCount(), 2u);
    EXPECT_EQ(s.point(0).settings.getString("hr.oracle", ""), "ff");
    EXPECT_DOUBLE_EQ(s.point(0).settings.getDouble("oracle.eps", 0), 0.05);
    EXPECT_EQ(s.point(0).reference.getInt("fm.level", 0), 1);
    EXPECT_DOUBLE_EQ(s.point(1).reference.getDouble("fm.tolerance", 0), 1e-6);
    EXPECT_FALSE(s.point(1).settings.has("reference.fm.tolerance"));
    validateStudy(s);
}

TEST(StudyValidation, UnknownSettingNamesFileAndLine) {
    std::string msg = errorOf("scenes = [\"furnace\"]\n[solver]\n\"hr.orcale\" = \"bfa\"\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("hr.orcale"), std::string::npos) << msg;
}

TEST(StudyValidation, UnknownKeyInSweepPointsAtItsValue) {
    std::string msg = errorOf(
        "scenes = [\"furnace\"]\n[sweep]\n\"oracle.eps\" = [0.1,\n  0.2]\n\"ff.vis_ray\" = [1]\n");
    EXPECT_NE(msg.find("study.toml:5"), std::string::npos) << msg;
    EXPECT_NE(msg.find("ff.vis_ray"), std::string::npos) << msg;
}

TEST(StudyValidation, BadOracleNameListsValidNames) {
    std::string msg = errorOf("scenes = [\"furnace\"]\n\n[sweep]\n\"hr.oracle\" = [\"bfa\", \"nope\"]\n");
    EXPECT_NE(msg.find("study.toml:4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("nope"), std::string::npos) << msg;
    EXPECT_NE(msg.find("bfa"), std::string::npos) << msg;
    EXPECT_NE(msg.find("point 1"), std::string::npos) << msg;
}

TEST(StudyValidation, OutOfRangeEps) {
    std::string msg = errorOf("scenes = [\"furnace\"]\n[solver]\n\"oracle.eps\" = 2.5\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("out of range"), std::string::npos) << msg;
}

TEST(StudyValidation, SettingOfAnotherOracleIsUnknown) {
    // uniform reads oracle.level, not oracle.eps: the zip makes one bad point.
    std::string msg = errorOf(
        "scenes = [\"furnace\"]\n[solver]\n\"oracle.eps\" = 0.1\n[sweep]\n\"hr.oracle\" = [\"bfa\", \"uniform\"]\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("eps"), std::string::npos) << msg;
}

TEST(StudyValidation, ErrorMapNeedsAReference) {
    std::string msg = errorOf("scenes = [\"furnace\"]\n[outputs]\nexr = true\nerror_map = true\n");
    EXPECT_NE(msg.find("study.toml:4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("reference"), std::string::npos) << msg;
    msg = errorOf("scenes = [\"furnace\"]\n[outputs]\nerror_maps = true\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("error_map,"), std::string::npos) << msg;  // the list of valid keys
    msg = errorOf("scenes = [\"furnace\"]\n[solver]\n\"render.error_mode\" = \"pixel\"\n"
                  "[reference]\nkind = \"full-matrix\"\n[outputs]\nerror_map = true\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("regions"), std::string::npos) << msg;
}

TEST(StudyValidation, MissingSceneFile) {
    auto dir = test::tempDir("study_missing_scene");
    std::string msg = errorOf("name = \"x\"\nscenes = [\"furnace\",\n  \"nothere/box.obj\"]\n", dir);
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("not found"), std::string::npos) << msg;
}

TEST(StudyValidation, RelativeSceneResolvesAgainstStudyFolder) {
    auto dir = test::tempDir("study_relative_scene");
    test::writeFile(dir / "scenes" / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    test::writeFile(dir / "studies" / "s.toml", "scenes = [\"../scenes/tri.obj\"]\n");
    Study s = loadStudy(dir / "studies" / "s.toml");
    ASSERT_EQ(s.pointCount(), 1u);
    EXPECT_EQ(std::filesystem::path(s.point(0).scene), (dir / "scenes" / "tri.obj").lexically_normal());
    EXPECT_EQ(s.point(0).sceneLabel, "../scenes/tri.obj");
    EXPECT_EQ(s.name, "s");
}

TEST(StudyValidation, UnknownTopLevelKeyAndBadReferenceKind) {
    std::string msg = errorOf("scenes = [\"furnace\"]\nsolvr = 1\n");
    EXPECT_NE(msg.find("study.toml:2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("solvr"), std::string::npos) << msg;
    msg = errorOf("scenes = [\"furnace\"]\n[reference]\nkind = \"exact\"\n");
    EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << msg;
    msg = errorOf("scenes = [\"furnace\"]\n[reference]\nkind = \"montecarlo\"\n\"fm.level\" = 2\n");
    EXPECT_NE(msg.find("study.toml:4"), std::string::npos) << msg;
}

TEST(StudyValidation, ZipOfUnequalLengthsAndKeysSetTwice) {
    std::string msg = errorOf(
        "scenes = [\"furnace\"]\n[[zip]]\n\"oracle.eps\" = [0.1, 0.2]\n\"hr.max_level\" = [1, 2, 3]\n");
    EXPECT_NE(msg.find("study.toml:4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("equal lengths"), std::string::npos) << msg;
    msg = errorOf("scenes = [\"furnace\"]\n[solver]\n\"oracle.eps\" = 0.1\n[sweep]\n\"oracle.eps\" = [0.1]\n");
    EXPECT_NE(msg.find("study.toml:5"), std::string::npos) << msg;
    EXPECT_NE(msg.find("twice"), std::string::npos) << msg;
}

// Issue 16: a table header of 100,000 parts crashed toml++ (stack overflow,
// exit 139); at 20,000 parts flatten() overflowed under ASan. Both are now
// refused with the line before parsing; so is deep nesting of values.
TEST(StudyValidation, DeepKeysAndNestingAreRefusedWithTheLine) {
    for (int parts : {100000, 20000, 65}) {
        std::string header = "[solver";
        for (int i = 0; i < parts; ++i) header += ".a";
        std::string msg = errorOf("scenes = [\"furnace\"]\n# deep\n" + header + "]\nx = 1\n");
        EXPECT_NE(msg.find("study.toml:3: error: key or table header deeper than 64"), std::string::npos)
            << parts << ": " << msg.substr(0, 200);
    }
    std::string dotted = "scenes = [\"furnace\"]\n[solver]\n";
    for (int i = 0; i < 100; ++i) dotted += "a.";
    EXPECT_NE(errorOf(dotted + "b = 1\n").find("study.toml:3: error: key"), std::string::npos);
    std::string nested = "scenes = [\"furnace\"]\n[sweep]\n\"hr.eps\" = " + std::string(100, '[') +
                         std::string(100, ']') + "\n";
    EXPECT_NE(errorOf(nested).find("study.toml:3: error: arrays and inline tables nest"), std::string::npos)
        << errorOf(nested);
    // Dots inside strings and numbers do not count; 60 levels is still fine.
    std::string fine = "scenes = [\"furnace\"]  # a.b.c\n[solver]\n\"hr.eps\" = 0.01\n"
                       "# " + std::string(200, '.') + "\n[limits]\n";
    EXPECT_EQ(errorOf(fine + "x = '" + std::string(200, '.') + "'\n").find("deeper"), std::string::npos);
    std::string sixty = "[solver";
    for (int i = 0; i < 60; ++i) sixty += ".a";
    EXPECT_EQ(errorOf("scenes = [\"furnace\"]\n" + sixty + "]\nx = 1\n").find("deeper"), std::string::npos);
}

TEST(StudyValidation, TomlSyntaxErrorHasLine) {
    std::string msg = errorOf("scenes = [\"furnace\"]\n[solver\n");
    EXPECT_NE(msg.find("study.toml:2"), std::string::npos) << msg;
}

}  // namespace
}  // namespace hrad::experiments

namespace hrad::experiments {
namespace {

TEST(Study, SceneEntriesOverrideBaseSettings) {
    Study s = parse(R"(
scenes = ["furnace", { scene = "cornell", reference = { "fm.level" = 3 }, solver = { "oracle.eps" = 0.5 } }]
[solver]
"oracle.eps" = 0.1
[reference]
kind = "full-matrix"
"fm.level" = 1
[sweep]
"ff.vis_rays" = [4, 8]
)");
    ASSERT_EQ(s.pointCount(), 4u);
    EXPECT_EQ(s.point(0).reference.getInt("fm.level", 0), 1);
    EXPECT_EQ(s.point(2).reference.getInt("fm.level", 0), 3);
    EXPECT_DOUBLE_EQ(s.point(3).settings.getDouble("oracle.eps", 0), 0.5);
    EXPECT_EQ(s.point(3).settings.where("oracle.eps").line, 2);
    validateStudy(s);
}

}  // namespace
}  // namespace hrad::experiments

namespace hrad::experiments {
namespace {

std::string axesStudy(int axes, int values, const std::string& extra = "") {
    std::string t = "scenes = [\"furnace\"]\n" + extra + "[sweep]\n";
    for (int a = 0; a < axes; ++a) {
        t += fmt::format("\"hr.k{}\" = [", a);
        for (int v = 0; v < values; ++v) t += fmt::format("{}{}", v ? ", " : "", v);
        t += "]\n";
    }
    return t;
}

// Issue 16: 9 axes x 10 values (10^9 points) used to be expanded in memory
// (7 GB, then bad_alloc); 64 axes x 2 values wrapped the count to 0 and
// validated nothing. Both are refused with the count, without expanding.
TEST(StudyLimits, TooManyPointsAreRefusedWithTheCount) {
    Study big = parse(axesStudy(9, 10));
    EXPECT_EQ(big.pointCount(), 1000000000u);
    std::string msg = errorOf(axesStudy(9, 10));
    EXPECT_NE(msg.find("study.toml:1:10: error: study 'study' expands to 1000000000 points (1 scene(s) x 10 x 10"),
              std::string::npos) << msg;
    EXPECT_NE(msg.find("sweep.max_points = 1000000 (the default)"), std::string::npos) << msg;
    Study wrap = parse(axesStudy(64, 2));
    EXPECT_EQ(wrap.pointCount(), UINT64_MAX);
    msg = errorOf(axesStudy(64, 2));
    EXPECT_NE(msg.find("more than 1.8e19 points"), std::string::npos) << msg;
    // A setting in the study lowers (or raises) the bound, and is named.
    msg = errorOf(axesStudy(2, 3, "[limits]\nmax_points = 8\n"));
    EXPECT_NE(msg.find("expands to 9 points"), std::string::npos) << msg;
    EXPECT_NE(msg.find("sweep.max_points = 8 (set at study.toml:3"), std::string::npos) << msg;
    EXPECT_THROW(describePoints(parse(axesStudy(2, 3, "[limits]\nmax_points = 8\n"))), InputError);
    // Points are built on demand and agree with the order of the axes.
    Study small = parse(axesStudy(2, 3));
    EXPECT_EQ(small.pointCount(), 9u);
    EXPECT_EQ(small.point(5).settings.getInt("hr.k0", -1), 1);
    EXPECT_EQ(small.point(5).settings.getInt("hr.k1", -1), 2);
    EXPECT_EQ(small.points().size(), 9u);
}

// Issue 16: a study name of "../../escaped" wrote artefacts outside the store's folder.
TEST(StudyPaths, NamesAndOutputFoldersStayInside) {
    for (const char* name : {"../../escaped", "a/b", "..", "/abs", "x\\\\y", ""}) {
        std::string msg = errorOf(fmt::format("name = \"{}\"\nscenes = [\"furnace\"]\n", name));
        EXPECT_NE(msg.find("study.toml:1"), std::string::npos) << name << ": " << msg;
    }
    EXPECT_EQ(errorOf("name = \"oracles-v2.1_b\"\nscenes = [\"furnace\"]\n"), "");
    for (const char* dir : {"../out", "/tmp/out", "a/../../out", ""}) {
        std::string msg = errorOf(fmt::format("scenes = [\"furnace\"]\n[outputs]\ndir = \"{}\"\n", dir));
        EXPECT_NE(msg.find("study.toml:3"), std::string::npos) << dir << ": " << msg;
    }
    EXPECT_EQ(errorOf("scenes = [\"furnace\"]\n[outputs]\ndir = \"runs/a/../b\"\n"), "");
    // Found by the study fuzzer: a scene name too long for the system threw
    // std::filesystem_error instead of an input error.
    std::string msg = errorOf("scenes = [\"" + std::string(5000, 'a') + ".obj\"]\n");
    EXPECT_NE(msg.find("study.toml:1"), std::string::npos) << msg.substr(0, 100);
    EXPECT_NE(msg.find("not found"), std::string::npos) << msg.substr(0, 100);
}

}  // namespace
}  // namespace hrad::experiments
