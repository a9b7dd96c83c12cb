// Little-endian writers for the binary test inputs of scene/ loaders
// (Mitsuba .serialized): the format's byte order, independent of the host's.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

namespace hrad::test {

/// Appends v's sizeof(T) low bytes to s, least significant first.
template <typename T>
void put(std::string& s, T v) {
    for (size_t i = 0; i < sizeof(T); ++i) s += char((uint64_t(v) >> (8 * i)) & 0xFF);
}

/// Appends the IEEE-754 bits of f, least significant byte first.
inline void putFloat(std::string& s, float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    put(s, b);
}

}  // namespace hrad::test
