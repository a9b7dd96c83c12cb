// libFuzzer harness: TOML studies (experiments/study.cpp): parsing, the
// point count, and validation of studies of up to 64 points (validating a
// larger one is the same code point after point).
#include "experiments/study.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string text(reinterpret_cast<const char*>(data), size);
    hrad::fuzz::expectOnlyInputErrors([&] {
        hrad::experiments::Study s = hrad::experiments::parseStudy(text, "fuzz.toml", hrad::fuzz::workDir());
        if (s.pointCount() <= 64) hrad::experiments::validateStudy(s);
    });
    return 0;
}
