// Issue 64, the file system and signals, end to end through the `hrad`
// binary: a file system that is really full or really read-only (a small
// tmpfs mounted in a private mount namespace, `unshare -m`, so that it
// vanishes with the shell; skipped where mounting is not allowed, e.g. not
// root), and SIGINT/SIGTERM during every solver kind and the references.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "tests/test_util.h"

namespace {

namespace fs = std::filesystem;

struct Result {
    int code;
    std::string output;
};

Result shell(const std::string& cmd) {
    FILE* p = popen(cmd.c_str(), "r");
    std::string out;
    std::array<char, 4096> buf;
    while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
    int status = pclose(p);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

const std::string kHrad = std::string(HRAD_BINARY) + " --log quiet";

/// Runs `script` (sh) with a tmpfs of `size` mounted on `mountPoint` in a
/// private mount namespace; nullopt-like code -1 with a reason when the
/// machine does not allow it.
Result inTmpfs(const fs::path& mountPoint, const std::string& size, const std::string& script) {
    fs::create_directories(mountPoint);
    const std::string full = "mount -t tmpfs -o size=" + size + " tmpfs '" + mountPoint.string() + "' || exit 99\n" + script;
    std::ofstream(mountPoint.parent_path() / "script.sh") << full;
    return shell("unshare -m --propagation private sh '" + (mountPoint.parent_path() / "script.sh").string() +
                 "' 2>&1");
}

bool canMount(const fs::path& dir) {
    return inTmpfs(dir / "probe", "64k", "true").code == 0;
}

/// "rc=N" lines of a script's output, in order.
std::vector<int> codes(const std::string& out) {
    std::vector<int> c;
    for (size_t at = out.find("rc="); at != std::string::npos; at = out.find("rc=", at + 3))
        c.push_back(std::stoi(out.substr(at + 3)));
    return c;
}

const char* kStudy = R"(
name = "full"
scenes = ["furnace"]
[solver]
"hr.max_iterations" = 4
[outputs]
dir = "runs"
solution = true
[sweep]
"oracle.eps" = [0.5, 0.1]
)";

// Disk full: artefacts of a sweep (kind io, rerun by --resume), results
// export (exit 2 naming the path, no 0-byte CSV left), solve -o, and a full
// reference cache (says so, names no file that does not exist).
TEST(HostileIo, FullFileSystemIsAnIoErrorNamingThePath) {
    auto dir = hrad::test::tempDir("hostile_full");
    if (!canMount(dir)) GTEST_SKIP() << "cannot mount a tmpfs here (needs root and unshare)";
    hrad::test::writeFile(dir / "study.toml", kStudy);
    const std::string d = dir.string(), t = (dir / "runs").string();
    // First a store with rows (on the normal disk), written without a mount.
    Result first = shell(kHrad + " sweep " + d + "/study.toml --store " + d + "/ok.sqlite 2>&1; echo rc=$?");
    ASSERT_EQ(codes(first.output), std::vector<int>{0}) << first.output;
    Result r = inTmpfs(dir / "runs", "256k",
                       "dd if=/dev/zero of=" + t + "/fill bs=4k 2>/dev/null\n" +
                       kHrad + " sweep " + d + "/study.toml --store " + d + "/s.sqlite; echo rc=$?\n"
                       "sqlite3 " + d + "/s.sqlite 'SELECT kind FROM failures' | sort -u | sed 's/^/kind=/'\n" +
                       kHrad + " results export " + d + "/ok.sqlite --csv " + t + "/csv; echo rc=$?\n"
                       "find " + t + "/csv -type f -size 0 | sed 's/^/empty=/'\n" +
                       kHrad + " solve furnace --no-progress -o " + t + "/o; echo rc=$?\n" +
                       kHrad + " --set fm.level=1 reference furnace --no-progress --cache " + t + "/cache; echo rc=$?\n"
                       "rm " + t + "/fill\n" +
                       kHrad + " sweep " + d + "/study.toml --store " + d + "/s.sqlite --resume; echo rc=$?\n"
                       "sqlite3 " + d + "/s.sqlite 'SELECT count(*) FROM runs' | sed 's/^/runs=/'\n");
    ASSERT_NE(r.code, 99) << r.output;
    const std::vector<int> want{3, 2, 2, 0, 0};
    EXPECT_EQ(codes(r.output), want) << r.output;
    EXPECT_NE(r.output.find("kind=io"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("kind=input"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(t + "/csv"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("empty="), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(t + "/o"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("cache file: none, the cache " + t + "/cache could not be written"),
              std::string::npos) << r.output;
    EXPECT_NE(r.output.find("runs=2"), std::string::npos) << r.output;
}

// Read-only output folders, store folders and reference caches, which root
// (the CI's user) writes through permission bits: a read-only mount stops it.
TEST(HostileIo, ReadOnlyFileSystemExitsTwo) {
    auto dir = hrad::test::tempDir("hostile_ro");
    if (!canMount(dir)) GTEST_SKIP() << "cannot mount a tmpfs here (needs root and unshare)";
    hrad::test::writeFile(dir / "study.toml", kStudy);
    const std::string d = dir.string(), t = (dir / "ro").string();
    Result r = inTmpfs(dir / "ro", "256k",
                       "mkdir " + t + "/o " + t + "/cache && mount -o remount,ro " + t + " || exit 98\n" +
                       kHrad + " solve furnace --no-progress -o " + t + "/o; echo rc=$?\n" +
                       kHrad + " solve furnace --no-progress -o " + t + "/new; echo rc=$?\n" +
                       kHrad + " sweep " + d + "/study.toml --store " + t + "/s.sqlite; echo rc=$?\n" +
                       kHrad + " --set fm.level=1 reference furnace --no-progress --cache " + t + "/cache; echo rc=$?\n");
    ASSERT_NE(r.code, 99) << r.output;
    ASSERT_NE(r.code, 98) << r.output;
    EXPECT_EQ(codes(r.output), (std::vector<int>{2, 2, 2, 0})) << r.output;
    EXPECT_NE(r.output.find(t + "/o"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("corrupt"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("cache file: none, the cache " + t + "/cache could not be written"),
              std::string::npos) << r.output;
}

// SIGINT/SIGTERM stop every solver kind at a safe point (core/stop.h): what
// was computed is written, marked interrupted, exit 128 + signal; an
// interrupted reference is reported and not cached. Each run would take
// minutes without the signal, which comes after 2 s. The full-matrix
// iterations are stopped in tests/reference/interrupt_test.cpp (a signal
// cannot be timed to land after the matrix).
TEST(HostileIo, EverySolverStopsOnASignalAndMarksItsResult) {
    auto dir = hrad::test::tempDir("hostile_signal");
    struct Case {
        std::string name, args, sig;
        int code;
        std::string warning;
    } cases[] = {
        {"fm_matrix", "solve cornell --solver full-matrix --set fm.level=6", "INT", 130, "form-factor matrix stops"},
        {"progressive", "solve cornell --solver progressive --set pr.level=4 --set pr.tolerance=1e-12", "TERM", 143,
         "progressive solution so far"},
        {"hr_linking", "solve office:8 --cluster none", "INT", 130, "during initial linking"},
        {"hr", "solve cornell --eps 1e-7", "TERM", 143, "signal 15"},
        {"mc_reference", "--set mc.samples=1000000 reference cornell --kind montecarlo", "INT", 130,
         "Monte Carlo reference stops"},
        {"fm_reference", "--set fm.level=6 reference cornell --kind full-matrix", "TERM", 143,
         "form-factor matrix stops"},
    };
    for (const Case& c : cases) {
        const fs::path out = dir / c.name;
        const bool solve = c.args.rfind("solve", 0) == 0;
        const std::string args = c.args + " --no-progress" +
                                 (solve ? " --no-images --no-ply -o " + out.string()
                                        : " --cache " + (dir / (c.name + "_cache")).string());
        Result r = shell(std::string(HRAD_BINARY) + " --log info " + args + " >" + out.string() +
                         ".log 2>&1 & pid=$!; sleep 2; kill -" + c.sig + " $pid; wait $pid; echo rc=$?; cat " +
                         out.string() + ".log");
        EXPECT_EQ(codes(r.output).empty() ? -1 : codes(r.output).front(), c.code) << c.name << ": " << r.output;
        EXPECT_NE(r.output.find(c.warning), std::string::npos) << c.name << ": " << r.output;
        if (solve) {
            std::ifstream in(out / "summary.json");
            nlohmann::json s = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
            EXPECT_EQ(s.value("interrupted", false), true) << c.name;
            EXPECT_EQ(s.value("converged", true), false) << c.name;
            EXPECT_TRUE(fs::exists(out / "solution.hrsol")) << c.name;
        } else {
            EXPECT_NE(r.output.find("not cached (interrupted: true)"), std::string::npos) << c.name << ": " << r.output;
            std::error_code ec;
            EXPECT_TRUE(!fs::exists(dir / (c.name + "_cache"), ec) || fs::is_empty(dir / (c.name + "_cache"), ec))
                << c.name;
        }
    }
}

// A signal while `solve --reference` computes its reference (sent once the
// solve and its error estimate are done, the log says so): the summary says the error was skipped and why, and holds no
// error block; an error against the estimated regions alone read 0 with a
// mean ratio of 1.0000 (NaN regions skipped), a silent zero.
TEST(HostileIo, AReferenceInterruptedInASolveReportsNoError) {
    auto dir = hrad::test::tempDir("hostile_solve_ref");
    const fs::path out = dir / "o";
    Result r = shell(std::string(HRAD_BINARY) + " --log info solve cornell --no-progress --no-images --no-ply " +
                     "--reference montecarlo --set mc.level=0 --set mc.samples=999999 --cache " +
                     (dir / "cache").string() + " -o " + out.string() + " >" + out.string() +
                     ".log 2>&1 & pid=$!; for i in $(seq 240); do grep -q 'error estimate (residual)' " + out.string() +
                     ".log && break; sleep 0.5; done; sleep 1; kill -INT $pid; wait $pid; echo rc=$?; cat " +
                     out.string() + ".log");
    EXPECT_EQ(codes(r.output).empty() ? -1 : codes(r.output).front(), 130) << r.output;
    EXPECT_NE(r.output.find("interrupted while computing the reference"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("mean ratio 1.0000"), std::string::npos) << r.output;
    std::ifstream in(out / "summary.json");
    nlohmann::json s = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(s.is_object()) << r.output;
    EXPECT_EQ(s.value("interrupted", false), true);
    EXPECT_TRUE(s.contains("error") && s["error"].is_null());
    EXPECT_NE(s.value("error_skipped", std::string()).find("regions estimated"), std::string::npos);
}

}  // namespace
