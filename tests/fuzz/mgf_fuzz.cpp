// libFuzzer harness: MGF (scene/mgf_loader.cpp). `i a.mgf` includes the input
// itself (the nesting bound stops it). mgf.max_faces is lowered to 200,000 so
// that one input stays well under libFuzzer's time limit; the bound's logic is
// the same at any value.
#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    auto path = hrad::fuzz::writeInput("a.mgf", std::string_view(reinterpret_cast<const char*>(data), size));
    hrad::Params params;
    params.set("mgf.max_faces", int64_t(200000));
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(path.string(), params); });
    return 0;
}
