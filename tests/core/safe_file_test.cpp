// core/safe_file.h, issue 64: outputs never written through a planted symlink
// and never left half-written; inputs only from regular files.
#include "core/safe_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/test_util.h"

namespace hrad {
namespace {

namespace fs = std::filesystem;

std::string readText(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

size_t entries(const fs::path& dir) {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
    return n;
}

TEST(SafeFile, WritesReplaceAPlantedSymlinkAndLeaveItsTargetAlone) {
    auto dir = test::tempDir("safe_symlink");
    fs::create_directories(dir / "o");
    test::writeFile(dir / "victim", "precious");
    fs::create_symlink(dir / "victim", dir / "o" / "summary.json");
    fs::create_symlink(dir / "victim", dir / "o" / "image.png");
    writeFileSafely(dir / "o" / "summary.json", "{}\n");
    writeThroughTemp(dir / "o" / "image.png", [](const fs::path& tmp) {
        std::ofstream(tmp, std::ios::binary) << "png";
    });
    EXPECT_EQ(readText(dir / "victim"), "precious");
    EXPECT_FALSE(fs::is_symlink(dir / "o" / "summary.json"));
    EXPECT_EQ(readText(dir / "o" / "summary.json"), "{}\n");
    EXPECT_EQ(readText(dir / "o" / "image.png"), "png");
    EXPECT_EQ(entries(dir / "o"), 2u);  // no temporary left behind
}

TEST(SafeFile, FailedWritesNameThePathAndKeepTheOldFile) {
    auto dir = test::tempDir("safe_fail");
    test::writeFile(dir / "out.csv", "old");
    // A writer that fails leaves the old file and no temporary.
    EXPECT_THROW(writeThroughTemp(dir / "out.csv",
                                  [&](const fs::path&) { throw IoError(dir / "out.csv", "disk full"); }),
                 IoError);
    EXPECT_EQ(readText(dir / "out.csv"), "old");
    EXPECT_EQ(entries(dir), 1u);
    // A folder where the file should go.
    fs::create_directories(dir / "folder.json");
    try {
        writeFileSafely(dir / "folder.json", "x");
        ADD_FAILURE() << "no error";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("folder.json: error: is a folder"), std::string::npos) << e.what();
    }
    // Output folders: a file, a device, an empty name; a read-only folder.
    EXPECT_THROW(ensureOutputFolder(dir / "out.csv", "-o"), IoError);
    EXPECT_THROW(ensureOutputFolder("/dev/null", "-o"), IoError);
    EXPECT_THROW(ensureOutputFolder("", "-o"), InputError);
    if (::geteuid() != 0) {  // root writes anywhere
        fs::create_directories(dir / "ro");
        fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
        EXPECT_THROW(ensureOutputFolder(dir / "ro", "-o"), IoError);
        EXPECT_THROW(writeFileSafely(dir / "ro" / "summary.json", "{}"), IoError);
        fs::permissions(dir / "ro", fs::perms::owner_all);
    }
    ensureOutputFolder(dir / "new" / "deeper", "-o");
    EXPECT_TRUE(fs::is_directory(dir / "new" / "deeper"));
    // /dev/full: the write itself fails (ENOSPC), reported with the path.
    EXPECT_THROW(writeThroughTemp(dir / "x", [](const fs::path&) {
                     std::ofstream out("/dev/full");
                     out << std::string(1 << 16, 'x');
                     out.close();
                     if (!out) throw IoError("/dev/full", "No space left on device");
                 }),
                 IoError);
}

TEST(SafeFile, OnlyRegularFilesAreInputs) {
    auto dir = test::tempDir("safe_inputs");
    ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
    fs::create_directories(dir / "folder");
    for (const fs::path& p : {dir / "fifo", fs::path("/dev/zero"), dir / "folder", dir / "none"})
        EXPECT_THROW(requireRegularFile(p, "solution file"), InputError) << p;
    test::writeFile(dir / "ok", "x");
    fs::create_symlink(dir / "ok", dir / "link");
    requireRegularFile(dir / "ok", "solution file");
    requireRegularFile(dir / "link", "solution file");  // the user named it: followed
}

TEST(SafeFile, SymlinksBelowAnOutputRootAreRefused) {
    auto dir = test::tempDir("safe_below");
    fs::create_directories(dir / "elsewhere");
    fs::create_symlink(dir / "elsewhere", dir / "runs");
    EXPECT_THROW(requireNoSymlinkBelow(dir, dir / "runs" / "study"), InputError);
    requireNoSymlinkBelow(dir, dir / "other" / "study");  // not there yet: fine
}

TEST(SafeFile, OneLockHolderAtATime) {
    auto dir = test::tempDir("safe_lock");
    test::writeFile(dir / "store.sqlite", "");
    {
        FileLock a, b;
        EXPECT_TRUE(a.tryLock(dir / "store.sqlite"));
        EXPECT_FALSE(b.tryLock(dir / "store.sqlite"));
    }
    FileLock c;
    EXPECT_TRUE(c.tryLock(dir / "store.sqlite"));
}

}  // namespace
}  // namespace hrad
