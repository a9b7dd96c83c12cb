// libFuzzer harness: Mitsuba XML (scene/mitsuba_loader.cpp) and .serialized
// meshes (scene/mitsuba_serialized.cpp). The input up to a line
// `<!--serialized-->` is the scene a.xml; the bytes after it are m.serialized,
// which the scene may name (seeds do). mitsuba.max_faces = 200,000 bounds
// what a valid input may ask to build.
#include <string_view>

#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string_view in(reinterpret_cast<const char*>(data), size);
    constexpr std::string_view kMarker = "<!--serialized-->\n";
    size_t cut = in.find(kMarker);
    std::string_view xml = cut == std::string_view::npos ? in : in.substr(0, cut);
    std::string_view mesh = cut == std::string_view::npos ? std::string_view() : in.substr(cut + kMarker.size());
    auto path = hrad::fuzz::writeInput("a.xml", xml);
    hrad::fuzz::writeInput("m.serialized", mesh);
    hrad::Params params;
    params.set("mitsuba.max_faces", int64_t(200000));
    params.set("validate", false);
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(path.string(), params); });
    return 0;
}
