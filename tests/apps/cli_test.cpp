// End-to-end tests of the `hrad` command: bad input gives one clear message
// naming the file and line and a non-zero exit; a good solve writes its
// artefacts and a summary with the documented fields.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "tests/test_util.h"

namespace {
struct Result {
    int code;
    std::string output;
};

Result run(const std::string& args) {
    std::string cmd = std::string(HRAD_BINARY) + " --log quiet " + args + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    std::string out;
    std::array<char, 4096> buf;
    while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
    int status = pclose(p);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}
}  // namespace

TEST(Cli, MalformedSceneFilesNameFileAndLine) {
    auto dir = hrad::test::tempDir("cli");
    struct Case {
        std::string name, text, expect;
    } cases[] = {
        {"nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "nan.obj:3"},
        {"badnum.mgf", "m light =\n  ed 10\nv a =\n  p 0 0 0\nv b =\n  p 1 x 0\n", "badnum.mgf:6"},
        {"missing.mgf", "m light =\n  ed 10\nf a b c\n", "missing.mgf:3"},
        {"rho.obj", "mtllib rho.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl bright\nf 1 2 3\n", "rho.mtl:1"},
        {"dark.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "no emitter"},
    };
    hrad::test::writeFile(dir / "rho.mtl", "newmtl bright\nKd 1.2 0.5 0.5\nKe 1 1 1\n");
    for (const auto& c : cases) {
        auto path = hrad::test::writeFile(dir / c.name, c.text);
        Result r = run("info " + path.string());
        EXPECT_EQ(r.code, 2) << c.name << ": " << r.output;
        EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.name << ": " << r.output;
        EXPECT_NE(r.output.find("error"), std::string::npos) << r.output;
    }
}

TEST(Cli, UnknownSettingsAndNamesAreErrors) {
    Result r = run("--set oracle.epsilon=1e-3 solve cornell -o /tmp/hrad_cli_unused");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("oracle.epsilon"), std::string::npos) << r.output;
    r = run("solve cornell --oracle nope -o /tmp/hrad_cli_unused");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("bfa"), std::string::npos) << r.output;
    r = run("solve cornell --eps -3 -o /tmp/hrad_cli_unused");
    EXPECT_NE(r.code, 0) << r.output;
    r = run("solve cornell --cluster spherical -o /tmp/hrad_cli_unused");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("oriented"), std::string::npos) << r.output;
    r = run("info nosuchscene.obj");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("nosuchscene.obj"), std::string::npos) << r.output;
}

TEST(Cli, SolveWritesArtefactsAndSummary) {
    auto dir = hrad::test::tempDir("cli_solve");
    Result r = run("solve cornell --eps 1e-2 --cluster oriented --width 64 --height 64 -o " +
                   dir.string());
    ASSERT_EQ(r.code, 0) << r.output;
    for (const char* f : {"image.exr", "image.png", "solution.ply", "summary.json"})
        EXPECT_GT(std::filesystem::file_size(dir / f), 100u) << f;
    nlohmann::json s;
    std::ifstream(dir / "summary.json") >> s;
    for (const char* k : {"settings", "counts", "timings", "memory", "history", "scene_info"})
        EXPECT_TRUE(s.contains(k)) << k;
    EXPECT_GT(s["counts"]["links"].get<double>(), 0);
    EXPECT_GT(s["memory"]["peak_rss"].get<double>(), 0);
    EXPECT_EQ(s["settings"]["cluster.model"], "oriented");
}

TEST(Cli, ErrorMapNeedsReferenceLevelAndWritesMaps) {
    auto dir = hrad::test::tempDir("cli_errmap");
    Result bad = run("solve cornell --error-map --no-progress -o " + dir.string());
    EXPECT_EQ(bad.code, 2) << bad.output;
    EXPECT_NE(bad.output.find("--error-map"), std::string::npos) << bad.output;
    EXPECT_NE(bad.output.find("--reference-level"), std::string::npos) << bad.output;
    Result r = run("solve cornell --eps 1e-2 --reference-level 1 --error-map --no-ply "
                   "--no-progress --width 32 --height 32 -o " + dir.string());
    ASSERT_EQ(r.code, 0) << r.output;
    for (const char* f : {"reference.png", "error.png", "error_fc.png"})
        EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
    nlohmann::json s;
    std::ifstream(dir / "summary.json") >> s;
    EXPECT_GT(s["error_map"]["mean_abs"].get<double>(), 0.0);
    // Pixels that see a surface: most of the frame (the box's open front and
    // the edges beyond it are black in both renders and carry no error).
    EXPECT_GT(s["error_map"]["pixels"].get<int>(), 32 * 32 / 2);
    EXPECT_LE(s["error_map"]["pixels"].get<int>(), 32 * 32);
}

