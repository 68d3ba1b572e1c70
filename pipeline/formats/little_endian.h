// Binary appends and stores in an explicit byte order (little-endian for the PLY, EXR and GLB
// writers; big-endian where PNG and zlib want it), so every file is identical on any host, and
// the byte-run scan the run-length coders share.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// The same most significant byte first (PNG's lengths and CRCs, zlib's Adler-32).
inline char* storeU32BigEndian(char* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((v >> (24 - 8 * i)) & 0xff);
    return p + 4;
}

// The end of the run of bytes equal to b from `from`: the first index in [from, end) whose
// byte differs, or end. Sixteen bytes at a time with SSE2 (the first differing byte is the
// lowest clear bit of the comparison's mask: 0.5 % of ez-size's instructions against eight at a
// time), then eight: on a little-endian host the first differing byte of a word is the lowest
// nonzero byte of its XOR with the pattern.
inline size_t runEnd(const uint8_t* in, size_t from, size_t end, uint8_t b) {
    size_t j = from;
#if defined(__SSE2__)
    const __m128i bytes = _mm_set1_epi8(static_cast<char>(b));
    while (j + 16 <= end) {
        const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + j));
        const unsigned differ =
            ~static_cast<unsigned>(_mm_movemask_epi8(_mm_cmpeq_epi8(v, bytes))) & 0xffffu;
        if (differ != 0) return j + static_cast<size_t>(__builtin_ctz(differ));
        j += 16;
    }
#endif
    const uint64_t pattern = 0x0101010101010101ull * b;
    while (j + 8 <= end) {
        uint64_t word;
        std::memcpy(&word, in + j, 8);
        const uint64_t differ = word ^ pattern;
        if (differ != 0) {
            if (!isLittleEndian()) break;
            return j + static_cast<size_t>(__builtin_ctzll(differ)) / 8;
        }
        j += 8;
    }
    while (j < end && in[j] == b) ++j;
    return j;
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
