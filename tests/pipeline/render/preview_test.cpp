// Preview raster: framing, thickness, sub-pixel twigs, determinism and the PNG round trip.
#include "pipeline/render/preview.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>

#include "pipeline/formats/view_writers.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

namespace fs = std::filesystem;

// The documented framing: x-y box including radii, centred, 4% margin per side.
struct Framing {
    double cx, cy, scale;
    int size;
    double px(double x) const { return (x - cx) * scale + 0.5 * size; }
    double py(double y) const { return 0.5 * size - (y - cy) * scale; }
};
Framing framing(double lox, double hix, double loy, double hiy, int size) {
    return {0.5 * (lox + hix), 0.5 * (loy + hiy), size * 0.92 / std::max(hix - lox, hiy - loy),
            size};
}

uint8_t at(const std::vector<uint8_t>& img, int size, int x, int y) {
    return img.at(static_cast<size_t>(y) * size + x);
}

TEST(Preview, VerticalThickSegmentIsCentredBlackBar) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    addNode(t, 0, {0, 1, 0}, 0.1);
    const int n = 200;
    auto img = renderPreview(t, n);
    ASSERT_EQ(img.size(), size_t(n) * n);
    // scale = 200 * 0.92 / 1.2 = 153.3 px/m -> bar half-width 15.3 px around x = 100.
    for (int y : {20, 60, 100, 140, 180}) {
        for (int dx : {-10, -1, 0, 9}) EXPECT_EQ(at(img, n, 100 + dx, y), 0) << dx << "," << y;
        EXPECT_EQ(at(img, n, 100 - 25, y), 255);
        EXPECT_EQ(at(img, n, 100 + 24, y), 255);
    }
    EXPECT_EQ(at(img, n, 0, 0), 255);
    EXPECT_EQ(at(img, n, n - 1, 0), 255);
    EXPECT_EQ(at(img, n, 0, n - 1), 255);
    EXPECT_EQ(at(img, n, n - 1, n - 1), 255);
    // Margin rows (top 4% = 8 px) stay white; the capsule reaches into row 9.
    for (int x = 0; x < n; ++x) EXPECT_EQ(at(img, n, x, 5), 255);
    EXPECT_LT(at(img, n, 100, 9), 128);
    // Anti-aliased edge: some pixels strictly between ink and paper.
    int grey = 0;
    for (int x = 80; x < 120; ++x) grey += at(img, n, x, 100) > 0 && at(img, n, x, 100) < 255;
    EXPECT_GE(grey, 1);
}

TEST(Preview, SubPixelTwigStillShows) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.05);
    addNode(t, 0, {0, 1, 0}, 0.05);
    addNode(t, 1, {0.1, 1.04, 0}, 0.0001);  // tapers from the trunk's 0.05 m
    addNode(t, 2, {0.5, 1.2, 0}, 0.0001);   // a 0.0001 m twig all along: 0.02 px wide
    const int n = 256;
    auto img = renderPreview(t, n);
    Framing f = framing(-0.05, 0.5001, -0.05, 1.2001, n);
    // The 0.5 px minimum radius gives every column along the twig a pixel darker than 50%
    // (without it a 0.02 px line would almost never reach 50% coverage).
    for (int x = int(f.px(0.15)); x <= int(f.px(0.45)); ++x) {
        double yLine = f.py(1.04 + (f.cx + (x + 0.5 - 0.5 * n) / f.scale - 0.1) * 0.4);
        int darkest = 255;
        for (int y = int(yLine) - 2; y <= int(yLine) + 2; ++y) {
            darkest = std::min<int>(darkest, at(img, n, x, y));
        }
        EXPECT_LT(darkest, 128) << "column " << x;
        // ...but it stays thin: pixels a few rows away are untouched paper.
        EXPECT_EQ(at(img, n, x, int(yLine) - 4), 255);
        EXPECT_EQ(at(img, n, x, int(yLine) + 4), 255);
    }
}

TEST(Preview, GroundLineOnlyWithRootSystem) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.05);
    addNode(t, 0, {0, 1, 0}, 0.05);
    const int n = 128;
    auto noRoots = renderPreview(t, n);
    for (int y = 0; y < n; ++y) EXPECT_EQ(at(noRoots, n, 2, y), 255);
    addNode(t, 0, {0.1, -0.5, 0}, 0.02, 0, kRootPart);
    auto img = renderPreview(t, n);
    int darkest = 255;
    for (int y = 0; y < n; ++y) darkest = std::min<int>(darkest, at(img, n, 2, y));
    EXPECT_GT(darkest, 120);  // grey, not black
    EXPECT_LT(darkest, 210);
}

TEST(Preview, DeterministicAcrossThreadCounts) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2);
    for (int i = 1; i < 400; ++i) {
        double a = i * 2.399963;
        addNode(t, (i - 1) / 3, {std::cos(a) * i * 0.01, i * 0.02, std::sin(a) * i * 0.01},
                0.2 / (1 + i * 0.05));
    }
    auto many = renderPreview(t, 300);
    std::vector<uint8_t> one;
    tbb::task_arena single(1);
    single.execute([&] { one = renderPreview(t, 300); });
    EXPECT_EQ(many, one);
    EXPECT_LT(*std::min_element(many.begin(), many.end()), 128);
}

TEST(Preview, EdgeCases) {
    EXPECT_THROW(renderPreview(Tree{}, 0), std::invalid_argument);
    auto empty = renderPreview(Tree{}, 16);
    EXPECT_EQ(empty, std::vector<uint8_t>(256, 255));
    Tree single;
    addNode(single, -1, {0, 0, 0}, 0.0);
    EXPECT_EQ(renderPreview(single, 8).size(), 64u);
}

TEST(Preview, PngRoundTripWithOiio) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    addNode(t, 0, {0.3, 1, 0}, 0.05);
    fs::path dir = fs::temp_directory_path() / ("sylva_preview_test_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::path file = dir / "sub" / "tree.png";
    writePreviewPng(t, file, 96);
    writePreviewPng(t, file, 96);  // replacing an existing file works too

    auto in = OIIO::ImageInput::open(file.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(spec.width, 96);
    EXPECT_EQ(spec.height, 96);
    EXPECT_EQ(spec.nchannels, 1);
    EXPECT_EQ(spec.format, OIIO::TypeDesc::UINT8);
    std::vector<uint8_t> pixels(96 * 96);
    ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, pixels.data()));
    in->close();
    EXPECT_EQ(pixels, renderPreview(t, 96));

    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir / "sub")) names.push_back(e.path().filename());
    EXPECT_EQ(names, std::vector<std::string>{"tree.png"});  // no temp files left
    fs::remove_all(dir);
}

}  // namespace
}  // namespace sylva
