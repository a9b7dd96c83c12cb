// libFuzzer harness: the GLB container (glTF 2.0 §4.4, scene/gltf_loader.cpp).
// gltf_fuzz reads GLB only when a mutation keeps the magic and three
// consistent lengths; here the harness writes the container: the input up to
// a line `--bin--` is the JSON chunk, the rest the BIN chunk, each padded to
// 4 bytes and given its length. An input starting with 'R' is the file
// itself, raw, for the container's own checks. gltf.max_faces = 200,000.
#include <cstring>
#include <string>
#include <string_view>

#include "scene/loader.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

void put32(std::string& s, uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); }

std::string container(std::string_view in) {
    constexpr std::string_view kMarker = "--bin--\n";
    size_t cut = in.find(kMarker);
    std::string json(in.substr(0, cut));
    std::string bin = cut == std::string_view::npos ? std::string() : std::string(in.substr(cut + kMarker.size()));
    while (json.size() % 4) json += ' ';
    while (bin.size() % 4) bin += '\0';
    std::string f = "glTF";
    put32(f, 2);
    put32(f, uint32_t(12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin.size())));
    put32(f, uint32_t(json.size()));
    put32(f, 0x4E4F534Au);  // JSON
    f += json;
    if (!bin.empty()) {
        put32(f, uint32_t(bin.size()));
        put32(f, 0x004E4942u);  // BIN
        f += bin;
    }
    return f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string_view in(reinterpret_cast<const char*>(data), size);
    std::string bytes = !in.empty() && in[0] == 'R' ? std::string(in.substr(1)) : container(in);
    auto path = hrad::fuzz::writeInput("a.glb", bytes);
    hrad::Params params;
    params.set("gltf.max_faces", int64_t(200000));
    hrad::fuzz::expectOnlyInputErrors([&] { hrad::scene::loadScene(path.string(), params); });
    return 0;
}
