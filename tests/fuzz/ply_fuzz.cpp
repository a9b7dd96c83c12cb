// libFuzzer harness: PLY, ASCII and binary (scene/ply_loader.cpp).
#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    auto path = hrad::fuzz::writeInput("a.ply", std::string_view(reinterpret_cast<const char*>(data), size));
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(path.string()); });
    return 0;
}
