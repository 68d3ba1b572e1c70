// Per-view outputs: transforms.json, grey PNGs, depth EXRs, the labelled point cloud and
// contact sheets. Every file is written atomically (a unique temp sibling, then a rename).
//
// transforms.json (nerfstudio "OPENCV" model without distortion, also read by instant-ngp):
//   top level: camera_model "OPENCV", fl_x, fl_y, cx, cy (pixels; pixel centres at i + 0.5,
//   cx = w/2), w, h, k1 = k2 = p1 = p2 = 0; perspective: camera_angle_x / camera_angle_y
//   (radians, instant-ngp); orthographic: "orthographic": true, ortho_height_m, ortho_width_m
//   and fl_x = fl_y = pixels per metre (nerfstudio has no orthographic model: such files
//   need a reader that honours the flag). Intrinsics go into every frame as well when the
//   cameras do not share them.
//   instant-ngp's placement (src/nerf_loader.cu): scale and offset (camera.h ngpPlacement:
//   the tree's bounding sphere centred in its unit cube), aabb_scale = 1 (the scene is the
//   tree on an empty background: nothing to reconstruct outside the cube), up = [0, 1, 0]
//   (its viewer's up; its default is +z), integer_depth_scale with depth PNGs.
//   nerfstudio: orientation_override "none" (its default re-orients the poses to +z up).
//   frames[]: file_path and mask_path (both the silhouette; nerfstudio samples rays only
//   where the mask is non-zero), transform_matrix (4 rows, camera-to-world, OpenGL
//   convention: columns right, up, back = −forward, eye; world +y up, metres),
//   depth_file_path (EXR, nerfstudio), depth_path (PNG, instant-ngp) and label_file_path when
//   written, azimuth_deg, elevation_deg. Keys sorted (nlohmann default).
//   Depth in both files is z-depth: metres along the camera's optical axis (−z in camera
//   space), not the length of the ray, 0 = background. nerfstudio (depth-nerfacto's
//   is_euclidean_depth = false multiplies it by the ray direction's norm) and instant-ngp
//   (target = |d| × depth for d = ((u − cx)/f, (v − cy)/f, 1)) both expect z-depth. With
//   nerfstudio pass `--depth-unit-scale-factor 1.0` (its default 1e-3 expects millimetres).
// Depth EXR: one FLOAT channel "Y", RLE compression (lossless): image_codecs.h says why "Y".
// Depth PNG: 16-bit grey, depth / integer_depth_scale rounded (see view_writers.h).
// PNGs: 8-bit grey. All encoded in memory (pipeline/formats/image_codecs.h, which gives the
//   formats and the measured reasons) and written with writeFileAtomic; identical pixels give
//   identical bytes.
// Point cloud PLY: binary little-endian, vertex = float x, y, z (world metres), uchar label
//   (as the label images: 1 + branch order shoot wood, 254 root wood, 255 leaf; 1 when the view
//   has no label image), uchar view (camera index); views in order, then rows top to bottom,
//   then columns.
// Contact sheets: tiles in row-major order, 2 px light grey (200) gutters around and between
//   tiles, white letterboxing. writeContactSheet (an instance's views): 8-bit grey PNG,
//   `columns` per row (≤ 0: about square), silhouettes black (0) on white (255).
//   writeSpeciesSheet (a species' instances): 8-bit RGB PNG, about square, each instance's
//   first view in label colours (render.h labelColour), or its silhouette dark grey on white
//   without label images, at an integer scale (nearest pixel) in tiles of max(256, view size).
#include "pipeline/formats/view_writers.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/atomic_file.h"
#include "pipeline/formats/image_codecs.h"
#include "pipeline/formats/little_endian.h"
#include "pipeline/render/preview.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "volumes/image_file.h"
#include "volumes/oiio_module.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

constexpr int kGutter = 2;            // contact sheet gutter, pixels
constexpr uint8_t kGutterGrey = 200;  // light grey

