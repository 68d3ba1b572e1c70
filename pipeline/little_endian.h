// Little-endian binary appends for the PLY writers: explicit byte order, so every file is
// identical on any host.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

namespace sylva {

inline void putU32(std::string& out, uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
inline void putInt(std::string& out, int32_t v) { putU32(out, static_cast<uint32_t>(v)); }
// Stored as a 32-bit IEEE float.
inline void putFloat(std::string& out, double v) {
    const float f = static_cast<float>(v);
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    putU32(out, bits);
}

}  // namespace sylva
