// Helpers shared by the test binaries.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

namespace hrad::test {

/// ../shared/scenes (or $HRAD_SCENES) when it exists.
inline std::optional<std::filesystem::path> sharedScenesDir() {
    if (const char* env = std::getenv("HRAD_SCENES")) {
        std::filesystem::path p(env);
        if (std::filesystem::is_directory(p)) return p;
        return std::nullopt;
    }
    std::filesystem::path p(HRAD_SCENES_DEFAULT);
    if (std::filesystem::is_directory(p)) return p;
    return std::nullopt;
}

/// A fresh temporary directory for one test, removed with everything in it
/// when the object goes out of scope (tests leave nothing behind). It is a
/// path, so it is used like one; it cannot be copied (a copy would remove the
/// directory early).
class TempDir : public std::filesystem::path {
  public:
    explicit TempDir(std::filesystem::path p) : std::filesystem::path(std::move(p)) {}
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(*this, ec);
    }
};

inline TempDir tempDir(const std::string& name) {
    auto dir = std::filesystem::temp_directory_path() / ("hrad_test_" + name + "_" +
                                                         std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return TempDir(dir);
}

inline std::filesystem::path writeFile(const std::filesystem::path& path, const std::string& text) {
    std::filesystem::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << text;
    return path;
}

}  // namespace hrad::test

#include <unistd.h>