void checkSize(int width, int height, size_t have, const char* what) {
    if (width <= 0 || height <= 0 || have != static_cast<size_t>(width) * height) {
        throw std::invalid_argument(std::string(what) + ": " + std::to_string(have) +
                                    " pixels for a " + std::to_string(width) + "x" +
                                    std::to_string(height) + " image");
    }
}

nlohmann::json matrixRows(const Camera& c) {
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < 4; ++i) {
        nlohmann::json row = nlohmann::json::array();
        for (int j = 0; j < 4; ++j) row.push_back(c.cameraToWorld[i][j] + 0.0 /* no -0 */);
        rows.push_back(row);
    }
    return rows;
}

// Intrinsics shared by nerfstudio (OPENCV model, no distortion) and instant-ngp.
void putIntrinsics(nlohmann::json& j, const Camera& c) {
    j["fl_x"] = c.fx();
    j["fl_y"] = c.fy();
    j["cx"] = c.cx();
    j["cy"] = c.cy();
    j["w"] = c.width;
    j["h"] = c.height;
    if (c.orthographic) {
        j["orthographic"] = true;
        j["ortho_height_m"] = c.orthoHeight;
        j["ortho_width_m"] = c.orthoHeight * c.width / c.height;
    } else {
        j["camera_angle_x"] = 2.0 * std::atan(0.5 * c.width / c.fx());
        j["camera_angle_y"] = 2.0 * std::atan(0.5 * c.height / c.fy());
    }
}

bool sameIntrinsics(const Camera& a, const Camera& b) {
    return a.width == b.width && a.height == b.height && a.orthographic == b.orthographic &&
           a.fx() == b.fx() && a.fy() == b.fy() &&
           (!a.orthographic || a.orthoHeight == b.orthoHeight);
}

// Tiles equally sized grey tiles into a sheet: `columns` columns (≤ 0: about square), a
// kGutter-pixel light grey gutter around and between the tiles.
struct Sheet {
    int cols = 0, rows = 0, tileW = 0, tileH = 0, width = 0, height = 0;
    std::vector<uint8_t> pixels;

    Sheet(size_t count, int columns, int tw, int th) : tileW(tw), tileH(th) {
        const int n = static_cast<int>(count);
        cols = columns > 0 ? std::min(columns, n)
                           : static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
        rows = (n + cols - 1) / cols;
        width = cols * (tileW + kGutter) + kGutter;
        height = rows * (tileH + kGutter) + kGutter;
        pixels.assign(static_cast<size_t>(width) * height, kGutterGrey);
    }
    // Writes tile i (row-major grid) from a w×h image centred in its cell (white letterbox);
    // row(y, dst) fills the w pixels of image row y.
    template <typename RowFn>
    void put(size_t i, int w, int h, RowFn row) {
        const int cx0 = kGutter + static_cast<int>(i % cols) * (tileW + kGutter);
        const int cy0 = kGutter + static_cast<int>(i / cols) * (tileH + kGutter);
        for (int y = 0; y < tileH; ++y) {
            std::fill_n(pixels.begin() + static_cast<size_t>(cy0 + y) * width + cx0, tileW,
                        uint8_t{255});
        }
        const int ox = cx0 + (tileW - w) / 2, oy = cy0 + (tileH - h) / 2;
        for (int y = 0; y < h; ++y) {
            row(y, pixels.data() + static_cast<size_t>(oy + y) * width + ox);
        }
    }
};

