// libFuzzer harness: OBJ with its MTL (scene/obj_loader.cpp). The input is the
// OBJ text, optionally followed by a line "#--mtl--" and the text of m.mtl,
// which the OBJ can name with `mtllib m.mtl`.
#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string_view in(reinterpret_cast<const char*>(data), size);
    static constexpr std::string_view kSplit = "#--mtl--\n";
    size_t cut = in.find(kSplit);
    std::string_view obj = in.substr(0, cut);
    std::string_view mtl = cut == std::string_view::npos ? std::string_view() : in.substr(cut + kSplit.size());
    auto path = hrad::fuzz::writeInput("a.obj", obj);
    hrad::fuzz::writeInput("m.mtl", mtl);
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(path.string()); });
    return 0;
}
