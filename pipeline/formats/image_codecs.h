// In-memory encoders for the per-view images, so each file is one atomic write of bytes.
//
// encodeGreyPng: 8-bit greyscale PNG, no row filter, one IDAT chunk of zlibRuns's stream
//   (deflate_runs.h: the tokens of zlib's Z_RLE strategy in one block of dynamic codes).
//   Silhouettes, label images and contact sheets are long runs of a few values: the files are
//   the size libpng with zlib level 1 and Z_RLE made, written 2–2.7× faster (a 256²
//   silhouette 202 → 74 µs, a 776² contact sheet 2.24 → 1.13 ms on this machine).
// encodeRgbPng, encodeGrey16Png: through libpng, zlib level 1 with Z_RLE, memLevel 6, no
//   row filter. encodeGrey16Png is 16-bit greyscale (samples big-endian in the file, as PNG
//   requires; given here as native uint16 values). Depth maps for instant-ngp.
//
// encodeFloatExr: a single-part scanline OpenEXR 2.0 file, one FLOAT (32-bit) or HALF channel,
//   RLE compression (one scanline per chunk) or ZIP (16 scanlines per chunk), increasing y, data
//   window = display window = (0, 0)–(w−1, h−1); the header holds exactly the eight required
//   attributes (no time stamp, so equal pixels give equal bytes). Written here rather than through
//   OpenEXR 3.1 because its writer spends ≈ 0.75 ms on a 256² map (a byte-at-a-time run
//   coder and per-line buffer churn), the largest single cost of an instance; this one
//   writes the same format in ≈ 0.1 ms. The layout follows the OpenEXR file layout
//   document (openexr.com, "OpenEXR File Layout"): magic, version 2, attributes, the line
//   offset table, then chunks (y, size, data). RLE data is OpenEXR's: bytes split into
//   two halves (even then odd positions), delta-coded (d = b[i] − b[i−1] + 128 mod 256), then
//   runs of 3–128 equal bytes as (count − 1, byte) and other stretches of ≤ 128 bytes as
//   (−count, bytes…); a chunk that would not shrink is stored raw. ZIP data is the same split
//   and delta-coded bytes of the chunk's 16 lines (the even bytes of each line, line after
//   line, then the odd ones), through zlib at level 4: 0.6× RLE's bytes on depth maps, in
//   8–11× its time (a 256² map written in 1.0 ms as half, 1.5 ms as float, against 0.13 ms). Files
//   read back through OpenEXR (OIIO) bit-exactly (tests/image_codecs_test.cpp). The channel is
//   named "Y" (luminance) by default: the one single-channel name that OpenCV (imgcodecs
//   grfmt_exr.cpp: R/G/B make a colour image, a lone "Y" a grey one; 4.6 reads a lone "Z" as all
//   zeros and other names not at all), Blender (imbuf openexr_api.cpp: "Y" is broadcast to grey
//   RGB; older versions load a "Z" channel as a hidden z-buffer and show black) and OpenImageIO
//   (any name) all read as the value.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace sylva {

// width × height pixels, row-major, row 0 at the top. Throws std::invalid_argument for a
// non-positive size.
std::string encodeGreyPng(int width, int height, const uint8_t* pixels);
// The same PNG encoding for 8-bit RGB: 3 bytes per pixel (r, g, b), row-major.
std::string encodeRgbPng(int width, int height, const uint8_t* rgb);
// 8-bit RGBA (straight alpha), 4 bytes per pixel: colour pictures, so with adaptive row
// filters and zlib level 6 (a rendered tree is gradients, not runs).
std::string encodeRgbaPng(int width, int height, const uint8_t* rgba);
// 16-bit greyscale: one uint16 per pixel, row-major.
std::string encodeGrey16Png(int width, int height, const uint16_t* pixels);
enum class ExrCompression : uint8_t { kRle, kZip };
// half: the channel as HALF (16-bit floats, Imath's round-to-nearest-even; relative error at
// most 2⁻¹¹ ≈ 0.05 %, values above 65504 become infinity), half the bytes.
std::string encodeFloatExr(int width, int height, const float* pixels,
                           const std::string& channel = "Y", bool half = false,
                           ExrCompression compression = ExrCompression::kRle);
// n floats as halves, bit for bit what Imath's imath_float_to_half gives (the half EXRs' pixels),
// eight at a time with the F16C instruction where the CPU has it.
void floatsToHalves(const float* in, uint16_t* out, size_t n);

}  // namespace sylva