// An image decoded from memory (from a file or a tar member) into `channels` 8-bit channels
// per pixel, the missing ones `fill`; `name` for messages and for the format. sylva's own PNGs
// through libpng at the views' size limits (image_file.h), anything else (a colour picture's
// JPEG) through OpenImageIO's module (oiio_module.h). imageChannels: the image's own count.
std::vector<uint8_t> decodeImage(const std::string& bytes, const std::string& name, int channels,
                                 uint8_t fill, int& w, int& h, int& imageChannels) {
    std::vector<uint8_t> px;
    if (hasPngSignature(bytes)) {
        Image8 img = readPng8Bytes(bytes, name, kViewImageLimits);
        w = img.width;
        h = img.height;
        imageChannels = img.channels;
        if (img.channels == channels) return std::move(img.pixels);
        px.assign(static_cast<size_t>(w) * h * channels, fill);
        const int copy = std::min(channels, img.channels);
        for (size_t k = 0; k < static_cast<size_t>(w) * h; ++k) {
            std::memcpy(&px[k * channels], &img.pixels[k * img.channels], copy);
        }
        return px;
    }
    std::string error;
    if (!oiioModule().decode(bytes, name, channels, fill, px, w, h, imageChannels, error)) {
        throw std::runtime_error("cannot read image '" + name + "': " + error);
    }
    return px;
}

// The first channel of an 8-bit image (a label or silhouette PNG), exactly.
std::vector<uint8_t> readChannel0(const std::string& bytes, const std::string& name, int& w,
                                  int& h) {
    int channels = 0;
    return decodeImage(bytes, name, 1, 0, w, h, channels);
}

// Straight-alpha sRGB over white, in 8 bits (the sheets are for looking at).
void overWhite(const uint8_t* rgba, uint8_t* rgb) {
    const double a = rgba[3] / 255.0;
    for (int c = 0; c < 3; ++c) {
        rgb[c] = static_cast<uint8_t>(std::lround(rgba[c] * a + 255.0 * (1.0 - a)));
    }
}

// The RGB of a colour picture, its alpha dropped.
std::vector<uint8_t> rgbOf(const ColourImage& image) {
    std::vector<uint8_t> rgb(static_cast<size_t>(image.width) * image.height * 3);
    for (size_t k = 0; k < rgb.size() / 3; ++k) std::memcpy(&rgb[3 * k], &image.rgba[4 * k], 3);
    return rgb;
}

// One camera for a tree's previews: perspective at azimuth 0 (looking along −z), 10° above the
// horizon, size × size pixels, framing the tree as the dataset views do.
Camera previewCamera(const Tree& tree, int size) {
    ViewOptions o;
    o.count = 1;
    o.width = o.height = size;
    o.elevationsDeg = {10};
    o.randomAzimuth = false;
    Rng unused(0);  // no random azimuth
    return makeCameras(tree, o, unused).front();
}

// An RGBA picture (views/NNN_rgb.png, or its JPEG) as RGB over white.
std::vector<uint8_t> readRgbOverWhite(const std::string& bytes, const std::string& name, int& w,
                                      int& h) {
    int channels = 0;
    const std::vector<uint8_t> px = decodeImage(bytes, name, 4, 255, w, h, channels);
    if (channels < 3) throw std::runtime_error("cannot read image '" + name + "': not colour");
    std::vector<uint8_t> rgb(static_cast<size_t>(w) * h * 3);
    for (size_t k = 0; k < rgb.size() / 3; ++k) overWhite(&px[4 * k], &rgb[3 * k]);
    return rgb;
}

}  // namespace

