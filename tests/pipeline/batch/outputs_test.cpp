// End-to-end checks of a built dataset using only what was written to disk: cameras from
// transforms.json (projected here with the nerfstudio / OpenGL convention, independently of
// sylva's Camera class), silhouettes and depth maps read through OpenImageIO, skeletons
// parsed from skeleton.ply, meshes loaded through tinygltf.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"

namespace fs = std::filesystem;
using namespace sylva;

namespace {

struct SkeletonVertex {
    float x, y, z, radius;
    int32_t order;
};

// Parses sylva's binary skeleton PLY (vertex: float x y z radius, int order, uchar part;
// edge: int vertex1 vertex2, appended to `edges` when given).
std::vector<SkeletonVertex> readSkeletonPly(
    const fs::path& path, std::vector<std::pair<int32_t, int32_t>>* edges = nullptr) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    size_t count = 0, edgeCount = 0;
    while (std::getline(in, line) && line != "end_header") {
        if (line.rfind("element vertex ", 0) == 0) count = std::stoul(line.substr(15));
        if (line.rfind("element edge ", 0) == 0) edgeCount = std::stoul(line.substr(13));
    }
    std::vector<SkeletonVertex> v(count);
    for (auto& s : v) {
        char buf[21];
        in.read(buf, sizeof buf);
        std::memcpy(&s.x, buf, 4);
        std::memcpy(&s.y, buf + 4, 4);
        std::memcpy(&s.z, buf + 8, 4);
        std::memcpy(&s.radius, buf + 12, 4);
        std::memcpy(&s.order, buf + 16, 4);
    }
    for (size_t i = 0; edges && i < edgeCount; ++i) {
        int32_t e[2];
        in.read(reinterpret_cast<char*>(e), sizeof e);
        edges->emplace_back(e[0], e[1]);
    }
    return v;
}

template <class T>
std::vector<T> readImage(const fs::path& path, OIIO::TypeDesc type, int& w, int& h) {
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) return {};
    w = in->spec().width;
    h = in->spec().height;
    std::vector<T> px(static_cast<size_t>(w) * h);
    in->read_image(0, 0, 0, 1, type, px.data());
    in->close();
    return px;
}

class BuiltDataset : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        out_ = fs::temp_directory_path() / ("sylva_outputs_test_" + std::to_string(getpid()));
        fs::remove_all(out_);
        spec_ = new DatasetSpec(loadDataset(SYLVA_SOURCE_DIR "/tests/data/tiny_dataset.toml"));
        BuildOptions o;
        o.out = out_;
        o.progress = false;
        summary_ = buildDataset(*spec_, o);
        std::ifstream m(out_ / "manifest.jsonl");
        for (std::string line; std::getline(m, line);)
            records_.push_back(nlohmann::json::parse(line));
    }
    static void TearDownTestSuite() {
        fs::remove_all(out_);
        delete spec_;
    }
    static fs::path out_;
    static DatasetSpec* spec_;
    static BuildSummary summary_;
    static std::vector<nlohmann::json> records_;
};
fs::path BuiltDataset::out_;
DatasetSpec* BuiltDataset::spec_ = nullptr;
BuildSummary BuiltDataset::summary_;
std::vector<nlohmann::json> BuiltDataset::records_;

TEST_F(BuiltDataset, EveryInstanceRecorded) {
    EXPECT_EQ(summary_.failed, 0);
    EXPECT_EQ(records_.size(), static_cast<size_t>(summary_.built));
    EXPECT_GT(records_.size(), 0u);
}

// The species' habit goes with every instance (tiny.toml states "tree", tiny_var.toml none),
// and into dataset.json's species list.
TEST_F(BuiltDataset, HabitRecordedWhenTheSpeciesStatesOne) {
    int tiny = 0;
    for (const auto& rec : records_) {
        if (rec["species"] == "tiny") {
            EXPECT_EQ(rec.at("habit"), "tree");
            ++tiny;
        } else {
            EXPECT_FALSE(rec.contains("habit")) << rec["species"];
        }
    }
    EXPECT_GT(tiny, 0);
    const auto info = nlohmann::json::parse(std::ifstream(out_ / "dataset.json"));
    EXPECT_EQ(info["species"][0]["name"], "tiny");
    EXPECT_EQ(info["species"][0]["habit"], "tree");
    EXPECT_FALSE(info["species"][1].contains("habit"));
}

