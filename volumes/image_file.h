// The images a species file names — silhouette masks, canopy layer images, drawn strokes —
// read as float pixels after checks that come before any pixel is decoded: the file is not
// empty, its format is recognised, its header's dimensions are within the limits below, and
// (PNG) its data is complete and uncorrupted (every chunk whole, CRCs and the zlib stream
// correct, up to IEND). Nothing is printed: libpng's and OpenImageIO's messages become the
// one-line ImageError, which the spec reader reports at the key naming the file.
//
// PNG, the format of every shipped sketch, is decoded with libpng directly (OpenImageIO 2.4's
// PNG reader installs no libpng error handler, so a corrupt file printed libpng's own lines on
// stderr); the values equal OpenImageIO's float read (tests/volumes/image_file_test.cpp).
// Other formats (JPEG, TIFF, EXR, …) go through OpenImageIO, their header checked first.
// sylva's own views read back (contact sheets, gates) go through the same PNG decoder into
// 8-bit samples, with the views' larger size limits.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace sylva {

// At most this many pixels on either side of an image a spec names …
constexpr int kMaxImageSide = 16384;
// … and this many in all (4096², 16.8 megapixels: about 270 MB as float RGBA).
constexpr int64_t kMaxImagePixels = int64_t(4096) * 4096;
// Channels (grey, grey + alpha, RGB, RGBA, or more in an EXR).
constexpr int kMaxImageChannels = 16;

// The size an image may declare before it is decoded.
struct ImageLimits {
    int maxSide = kMaxImageSide;
    int64_t maxPixels = kMaxImagePixels;
};
// sylva's own views (masks, labels, colour pictures): up to 16384 × 16384 ([views] resolution).
constexpr ImageLimits kViewImageLimits{16384, int64_t(16384) * 16384};

// An image that cannot be used; the message is one line naming the file.
class ImageError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

struct ImageFile {
    int width = 0, height = 0, channels = 0;
    int alphaChannel = -1;  // -1: none (PNG: the last channel of grey + alpha and RGBA)
    // Integer formats: the largest sample value (255, 65535, …), which `pixels` divides by;
    // 0 for floating-point formats (stored as read). pixels × integerMax is the stored integer.
    double integerMax = 0;
    // Row-major, top row first, channels interleaved; integer formats scaled to [0, 1]
    // (v / 255, v / 65535); alpha unassociated (colour as stored, not multiplied by alpha).
    std::vector<float> pixels;

    float at(int column, int row, int channel) const {
        return pixels[(static_cast<size_t>(row) * width + column) * channels + channel];
    }
};

// Reads the image at `path`. Throws ImageError ("cannot read the image <path>: <why>").
ImageFile readImageFile(const std::string& path);
// A PNG's samples in 8 bits (16-bit samples rounded to v · 255 / 65535), as sylva reads back
// its own views for contact sheets and gates: the same checks and expansions as above, the
// size checked against `limits`. The second reads a PNG held in memory (a member of a packed
// dataset's tar); `name` for messages.
struct Image8 {
    int width = 0, height = 0, channels = 0;
    std::vector<uint8_t> pixels;  // row-major, top row first, channels interleaved
};
Image8 readPng8File(const std::string& path, const ImageLimits& limits);
Image8 readPng8Bytes(const std::string& bytes, const std::string& name, const ImageLimits& limits);
// True when `bytes` start with the PNG signature.
bool hasPngSignature(const std::string& bytes);

}  // namespace sylva