nlohmann::json transformsJson(const std::vector<Camera>& cameras, const ViewFiles& files,
                              const NgpPlacement& placement) {
    const size_t n = cameras.size();
    auto matches = [n](const auto& v) { return v.empty() || v.size() == n; };
    if (files.images.size() != n || !matches(files.depthExr) || !matches(files.depthPng) ||
        !matches(files.labels) || !matches(files.colour) || !matches(files.lights)) {
        throw std::invalid_argument("transformsJson: " + std::to_string(n) + " cameras but " +
                                    std::to_string(files.images.size()) + " images, " +
                                    std::to_string(files.depthExr.size()) + " depth EXRs, " +
                                    std::to_string(files.depthPng.size()) + " depth PNGs, " +
                                    std::to_string(files.labels.size()) + " label images");
    }
    if (!files.depthPng.empty() && !(files.integerDepthScale > 0)) {
        throw std::invalid_argument("transformsJson: depth PNGs need a positive depth scale");
    }
    nlohmann::json j;
    j["camera_model"] = "OPENCV";
    for (const char* k : {"k1", "k2", "p1", "p2"}) j[k] = 0.0;
    bool shared = true;
    for (const Camera& c : cameras) shared = shared && sameIntrinsics(c, cameras.front());
    if (n > 0) putIntrinsics(j, cameras.front());
    j["aabb_scale"] = 1;
    j["scale"] = placement.scale;
    j["offset"] = {placement.offset.x + 0.0, placement.offset.y + 0.0, placement.offset.z + 0.0};
    j["up"] = {0.0, 1.0, 0.0};
    j["orientation_override"] = "none";
    if (!files.depthPng.empty()) j["integer_depth_scale"] = files.integerDepthScale;
    nlohmann::json frames = nlohmann::json::array();
    for (size_t i = 0; i < n; ++i) {
        nlohmann::json f;
        f["file_path"] = files.colour.empty() ? files.images[i] : files.colour[i];
        f["mask_path"] = files.images[i];
        f["transform_matrix"] = matrixRows(cameras[i]);
        if (!files.depthExr.empty()) f["depth_file_path"] = files.depthExr[i];
        if (!files.depthPng.empty()) f["depth_path"] = files.depthPng[i];
        if (!files.labels.empty()) f["label_file_path"] = files.labels[i];
        if (i < files.lights.size()) {
            const ColourLight& l = files.lights[i];
            f["sun_direction"] = {l.sunDirection.x, l.sunDirection.y, l.sunDirection.z};
            f["sun_elevation_deg"] = l.sunElevationDeg;
            f["sun_azimuth_deg"] = l.sunAzimuthDeg;
            f["exposure_ev"] = l.exposureEv;
            f["exposure_scale"] = l.exposureScale;
            f["sky_haze"] = l.haze;
        }
        f["azimuth_deg"] = cameras[i].azimuthDeg;
        f["elevation_deg"] = cameras[i].elevationDeg;
        if (!shared) putIntrinsics(f, cameras[i]);
        frames.push_back(std::move(f));
    }
    j["frames"] = std::move(frames);
    return j;
}

std::string greyPngBytes(int width, int height, const std::vector<uint8_t>& pixels) {
    checkSize(width, height, pixels.size(), "writeGreyPng");
    return encodeGreyPng(width, height, pixels.data());
}

void writeGreyPng(const fs::path& path, int width, int height, const std::vector<uint8_t>& pixels) {
    writeFileAtomic(path, greyPngBytes(width, height, pixels));
}

std::string depthExrBytes(int width, int height, const std::vector<float>& depth, bool half,
                          bool zip) {
    checkSize(width, height, depth.size(), "writeDepthExr");
    return encodeFloatExr(width, height, depth.data(), "Y", half,
                          zip ? ExrCompression::kZip : ExrCompression::kRle);
}

void writeDepthExr(const fs::path& path, int width, int height, const std::vector<float>& depth,
                   bool half, bool zip) {
    writeFileAtomic(path, depthExrBytes(width, height, depth, half, zip));
}

double integerDepthScale(const std::vector<ViewImage>& views) {
    double farthest = 0.0;
    for (const ViewImage& v : views) {
        for (float d : v.depth) {
            if (d > 0 && std::isfinite(d)) farthest = std::max(farthest, static_cast<double>(d));
        }
    }
    // 1, 2, 5 × 10^k mm: the finest step at which the farthest hit rounds to ≤ 65535 units
    // (each step the nearest double to its decimal value: 0.001, 0.002, 0.005, 0.01, …).
    for (double decade = 1;; decade *= 10) {
        for (double step : {1.0, 2.0, 5.0}) {
            const double scale = step * decade / 1000.0;
            if (farthest / scale < 65535.5) return scale;
        }
    }
}

