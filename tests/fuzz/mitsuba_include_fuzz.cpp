// libFuzzer harness: Mitsuba XML across included files (scene/mitsuba_loader.cpp
// <include>, its nesting and fan-out budgets). The input is cut at lines
// `<!--file-->` into a.xml, b.xml, c.xml and d.xml (the rest empty); a.xml is
// loaded, and any may include any other or itself (seeds do).
// mitsuba.max_faces = 200,000.
#include <string>
#include <string_view>

#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string_view in(reinterpret_cast<const char*>(data), size);
    constexpr std::string_view kMarker = "<!--file-->\n";
    const char* names[4] = {"a.xml", "b.xml", "c.xml", "d.xml"};
    std::filesystem::path top;
    for (int k = 0; k < 4; ++k) {
        size_t cut = in.find(kMarker);
        std::string_view part = k == 3 || cut == std::string_view::npos ? in : in.substr(0, cut);
        auto p = hrad::fuzz::writeInput(names[k], part);
        if (k == 0) top = p;
        in = cut == std::string_view::npos || k == 3 ? std::string_view() : in.substr(cut + kMarker.size());
    }
    hrad::Params params;
    params.set("mitsuba.max_faces", int64_t(200000));
    params.set("validate", false);
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(top.string(), params); });
    return 0;
}
