// Validation of the .glb files the tests write with the Khronos glTF
// validator (issue 60): scripts/validate_gltf.js runs the npm package
// `gltf-validator` (installed by scripts/setup.sh). A test that writes a .glb
// calls HRAD_EXPECT_VALID_GLTF(path) before its temporary directory goes;
// where node or the package is missing the check is skipped with a message
// (once per binary) and the test goes on.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <memory>
#include <string>
#include <sys/wait.h>

namespace hrad::test {

/// Runs the validator on `path`: its output and exit status (77: unavailable).
inline std::pair<int, std::string> runGltfValidator(const std::string& path) {
    std::string cmd = std::string("node '") + HRAD_SOURCE_DIR + "/scripts/validate_gltf.js' '" + path +
                      "' 2>&1";
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(::popen(cmd.c_str(), "r"), ::pclose);
    if (!pipe) return {77, "cannot start node"};
    std::string out;
    std::array<char, 512> buf;
    while (size_t n = std::fread(buf.data(), 1, buf.size(), pipe.get())) out.append(buf.data(), n);
    int status = ::pclose(pipe.release());
    int code = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
    if (code == 127) return {77, "node is not installed: " + out};
    return {code, out};
}

/// 0 errors and 0 warnings from the validator, or a skip message.
inline ::testing::AssertionResult validGltf(const std::string& path) {
    auto [code, out] = runGltfValidator(path);
    if (code == 77) {
        static bool told = false;
        if (!told) std::printf("[ SKIPPED ] glTF validation: %s\n", out.c_str());
        told = true;
        return ::testing::AssertionSuccess();
    }
    if (code == 0) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "gltf-validator on " << path << ":\n" << out;
}

}  // namespace hrad::test

#define HRAD_EXPECT_VALID_GLTF(path) EXPECT_TRUE(::hrad::test::validGltf(path))