std::vector<uint16_t> depthToUnits(const std::vector<float>& depth, double scale) {
    if (!(scale > 0)) throw std::invalid_argument("depthToUnits: the scale must be positive");
    std::vector<uint16_t> units(depth.size(), 0);
    for (size_t k = 0; k < depth.size(); ++k) {
        const float d = depth[k];
        if (!(d > 0)) continue;  // background (0) and anything not a hit
        const double v = std::floor(static_cast<double>(d) / scale + 0.5);
        if (!(v <= 65535)) {
            throw std::invalid_argument("depthToUnits: depth " + std::to_string(d) +
                                        " m exceeds 65535 units of " + std::to_string(scale) +
                                        " m");
        }
        units[k] = static_cast<uint16_t>(std::max(1.0, v));  // a hit never reads as "no hit"
    }
    return units;
}

std::string depthPngBytes(int width, int height, const std::vector<float>& depth, double scale) {
    checkSize(width, height, depth.size(), "writeDepthPng");
    const std::vector<uint16_t> units = depthToUnits(depth, scale);
    return encodeGrey16Png(width, height, units.data());
}

void writeDepthPng(const fs::path& path, int width, int height, const std::vector<float>& depth,
                   double scale) {
    writeFileAtomic(path, depthPngBytes(width, height, depth, scale));
}

std::string pointCloudPly(const std::vector<Camera>& cameras, const std::vector<ViewImage>& views) {
    if (cameras.size() != views.size()) {
        throw std::invalid_argument("pointCloudPly: " + std::to_string(cameras.size()) +
                                    " cameras but " + std::to_string(views.size()) + " views");
    }
    if (views.size() > 256) {
        throw std::invalid_argument("pointCloudPly: at most 256 views fit the uchar view index");
    }
    size_t count = 0;
    for (size_t v = 0; v < views.size(); ++v) {
        const ViewImage& view = views[v];
        const size_t n = static_cast<size_t>(view.width) * view.height;
        if (view.depth.size() != n || view.width != cameras[v].width ||
            view.height != cameras[v].height || (!view.labels.empty() && view.labels.size() != n)) {
            throw std::invalid_argument("pointCloudPly: view " + std::to_string(v) +
                                        " has no depth map or does not match its camera");
        }
        for (float z : view.depth) count += z > 0;
    }
    std::string out;
    out.reserve(400 + count * 14);
    out += "ply\n";
    out += "format binary_little_endian 1.0\n";
    out += "comment generated by sylva: depth maps back-projected to world points (metres)\n";
    out +=
        "comment label: 1 + branch order for shoot wood, 254 for root wood, 255 for leaves; "
        "view: camera index\n";
    out += "comment units: metres; up axis: +y\n";
    out += "element vertex " + std::to_string(count) + "\n";
    out += "property float x\n";
    out += "property float y\n";
    out += "property float z\n";
    out += "property uchar label\n";
    out += "property uchar view\n";
    out += "end_header\n";
    for (size_t v = 0; v < views.size(); ++v) {
        const ViewImage& view = views[v];
        for (int y = 0; y < view.height; ++y) {
            for (int x = 0; x < view.width; ++x) {
                const size_t k = static_cast<size_t>(y) * view.width + x;
                const float z = view.depth[k];
                if (!(z > 0)) continue;
                const Vec3 p = cameras[v].unproject(x + 0.5, y + 0.5, z);
                putFloat(out, p.x);
                putFloat(out, p.y);
                putFloat(out, p.z);
                out.push_back(static_cast<char>(view.labels.empty() ? 1 : view.labels[k]));
                out.push_back(static_cast<char>(v));
            }
        }
    }
    return out;
}

std::string encodeColourImage(const ColourImage& image, bool jpeg, int quality) {
    checkSize(image.width, image.height, image.rgba.size() / 4, "encodeColourImage");
    if (!jpeg) return encodeRgbaPng(image.width, image.height, image.rgba.data());
    const std::vector<uint8_t> rgb = rgbOf(image);
    std::string bytes, error;
    if (!oiioModule().encodeJpeg(image.width, image.height, rgb.data(), quality, bytes, error)) {
        throw std::runtime_error("cannot encode a JPEG: " + error);
    }
    return bytes;
}

