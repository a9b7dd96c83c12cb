// libFuzzer harness: solution files (reference/cache.cpp loadSolution) on the
// built-in furnace scene. The trailing FNV-1a checksum is recomputed before
// loading (when the input is long enough), so that mutations reach the checks
// behind it (keys, tiling, radiosity bounds) instead of all stopping at
// "checksum mismatch"; the checksum test itself is in tests/apps/cli_test.cpp.
#include <cstring>

#include "reference/cache.h"
#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const hrad::scene::Scene scene = hrad::scene::loadScene("furnace");
    std::string bytes(reinterpret_cast<const char*>(data), size);
    if (bytes.size() >= 16 && bytes[0] != 'x') {  // inputs starting with 'x' keep their checksum
        uint64_t h = 0xcbf29ce484222325ull;
        for (size_t i = 0; i + 8 < bytes.size(); ++i) {
            h ^= static_cast<unsigned char>(bytes[i]);
            h *= 0x100000001b3ull;
        }
        std::memcpy(&bytes[bytes.size() - 8], &h, 8);
    }
    auto path = hrad::fuzz::writeInput("a.hrsol", bytes);
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::reference::loadSolution(path.string(), scene); });
    return 0;
}
