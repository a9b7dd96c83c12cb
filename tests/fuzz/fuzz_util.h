// Shared helpers of the libFuzzer harnesses (tests/fuzz/README.md).
//
// The loaders read files, so each input is written to a file in a private
// temporary folder (removed at exit). An input may only end in
// hrad::InputError: any other exception, a crash, a sanitizer report, a hang
// or an oversized allocation is a finding (libFuzzer stops and saves it).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "core/error.h"

namespace hrad::fuzz {

/// The harness's temporary folder, created on first use and removed at exit.
inline const std::filesystem::path& workDir() {
    static const std::filesystem::path dir = [] {
        std::string tmpl = (std::filesystem::temp_directory_path() / "hrad_fuzz_XXXXXX").string();
        if (!mkdtemp(tmpl.data())) std::abort();
        std::atexit([] {
            std::error_code ec;
            std::filesystem::remove_all(workDir(), ec);
        });
        return std::filesystem::path(tmpl);
    }();
    return dir;
}

inline std::filesystem::path writeInput(const std::string& name, std::string_view bytes) {
    std::filesystem::path p = workDir() / name;
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    return p;
}

/// Runs `body`; InputError is the expected outcome of bad input, anything
/// else aborts so that libFuzzer records the input.
template <typename F>
void expectOnlyInputErrors(F&& body) {
    try {
        body();
    } catch (const InputError&) {
    } catch (const std::exception& e) {
        std::fprintf(stderr, "hrad fuzz: unexpected exception: %s\n", e.what());
        std::abort();
    }
}

}  // namespace hrad::fuzz