void writeColourContactSheet(const fs::path& path, const std::vector<ColourImage>& images,
                             int columns) {
    if (images.empty()) throw std::invalid_argument("writeColourContactSheet: no images");
    int tw = 0, th = 0;
    for (const ColourImage& v : images) {
        checkSize(v.width, v.height, v.rgba.size() / 4, "writeColourContactSheet");
        tw = std::max(tw, v.width);
        th = std::max(th, v.height);
    }
    const int cols = std::max(1, columns);
    const int rows = (static_cast<int>(images.size()) + cols - 1) / cols;
    const int width = cols * tw, height = rows * th;
    std::vector<uint8_t> sheet(3 * static_cast<size_t>(width) * height, 255);
    for (size_t i = 0; i < images.size(); ++i) {
        const ColourImage& v = images[i];
        const int x0 = static_cast<int>(i % cols) * tw, y0 = static_cast<int>(i / cols) * th;
        for (int y = 0; y < v.height; ++y) {
            for (int x = 0; x < v.width; ++x) {
                overWhite(&v.rgba[4 * (static_cast<size_t>(y) * v.width + x)],
                          &sheet[3 * (static_cast<size_t>(y0 + y) * width + x0 + x)]);
            }
        }
    }
    writeFileAtomic(path, encodeRgbPng(width, height, sheet.data()));
}

void writeContactSheet(const fs::path& path, const std::vector<ViewImage>& views, int columns) {
    if (views.empty()) throw std::invalid_argument("writeContactSheet: no views");
    int tw = 0, th = 0;
    for (const ViewImage& v : views) {
        checkSize(v.width, v.height, v.silhouette.size(), "writeContactSheet");
        tw = std::max(tw, v.width);
        th = std::max(th, v.height);
    }
    Sheet sheet(views.size(), columns, tw, th);
    for (size_t i = 0; i < views.size(); ++i) {
        const ViewImage& v = views[i];
        sheet.put(i, v.width, v.height, [&](int y, uint8_t* dst) {
            // The width held in a local: a byte store may alias v.width, which the loop would
            // then reload at every pixel instead of being vectorised (7 instructions a pixel).
            const int n = v.width;
            const uint8_t* src = v.silhouette.data() + static_cast<size_t>(y) * n;
            for (int x = 0; x < n; ++x) dst[x] = src[x] ? 0 : 255;
        });
    }
    writeGreyPng(path, sheet.width, sheet.height, sheet.pixels);
}

InstanceFileReader instanceDirReader(const fs::path& dir) {
    return [dir](const std::string& relPath) -> std::optional<std::string> {
        std::error_code ec;
        if (!fs::is_regular_file(dir / relPath, ec)) return std::nullopt;
        std::ifstream in(dir / relPath, std::ios::binary);
        std::ostringstream s;
        s << in.rdbuf();
        if (!in) throw std::runtime_error("cannot read '" + (dir / relPath).string() + "'");
        return s.str();
    };
}

void writeSpeciesSheet(const fs::path& path, const std::vector<fs::path>& instanceDirs) {
    std::vector<InstanceFileReader> readers;
    for (const fs::path& d : instanceDirs) readers.push_back(instanceDirReader(d));
    writeSpeciesSheet(path, readers);
}

