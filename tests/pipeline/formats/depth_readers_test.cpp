// Depth maps read by the tools people use, compared pixel by pixel with the renderer's buffer:
// the EXR through OpenCV's Python module (cv2.imread(f, IMREAD_ANYDEPTH), the call nerfstudio
// makes) and OpenImageIO (its Python module and the C++ library), the 16-bit PNG through
// OpenCV as uint16. The readers run in Debian's /usr/bin/python3 (python3-opencv,
// python3-openimageio, installed by scripts/setup); a missing module fails the test.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/formats/view_writers.h"
#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
using test::addNode;
using test::TempDir;

// A small tree with a trunk, forks and leaves: depth varies over the image and has background.
Tree smallTree() {
    Tree t;
    const int root = addNode(t, -1, {0, 0, 0}, 0.12);
    const int top = addNode(t, root, {0.05, 1.6, 0}, 0.08);
    const int a = addNode(t, top, {0.9, 2.3, 0.4}, 0.04, 1);
    const int b = addNode(t, top, {-0.7, 2.6, -0.5}, 0.035, 1);
    addNode(t, a, {1.3, 2.9, 0.2}, 0.01, 2);
    addNode(t, b, {-0.9, 3.1, -0.2}, 0.01, 2);
    for (int k = 0; k < 6; ++k) {
        Leaf leaf;
        leaf.position = {-0.6 + 0.3 * k, 2.7 + 0.05 * k, 0.1 * (k % 3)};
        leaf.normal = normalize(Vec3{0.2, 0.3, 1.0});
        leaf.tangent = normalize(cross(Vec3{0, 1, 0}, leaf.normal));
        leaf.size = 0.25;
        leaf.aspect = 0.6;
        t.leaves.push_back(leaf);
    }
    return t;
}

template <typename T>
std::vector<T> readRaw(const fs::path& p, size_t count) {
    std::vector<T> v(count);
    std::ifstream in(p, std::ios::binary);
    in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(count * sizeof(T)));
    EXPECT_TRUE(in && in.peek() == std::char_traits<char>::eof()) << p << ": not " << count;
    return v;
}

// Runs tests/python/read_depth.py on the files; returns its readers.json.
nlohmann::json readWithPython(const fs::path& out, const fs::path& exr, const fs::path& png) {
    const std::string cmd = std::string("/usr/bin/python3 '") + SYLVA_SOURCE_DIR +
                            "/tests/python/read_depth.py' '" + out.string() + "' '" + exr.string() +
                            "' '" + png.string() + "'";
    const int status = std::system(cmd.c_str());
    EXPECT_EQ(status, 0) << cmd << "\n(needs python3-opencv and python3-openimageio: "
                         << "scripts/setup installs them)";
    std::ifstream in(out / "readers.json");
    if (!in) return nlohmann::json::object();
    return nlohmann::json::parse(in);
}