TEST(Cli, ExplicitCameraIsUsedAndRecorded) {
    auto dir = hrad::test::tempDir("cli_camera");
    Result r = run("--set render.eye=278,273,-400 --set render.target=278,100,0 solve cornell "
                   "--eps 1e-2 --no-ply --no-progress --width 32 --height 32 -o " + dir.string());
    ASSERT_EQ(r.code, 0) << r.output;
    nlohmann::json s;
    std::ifstream(dir / "summary.json") >> s;
    EXPECT_EQ(s["camera"]["explicit"], true);
    EXPECT_EQ(s["camera"]["eye"][2].get<double>(), -400.0);
    EXPECT_EQ(s["camera"]["target"][1].get<double>(), 100.0);
    Result bad = run("--set render.fov=30 solve cornell --no-progress -o " + dir.string());
    EXPECT_EQ(bad.code, 2) << bad.output;
    EXPECT_NE(bad.output.find("render.fov"), std::string::npos) << bad.output;
}

static std::string fileBytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// hrad render: the saved solution rendered with the solve's settings gives
// the very same image; another camera works; a solution of another scene is
// refused with exit 2.
TEST(Cli, RenderASavedSolution) {
    auto dir = hrad::test::tempDir("cli_render");
    Result r = run("solve cornell --eps 1e-2 --no-ply --no-progress --width 40 --height 30 -o " +
                   (dir / "solve").string());
    ASSERT_EQ(r.code, 0) << r.output;
    ASSERT_TRUE(std::filesystem::exists(dir / "solve" / "solution.hrsol"));
    Result again = run("render cornell " + (dir / "solve" / "solution.hrsol").string() +
                       " --width 40 --height 30 -o " + (dir / "again").string());
    ASSERT_EQ(again.code, 0) << again.output;
    EXPECT_EQ(fileBytes(dir / "again" / "image.exr"), fileBytes(dir / "solve" / "image.exr"));
    EXPECT_EQ(fileBytes(dir / "again" / "image.png"), fileBytes(dir / "solve" / "image.png"));
    Result moved = run("--set render.eye=100,450,-300 --set render.target=350,150,300 render cornell " +
                       (dir / "solve" / "solution.hrsol").string() + " --width 40 --height 30 -o " +
                       (dir / "moved").string());
    ASSERT_EQ(moved.code, 0) << moved.output;
    EXPECT_NE(fileBytes(dir / "moved" / "image.exr"), fileBytes(dir / "solve" / "image.exr"));
    Result wrong = run("render furnace " + (dir / "solve" / "solution.hrsol").string() + " -o " +
                       (dir / "wrong").string());
    EXPECT_EQ(wrong.code, 2) << wrong.output;
    EXPECT_NE(wrong.output.find("another scene"), std::string::npos) << wrong.output;
    Result none = run("solve cornell --eps 1e-2 --no-ply --no-images --no-solution --no-progress -o " +
                      (dir / "nosol").string());
    ASSERT_EQ(none.code, 0) << none.output;
    EXPECT_FALSE(std::filesystem::exists(dir / "nosol" / "solution.hrsol"));
}

// Issue 16: a malformed command line is an input error (exit 2), not CLI11's own codes (104/105).
// Global options are accepted after the subcommand too.
TEST(Cli, GlobalOptionsAfterTheSubcommand) {
    Result r = run("info furnace --threads 1 --log quiet --set obj.default_rho=0.5");
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("patches"), std::string::npos) << r.output;
    // And still checked there.
    EXPECT_EQ(run("info furnace --threads -1").code, 2);
}

TEST(Cli, MalformedArgumentsExitTwo) {
    for (const char* args : {"solve cornell --eps abc -o /tmp/hrad_cli_unused",
                             "--threads -1 solve cornell -o /tmp/hrad_cli_unused", "--nosuchflag info cornell"}) {
        Result r = run(args);
        EXPECT_EQ(r.code, 2) << args << ": " << r.output;
    }
    EXPECT_EQ(run("--help").code, 0);
}

// Stores that are not hrad's or are corrupt: exit 2 and one sentence naming
// the file, no SQL (issue 16 item 6); a missing input refuses before the
// output of a merge is created.
TEST(Cli, ForeignAndCorruptStoresExitTwo) {
    auto dir = hrad::test::tempDir("cli_stores");
    std::string text = (dir / "notes.sqlite").string();
    { std::ofstream(text) << "just some notes\n"; }
    Result r = run("results export " + text + " --csv " + (dir / "csv").string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(text + ": error: not an hrad results store"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("SELECT"), std::string::npos) << r.output;
    std::string out = (dir / "merged.sqlite").string();
    r = run("results merge " + out + " " + text);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out));
    r = run("results merge " + out + " " + (dir / "absent.sqlite").string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("no such results store"), std::string::npos) << r.output;
}
