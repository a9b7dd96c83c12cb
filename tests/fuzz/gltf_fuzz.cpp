// libFuzzer harness: glTF 2.0 (scene/gltf_loader.cpp). An input that starts
// with the GLB magic "glTF" is written as a.glb, anything else as a.gltf (the
// loader goes by the container's magic either way). A buffer or image URI may
// name a.gltf / a.glb itself. gltf.max_faces is lowered to 200,000 so that one
// input stays well under libFuzzer's time limit. tinygltf itself comes from
// Debian's shared library and is not instrumented: the harness finds what
// hrad's validation lets through, and ASan still sees heap misuse via malloc.
#include <cstring>

#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    auto path = hrad::fuzz::writeInput(glb ? "a.glb" : "a.gltf",
                                       std::string_view(reinterpret_cast<const char*>(data), size));
    hrad::Params params;
    params.set("gltf.max_faces", int64_t(200000));
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(path.string(), params); });
    return 0;
}