TEST(DepthReaders, OpenCvAndOpenImageIoReadTheRenderersDepth) {
    const Tree tree = smallTree();
    ViewOptions o;
    o.count = 3;
    o.width = 72;  // not square, so a transposed read cannot pass
    o.height = 50;
    o.randomAzimuth = false;
    o.azimuthOffsetDeg = 20;
    o.elevationsDeg = {15, -5, 40};
    Rng unused(0);
    const std::vector<Camera> cameras = makeCameras(tree, o, unused);
    std::vector<ViewImage> views;
    for (const Camera& c : cameras) views.push_back(renderView(tree, c, true, false));
    const double scale = integerDepthScale(views);
    EXPECT_EQ(scale, 0.001);  // a 3 m tree seen from ≈ 8 m: millimetres

    TempDir dir;
    for (size_t v = 0; v < views.size(); ++v) {
        const ViewImage& view = views[v];
        const size_t n = view.depth.size();
        size_t hits = 0;
        for (float d : view.depth) hits += d > 0;
        ASSERT_GT(hits, n / 100) << "view " << v << ": too few tree pixels to test";
        ASSERT_LT(hits, n) << "view " << v << ": no background";

        const fs::path sub = dir.path() / std::to_string(v);
        fs::create_directories(sub);
        const fs::path exr = sub / "depth.exr", png = sub / "depth.png";
        writeDepthExr(exr, view.width, view.height, view.depth);
        writeDepthPng(png, view.width, view.height, view.depth, scale);
        const nlohmann::json info = readWithPython(sub, exr, png);
        SCOPED_TRACE("view " + std::to_string(v) + ": " + info.dump());

        // OpenCV: one float32 channel, (h, w), every pixel the renderer's value bit for bit.
        ASSERT_TRUE(info.contains("cv2_exr") && info["cv2_exr"].is_object());
        EXPECT_EQ(info["cv2_exr"]["dtype"], "float32");
        EXPECT_EQ(info["cv2_exr"]["shape"], nlohmann::json({view.height, view.width}));
        const auto cv = readRaw<float>(sub / "cv2_exr.f32", n);
        EXPECT_EQ(0, std::memcmp(cv.data(), view.depth.data(), n * sizeof(float)));

        // OpenImageIO (Python): the channel "Y", FLOAT, the same pixels.
        ASSERT_TRUE(info.contains("oiio_exr") && info["oiio_exr"].is_object());
        EXPECT_EQ(info["oiio_exr"]["channelnames"], nlohmann::json({"Y"}));
        EXPECT_EQ(info["oiio_exr"]["format"], "float");
        EXPECT_EQ(info["oiio_exr"]["shape"], nlohmann::json({view.height, view.width, 1}));
        const auto oi = readRaw<float>(sub / "oiio_exr.f32", n);
        EXPECT_EQ(0, std::memcmp(oi.data(), view.depth.data(), n * sizeof(float)));

        // OpenImageIO (C++), as sylva's own tools read it.
        {
            auto in = OIIO::ImageInput::open(exr.string());
            ASSERT_TRUE(in) << OIIO::geterror();
            EXPECT_EQ(in->spec().nchannels, 1);
            EXPECT_EQ(in->spec().channelnames.at(0), "Y");
            std::vector<float> back(n);
            ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, back.data()));
            EXPECT_EQ(0, std::memcmp(back.data(), view.depth.data(), n * sizeof(float)));
        }

        // The PNG through OpenCV: uint16, round(depth / scale), 0 exactly where there is no hit.
        ASSERT_TRUE(info.contains("cv2_png") && info["cv2_png"].is_object());
        EXPECT_EQ(info["cv2_png"]["dtype"], "uint16");
        EXPECT_EQ(info["cv2_png"]["shape"], nlohmann::json({view.height, view.width}));
        const auto units = readRaw<uint16_t>(sub / "cv2_png.u16", n);
        size_t wrong = 0;
        for (size_t k = 0; k < n; ++k) {
            const double d = view.depth[k];
            const uint16_t want =
                d > 0 ? static_cast<uint16_t>(std::lround(d / scale)) : uint16_t{0};
            wrong += units[k] != want;
            // What instant-ngp computes from it (value × integer_depth_scale) is within half a
            // unit of the depth.
            if (d > 0) {
                EXPECT_LE(std::abs(units[k] * scale - d), 0.5 * scale + 1e-9) << k;
            }
        }
        EXPECT_EQ(wrong, 0u);
    }
}

// The PNG scale: millimetres while the farthest hit fits 65535 of them, then 2, 5, 10, … mm.
TEST(DepthReaders, IntegerDepthScaleHoldsTheFarthestHit) {
    auto viewWith = [](float farthest) {
        ViewImage v;
        v.width = 2;
        v.height = 1;
        v.depth = {0.0f, farthest};
        return v;
    };
    EXPECT_EQ(integerDepthScale({viewWith(1.0f)}), 0.001);
    EXPECT_EQ(integerDepthScale({viewWith(65.535f)}), 0.001);
    EXPECT_EQ(integerDepthScale({viewWith(65.6f)}), 0.002);
    EXPECT_EQ(integerDepthScale({viewWith(131.0f)}), 0.002);
    EXPECT_EQ(integerDepthScale({viewWith(200.0f)}), 0.005);
    EXPECT_EQ(integerDepthScale({viewWith(400.0f)}), 0.01);
    EXPECT_EQ(integerDepthScale({viewWith(1000.0f)}), 0.02);
    EXPECT_EQ(integerDepthScale({viewWith(3.0e6f)}), 50.0);
    EXPECT_EQ(integerDepthScale({viewWith(0.0f)}), 0.001);                   // no hit at all
    EXPECT_EQ(integerDepthScale({viewWith(1.0f), viewWith(70.0f)}), 0.002);  // all views
    // Units: halves round up, no hit stays 0, a hit is never 0, overflow is refused.
    const std::vector<uint16_t> u =
        depthToUnits({0.0f, -1.0f, 0.0104f, 0.0006f, 0.0002f, 65.535f}, 0.001);
    EXPECT_EQ(u, (std::vector<uint16_t>{0, 0, 10, 1, 1, 65535}));
    EXPECT_THROW(depthToUnits({65.6f}, 0.001), std::invalid_argument);
    EXPECT_THROW(depthToUnits({1.0f}, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace sylva
