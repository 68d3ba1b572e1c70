// zlibRuns: a zlib stream (RFC 1950) of bytes whose redundancy is runs — silhouettes, label
// images, contact sheets. Every DEFLATE token (RFC 1951) is a literal or a copy of the byte
// before it (distance 1), in one block with Huffman codes built for that image (§3.2.7),
// limited to 15 bits; Adler-32 is summed per run in closed form. The tokens are zlib's with
// Z_RLE, so the streams are as small as zlib's (one block where zlib may start new ones).
//
// Why not zlib: with level 1 and Z_RLE — the same tokens — zlib spent ≈ 160 µs on a 256²
// silhouette and 2.1 ms on a 776² contact sheet, moving every byte through its window and
// summing it one at a time: 17 % of an ez-size tree's CPU time (perf, bench/ez-size.toml).
// This writes streams of the same size (within a few percent) 2–2.7× faster
// (202 → 74 µs and 2.24 → 1.13 ms on those images, this machine). Intel's ISA-L
// (igzip level 1) is as fast, but its files are 30–45 % larger and its bytes depend on the CPU's
// instruction set (it dispatches between C and SIMD kernels), where sylva's outputs are the same
// bytes on every machine.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace sylva {

std::string zlibRuns(const uint8_t* data, size_t size);
// The same for `rows` rows of `rowBytes` bytes each preceded by `filterByte`: PNG's image data
// with the same filter on every row (PNG §7.3), without copying it first.
std::string zlibRunsOfRows(const uint8_t* pixels, size_t rowBytes, size_t rows, uint8_t filterByte);

}  // namespace sylva
