// Little-endian binary appends and stores for the PLY and EXR writers: explicit byte order, so
// every file is identical on any host.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

namespace sylva {

// True on a little-endian host, where the bytes of a float or a uint32 in memory are already in
// the files' order and whole arrays can be copied (the compiler folds the test).
inline bool isLittleEndian() {
    const uint16_t probe = 1;
    unsigned char first;
    std::memcpy(&first, &probe, 1);
    return first == 1;
}

// Stores v at p[0..4) and returns p + 4: for writers that size their output first (a mesh
// of 20k vertices is a million bytes; appending them one by one cost a millisecond).
inline char* storeU32(char* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xff);
    return p + 4;
}
inline char* storeU64(char* p, uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xff);
    return p + 8;
}
inline char* storeFloat(char* p, double v) {
    const float f = static_cast<float>(v);
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    return storeU32(p, bits);
}

inline void putU32(std::string& out, uint32_t v) {
    char bytes[4];
    storeU32(bytes, v);
    out.append(bytes, 4);
}
inline void putInt(std::string& out, int32_t v) { putU32(out, static_cast<uint32_t>(v)); }
// Stored as a 32-bit IEEE float.
inline void putFloat(std::string& out, double v) {
    char bytes[4];
    storeFloat(bytes, v);
    out.append(bytes, 4);
}

}  // namespace sylva
