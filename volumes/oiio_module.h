// OpenImageIO, loaded when first needed. OpenImageIO 2.4 links ≈ 260 shared libraries (its
// codecs, ffmpeg, libheif, …): loading them and resolving their symbols cost every sylva process
// ≈ 0.25 s of CPU and ≈ 100 MB of resident memory at start, whatever the command — `sylva
// --help` included. Only three things need it: species images in formats other than PNG
// (image_file.h), colour pictures written or read as JPEG. So its calls live in a module of their
// own, libsylva_oiio.so (volumes/oiio/), built beside the executable and opened with dlopen the
// first time one of them is needed. Copy it with the executable (docs/cluster.md).
//
// The module is compiled by the same build as its callers, so the table passes C++ types.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "volumes/image_file.h"

namespace sylva {

struct OiioModule {
    // Reads the image at `path` as image_file.h's ImageFile (every channel as float,
    // unassociated alpha). `check(width, height, channels, depth)` sees the header before any
    // pixel is decoded and may throw. False with a one-line `error` when OpenImageIO cannot.
    bool (*readFile)(const std::string& path, const std::function<void(int, int, int, int)>& check,
                     ImageFile& out, std::string& error);
    // Decodes an image held in memory (`name`'s extension picks the format) into `channels`
    // 8-bit channels per pixel, row-major; channels the image lacks keep `fill`. Also gives the
    // image's own channel count.
    bool (*decode)(const std::string& bytes, const std::string& name, int channels, uint8_t fill,
                   std::vector<uint8_t>& pixels, int& width, int& height, int& imageChannels,
                   std::string& error);
    // A JPEG of 8-bit RGB pixels at `quality` (1–100).
    bool (*encodeJpeg)(int width, int height, const uint8_t* rgb, int quality, std::string& out,
                       std::string& error);
};

// The module, opened on the first call (thread-safe); later calls return the same table.
// Opens the environment's SYLVA_OIIO_MODULE (a path) when set, else libsylva_oiio.so beside
// the running executable. Throws std::runtime_error naming what it tried when it cannot load it.
const OiioModule& oiioModule();

}  // namespace sylva
