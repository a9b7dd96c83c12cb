// libFuzzer harness: Mitsuba .serialized meshes alone (scene/mitsuba_serialized.cpp).
// Mutated zlib streams rarely inflate, so the harness builds the container:
// byte 0 picks the record version (even: 4, odd: 3) and the rest is the
// record's uncompressed payload (flags, name, counts, arrays), which the
// harness deflates, prefixes with the 0x041C header and follows with the
// offset table of one mesh. An input starting with 'R' is the file itself,
// raw, to reach the header and table checks. At most 200,000 faces and
// 64 MiB inflated, as a scene could allow.
#include <zlib.h>

#include <cstring>
#include <string>

#include "scene/mitsuba_serialized.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

template <typename T>
void put(std::string& s, T v) {  // little-endian hosts (x86-64, the harness's targets)
    s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

std::string container(const uint8_t* data, size_t size) {
    const bool v3 = size > 0 && (data[0] & 1);
    std::string payload(reinterpret_cast<const char*>(data) + (size ? 1 : 0), size ? size - 1 : 0);
    uLongf n = compressBound(uLong(payload.size()));
    std::string z(n, '\0');
    if (compress2(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(payload.data()),
                  uLong(payload.size()), 1) != Z_OK)
        return {};
    z.resize(n);
    std::string f;
    put(f, uint16_t(0x041C));
    put(f, uint16_t(v3 ? 3 : 4));
    f += z;
    if (v3) put(f, uint32_t(0));
    else put(f, uint64_t(0));
    put(f, uint32_t(1));
    return f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string bytes = size > 0 && data[0] == 'R'
                            ? std::string(reinterpret_cast<const char*>(data) + 1, size - 1)
                            : container(data, size);
    auto path = hrad::fuzz::writeInput("m.serialized", bytes);
    hrad::fuzz::expectOnlyInputErrors([&] {
        hrad::scene::readSerialized(path.string(), 0, 200000, "fuzz", uint64_t(64) << 20);
    });
    return 0;
}