// Every wood pixel of the written views (label image ≠ leaf), back-projected with the written
// camera (transforms.json, the nerfstudio / OpenGL convention) and the written depth, lies on
// the skeleton's wood: within its segment's larger radius (the tubes' vertices lie on that
// radius; the tip cones reach one radius beyond the tip) plus two pixel footprints of some edge
// of skeleton.ply. A wrong camera, depth or pixel convention would move the points off it.
TEST_F(BuiltDataset, WoodPixelsBackProjectOntoTheSkeleton) {
    size_t checked = 0;
    for (const auto& rec : records_) {
        const fs::path dir = out_ / rec["files"]["transforms"].get<std::string>();
        const nlohmann::json tj = nlohmann::json::parse(std::ifstream(dir));
        const fs::path base = dir.parent_path();
        std::vector<std::pair<int32_t, int32_t>> edges;
        const auto nodes =
            readSkeletonPly(out_ / rec["files"]["skeleton_ply"].get<std::string>(), &edges);
        ASSERT_GT(nodes.size(), 1u);
        ASSERT_EQ(edges.size(), nodes.size() - 1);
        const double fx = tj["fl_x"], fy = tj["fl_y"], cx = tj["cx"], cy = tj["cy"];
        for (const auto& frame : tj["frames"]) {
            int w = 0, h = 0, dw = 0, dh = 0, lw = 0, lh = 0;
            auto sil = readImage<uint8_t>(base / frame["file_path"].get<std::string>(),
                                          OIIO::TypeDesc::UINT8, w, h);
            auto depth = readImage<float>(base / frame["depth_file_path"].get<std::string>(),
                                          OIIO::TypeDesc::FLOAT, dw, dh);
            auto labels = readImage<uint8_t>(base / frame["label_file_path"].get<std::string>(),
                                             OIIO::TypeDesc::UINT8, lw, lh);
            ASSERT_EQ(w, tj["w"].get<int>());
            ASSERT_EQ(h, tj["h"].get<int>());
            ASSERT_TRUE(dw == w && dh == h && lw == w && lh == h);
            const auto& m = frame["transform_matrix"];  // camera-to-world, camera looks along −z
            for (int py = 0; py < h; ++py) {
                for (int px = 0; px < w; ++px) {
                    const size_t k = static_cast<size_t>(py) * w + px;
                    ASSERT_EQ(sil[k] == 255, depth[k] > 0) << "silhouette and depth disagree";
                    if (sil[k] != 255 || labels[k] == 255) continue;  // background or leaf
                    // Camera space: x right, y up, looking along −z at depth z.
                    const double z = depth[k];
                    const double c[3] = {(px + 0.5 - cx) / fx * z, (cy - py - 0.5) / fy * z, -z};
                    double p[3];
                    for (int r = 0; r < 3; ++r) {
                        p[r] = m[r][3].get<double>();
                        for (int j = 0; j < 3; ++j) p[r] += m[r][j].get<double>() * c[j];
                    }
                    const double footprint = z / fx;
                    bool near = false;
                    for (const auto& [i, j] : edges) {
                        const SkeletonVertex &a = nodes[i], &b = nodes[j];
                        const double e[3] = {b.x - a.x, b.y - a.y, b.z - a.z};
                        const double q[3] = {p[0] - a.x, p[1] - a.y, p[2] - a.z};
                        const double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
                        const double t =
                            ee > 0 ? std::clamp((q[0] * e[0] + q[1] * e[1] + q[2] * e[2]) / ee, 0.0,
                                                1.0)
                                   : 0.0;
                        const double d =
                            std::hypot(q[0] - t * e[0], q[1] - t * e[1], q[2] - t * e[2]);
                        near |= d <= std::max(a.radius, b.radius) + 2 * footprint;
                        if (near) break;
                    }
                    ASSERT_TRUE(near) << "wood pixel " << px << "," << py << " off the skeleton";
                    ++checked;
                }
            }
        }
    }
    EXPECT_GT(checked, 500u);
}