void writeSpeciesSheet(const fs::path& path, const std::vector<InstanceFileReader>& instances) {
    if (instances.empty()) throw std::invalid_argument("writeSpeciesSheet: no instances");
    struct Tile {
        int w = 0, h = 0;
        std::vector<uint8_t> rgb;
    };
    std::vector<Tile> tiles;
    int tile = kSpeciesSheetMinTile;
    for (const InstanceFileReader& read : instances) {
        Tile t;
        if (auto colour = read("views/000_rgb.png")) {
            t.rgb = readRgbOverWhite(*colour, "views/000_rgb.png", t.w, t.h);
        } else if (auto labels = read("views/000_label.png")) {
            t.rgb = colourLabels(readChannel0(*labels, "views/000_label.png", t.w, t.h));
        } else if (auto silhouette = read("views/000.png")) {  // the tree dark grey on white
            const std::vector<uint8_t> sil = readChannel0(*silhouette, "views/000.png", t.w, t.h);
            t.rgb.resize(3 * sil.size());
            for (size_t k = 0; k < sil.size(); ++k) {
                const uint8_t v = sil[k] ? 40 : 255;
                t.rgb[3 * k] = t.rgb[3 * k + 1] = t.rgb[3 * k + 2] = v;
            }
        } else {
            throw std::runtime_error("writeSpeciesSheet: an instance without views/000.png");
        }
        tile = std::max({tile, t.w, t.h});
        tiles.push_back(std::move(t));
    }
    const int n = static_cast<int>(tiles.size());
    const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
    const int rows = (n + cols - 1) / cols;
    const int width = cols * (tile + kGutter) + kGutter, height = rows * (tile + kGutter) + kGutter;
    std::vector<uint8_t> sheet(3 * static_cast<size_t>(width) * height, kGutterGrey);
    for (int i = 0; i < n; ++i) {
        const Tile& t = tiles[i];
        // Each view at an integer scale (nearest pixel: labels stay exact), centred on white.
        const int s = std::max(1, std::min(tile / t.w, tile / t.h));
        const int x0 = kGutter + (i % cols) * (tile + kGutter);
        const int y0 = kGutter + (i / cols) * (tile + kGutter);
        const int ox = x0 + (tile - s * t.w) / 2, oy = y0 + (tile - s * t.h) / 2;
        for (int y = 0; y < tile; ++y) {
            uint8_t* row = sheet.data() + 3 * (static_cast<size_t>(y0 + y) * width + x0);
            std::fill_n(row, 3 * tile, uint8_t{255});
        }
        for (int y = 0; y < s * t.h; ++y) {
            uint8_t* row = sheet.data() + 3 * (static_cast<size_t>(oy + y) * width + ox);
            const uint8_t* src = t.rgb.data() + 3 * static_cast<size_t>(y / s) * t.w;
            for (int x = 0; x < s * t.w; ++x) std::memcpy(row + 3 * x, src + 3 * (x / s), 3);
        }
    }
    writeFileAtomic(path, encodeRgbPng(width, height, sheet.data()));
}

void writePreviewPng(const Tree& tree, const fs::path& path, int sizePixels) {
    const std::vector<uint8_t> pixels = renderPreview(tree, sizePixels);
    writeFileAtomic(path, encodeGreyPng(sizePixels, sizePixels, pixels.data()));
}

void writeColourPreviewPng(const Tree& tree, const Mesh& wood,
                           const std::vector<int32_t>& woodNodes, const Look& look, uint64_t seed,
                           const fs::path& path, int size) {
    const Camera camera = previewCamera(tree, size);
    const Mesh leaves = leafMesh(tree);
    const ViewImage v = renderView(tree, wood, woodNodes, camera, false, false);
    const ColourScene scene(tree, wood, leaves, look, seed);
    ColourOptions co;
    co.enabled = true;
    co.background = ColourBackground::kColour;  // white; the exposure meters the tree
    const ColourImage img = scene.render(camera, v, co, Rng(seed).derive("preview"));
    writeFileAtomic(path, encodeRgbPng(size, size, rgbOf(img).data()));
}

void writeLabelPreviewPng(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                          const fs::path& path, int size) {
    const ViewImage v = renderView(tree, wood, woodNodes, previewCamera(tree, size), false, true);
    writeFileAtomic(path, encodeRgbPng(size, size, colourLabels(v.labels).data()));
}

void writeLabelPreviewPng(const Tree& tree, const fs::path& path, int size) {
    std::vector<int32_t> nodes;
    const Mesh wood = tubeMesh(tree, TubeOptions{}, &nodes);
    writeLabelPreviewPng(tree, wood, nodes, path, size);
}

}  // namespace sylva