// Meshes read back: the GLB through tinygltf has the recorded vertex and triangle counts,
// 32-bit indices, and the branch order attribute; the PLY header agrees too.
TEST_F(BuiltDataset, MeshFilesReadBackWithRecordedCounts) {
    for (const auto& rec : records_) {
        tinygltf::Model model;
        tinygltf::TinyGLTF loader;
        std::string err, warn;
        const std::string glb = (out_ / rec["files"]["mesh_glb"].get<std::string>()).string();
        ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &err, &warn, glb)) << err;
        size_t vertices = 0, triangles = 0;
        bool order = false;
        for (const auto& mesh : model.meshes) {
            for (const auto& prim : mesh.primitives) {
                vertices += model.accessors[prim.attributes.at("POSITION")].count;
                const auto& idx = model.accessors[prim.indices];
                EXPECT_EQ(idx.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
                triangles += idx.count / 3;
                order = order || prim.attributes.count("_ORDER");
            }
        }
        EXPECT_TRUE(order);
        EXPECT_EQ(vertices, rec["stats"]["mesh_vertices"].get<size_t>());
        EXPECT_EQ(triangles, rec["stats"]["mesh_triangles"].get<size_t>());

        std::ifstream ply(out_ / rec["files"]["mesh_ply"].get<std::string>(), std::ios::binary);
        std::string line;
        size_t plyVertices = 0, plyFaces = 0;
        while (std::getline(ply, line) && line != "end_header") {
            if (line.rfind("element vertex ", 0) == 0) plyVertices = std::stoul(line.substr(15));
            if (line.rfind("element face ", 0) == 0) plyFaces = std::stoul(line.substr(13));
        }
        EXPECT_EQ(plyVertices, vertices);
        EXPECT_EQ(plyFaces, triangles);
        if (rec["species"] == "tiny") {  // tiny.toml has a [leaves] table, tiny_var.toml none
            EXPECT_GT(rec["stats"]["leaves"].get<size_t>(), 0u);
            EXPECT_GT(rec["stats"]["leaf_triangles"].get<size_t>(), 0u);
        } else {
            EXPECT_EQ(rec["stats"]["leaves"].get<size_t>(), 0u);
        }
    }
}

// Silhouette statistics in the manifest agree with the written images.
TEST_F(BuiltDataset, RecordedCoverageMatchesWrittenSilhouettes) {
    const auto& rec = records_.front();
    const fs::path tf = out_ / rec["files"]["transforms"].get<std::string>();
    const nlohmann::json tj = nlohmann::json::parse(std::ifstream(tf));
    const auto& coverage = rec["stats"]["silhouette_coverage"];
    ASSERT_EQ(coverage.size(), tj["frames"].size());
    for (size_t i = 0; i < coverage.size(); ++i) {
        int w = 0, h = 0;
        auto sil =
            readImage<uint8_t>(tf.parent_path() / tj["frames"][i]["file_path"].get<std::string>(),
                               OIIO::TypeDesc::UINT8, w, h);
        double tree = static_cast<double>(std::count(sil.begin(), sil.end(), 255));
        EXPECT_NEAR(coverage[i].get<double>(), tree / sil.size(), 1e-12);
        const double fd = rec["stats"]["fractal_dimension"][i];
        EXPECT_GT(fd, 0.8);
        EXPECT_LT(fd, 2.0);
    }
}

// leaf_pixel_fraction: leaf pixels (label 255) over tree pixels (label > 0), counted again in
// the label PNGs as written, over every view of every instance.
TEST_F(BuiltDataset, LeafPixelFractionCountsTheWrittenLabelImages) {
    int withLeaves = 0;
    for (const auto& rec : records_) {
        const fs::path tf = out_ / rec["files"]["transforms"].get<std::string>();
        const nlohmann::json tj = nlohmann::json::parse(std::ifstream(tf));
        double leaf = 0, tree = 0;
        for (const auto& frame : tj["frames"]) {
            int w = 0, h = 0;
            auto labels =
                readImage<uint8_t>(tf.parent_path() / frame["label_file_path"].get<std::string>(),
                                   OIIO::TypeDesc::UINT8, w, h);
            ASSERT_FALSE(labels.empty());
            leaf += static_cast<double>(std::count(labels.begin(), labels.end(), 255));
            tree +=
                static_cast<double>(labels.size() - std::count(labels.begin(), labels.end(), 0));
        }
        ASSERT_GT(tree, 0);
        EXPECT_NEAR(rec["stats"]["leaf_pixel_fraction"].get<double>(), leaf / tree, 1e-12);
        withLeaves += leaf > 0;
    }
    EXPECT_GT(withLeaves, 0);  // tiny.toml has leaves: some views show them
}

}  // namespace
