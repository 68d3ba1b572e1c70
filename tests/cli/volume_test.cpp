// `sylva volume`: the .vdb, PLY and preview of a species' volumes read back and checked
// against closed forms (a ball's voxel count, enclosed volume and projected area), the
// preview's view orientation, the per-instance draw, and bad input (exit 2, nothing written).
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/analysis/volume_output.h"
#include "species/spec/species.h"
#include "tests/cli/cli_support.h"
#include "tests/test_support.h"
#include "volumes/level_set_grid.h"
#include "volumes/vdb/grid.h"

namespace {

namespace fs = std::filesystem;
using namespace sylva;
using sylva::test::slurp;

const fs::path kSource = SYLVA_SOURCE_DIR;

class Scratch {
  public:
    // Named after the running test, or `name` (in SetUpTestSuite there is no current test).
    explicit Scratch(std::string name = "") {
        if (name.empty()) name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
        dir_ = fs::temp_directory_path() /
               ("sylva_volume_test_" + std::to_string(::getpid()) + "_" + name);
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    ~Scratch() {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    fs::path operator/(const std::string& s) const { return dir_ / s; }

  private:
    fs::path dir_;
};

void spit(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

// A species whose only volume is the crown table given.
std::string species(const std::string& name, const std::string& crown,
                    const std::string& extra = "") {
    return "name = \"" + name + "\"\nmethod = \"iterated-graph\"\n\n[crown]\n" + crown + "\n" +
           extra + "\n[[levels]]\nnodes = 50\nendpoints = 3\n";
}

using CliRun = sylva::test::CliResult;

// Runs the CLI with `args` split at spaces (test paths are plain), in the directory that holds
// `scratch`.
CliRun sylvaCli(const std::string& args, const fs::path& scratch) {
    std::vector<std::string> argv;
    std::istringstream in(args);
    for (std::string a; in >> a;) argv.push_back(a);
    return sylva::test::runSylva(argv, scratch.parent_path());
}

struct PlyMesh {
    std::vector<Vec3> vertices;
    std::vector<std::array<uint32_t, 3>> triangles;
};

// Reads the layout meshPly writes: 8 floats, int, 2 uchar per vertex; uchar 3 + 3 uint per
// face. Fails the test on any other header.
PlyMesh readPly(const fs::path& path) {
    const std::string bytes = slurp(path);
    PlyMesh m;
    const size_t end = bytes.find("end_header\n");
    EXPECT_NE(end, std::string::npos);
    if (end == std::string::npos) return m;
    std::istringstream header(bytes.substr(0, end));
    size_t nv = 0, nf = 0;
    for (std::string line; std::getline(header, line);) {
        if (line.rfind("element vertex ", 0) == 0) nv = std::stoul(line.substr(15));
        if (line.rfind("element face ", 0) == 0) nf = std::stoul(line.substr(13));
    }
    const char* p = bytes.data() + end + 11;
    constexpr size_t kVertexBytes = 8 * 4 + 4 + 2, kFaceBytes = 1 + 3 * 4;
    EXPECT_EQ(bytes.size(), end + 11 + nv * kVertexBytes + nf * kFaceBytes);
    if (bytes.size() != end + 11 + nv * kVertexBytes + nf * kFaceBytes) return m;
    for (size_t v = 0; v < nv; ++v, p += kVertexBytes) {
        float xyz[3];
        std::memcpy(xyz, p, sizeof xyz);
        m.vertices.push_back({xyz[0], xyz[1], xyz[2]});
    }
    for (size_t f = 0; f < nf; ++f, p += kFaceBytes) {
        EXPECT_EQ(p[0], 3);
        std::array<uint32_t, 3> t;
        std::memcpy(t.data(), p + 1, sizeof t);
        m.triangles.push_back(t);
    }
    return m;
}

openvdb::FloatGrid::Ptr readVdb(const fs::path& path, const std::string& name) {
    openvdb::initialize();
    openvdb::io::File file(path.string());
    file.open();
    openvdb::GridBase::Ptr base = file.readGrid(name);
    file.close();
    return openvdb::gridPtrCast<openvdb::FloatGrid>(base);
}

double interiorVoxels(const openvdb::FloatGrid& g) {
    double n = 0;
    for (auto it = g.constTree().cbeginValueAll(); it; ++it)
        if (*it <= 0.0f) n += static_cast<double>(it.getVoxelCount());
    return n;
}

struct Image {
    int width = 0, height = 0;
    std::vector<uint8_t> pixels;
    int at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
};

Image readPng(const fs::path& path) {
    Image im;
    auto in = OIIO::ImageInput::open(path.string());
    EXPECT_TRUE(in) << path;
    if (!in) return im;
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(spec.nchannels, 1);
    im.width = spec.width;
    im.height = spec.height;
    im.pixels.resize(static_cast<size_t>(im.width) * im.height);
    EXPECT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, im.pixels.data()));
    return im;
}

constexpr double kR = 2.0;  // the test crown: a sphere of radius 2 m centred 4 m up
const double kBall = 4.0 / 3.0 * kPi * kR * kR * kR;

// --- the sphere crown through the CLI ------------------------------------------------------

class VolumeOutputSphere : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        scratch_ = new Scratch("sphere");
        spec_ = *scratch_ / "ball.toml";
        spit(spec_, species("ball", "type = \"sphere\"\nradius = 2.0\nposition = [0, 4, 0]"));
        run_ = sylvaCli("volume " + spec_.string() + " --out " + (*scratch_ / "out").string(),
                        *scratch_ / "cli");
    }
    static void TearDownTestSuite() {
        delete scratch_;
        scratch_ = nullptr;
    }
    fs::path out(const std::string& f) const { return *scratch_ / "out" / f; }

    static Scratch* scratch_;
    static fs::path spec_;
    static CliRun run_;
};
Scratch* VolumeOutputSphere::scratch_ = nullptr;
fs::path VolumeOutputSphere::spec_;
CliRun VolumeOutputSphere::run_;

TEST_F(VolumeOutputSphere, ExitsZeroAndPrintsOneLinePerVolume) {
    ASSERT_EQ(run_.code, 0) << run_.err;
    EXPECT_NE(run_.out.find("  crown: sphere r=2 m"), std::string::npos) << run_.out;
    EXPECT_NE(run_.out.find("extent 4 × 4 × 4 m"), std::string::npos) << run_.out;
    EXPECT_NE(run_.out.find("voxel 0.03125 m"), std::string::npos) << run_.out;  // 4 m / 128
    for (const char* f : {"crown.vdb", "crown.ply", "preview.png", "volumes.json"})
        EXPECT_TRUE(fs::exists(out(f))) << f;
    // Only the files named, no temp files left behind.
    EXPECT_EQ(std::distance(fs::directory_iterator(*scratch_ / "out"), fs::directory_iterator{}),
              4);
}

TEST_F(VolumeOutputSphere, VdbIsALevelSetWhoseInteriorIsTheBall) {
    ASSERT_EQ(run_.code, 0) << run_.err;
    openvdb::FloatGrid::Ptr g = readVdb(out("crown.vdb"), "crown");
    ASSERT_TRUE(g);
    EXPECT_EQ(g->getGridClass(), openvdb::GRID_LEVEL_SET);
    const double voxel = g->voxelSize()[0];
    EXPECT_DOUBLE_EQ(voxel, 4.0 / 128);
    EXPECT_NEAR(g->background(), 3 * voxel, 1e-6);
    const double expected = kBall / (voxel * voxel * voxel);  // ≈ 1.1 million voxels
    EXPECT_NEAR(interiorVoxels(*g), expected, 0.03 * expected);
    // Signed distance at the centre of the band and just outside: world (0, 6, 0) is on the
    // surface, index space is world / voxel.
    auto acc = g->getConstAccessor();
    EXPECT_NEAR(acc.getValue(openvdb::Coord(0, 192, 0)), 0.0, 1e-6);         // y = 6 m
    EXPECT_NEAR(acc.getValue(openvdb::Coord(0, 190, 0)), -2 * voxel, 1e-6);  // 2 voxels in
    EXPECT_LT(acc.getValue(openvdb::Coord(0, 128, 0)), 0.0f);                // centre: inside
    EXPECT_GT(acc.getValue(openvdb::Coord(0, 0, 0)), 0.0f);                  // ground: outside
}

TEST_F(VolumeOutputSphere, PlyIsClosedOutwardAndEnclosesTheBall) {
    ASSERT_EQ(run_.code, 0) << run_.err;
    const PlyMesh m = readPly(out("crown.ply"));
    ASSERT_GT(m.triangles.size(), 10000u);
    // Closed and consistently oriented: every directed edge once, and its reverse once.
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    for (const auto& t : m.triangles)
        for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
    size_t bad = 0;
    for (const auto& [e, n] : directed)
        if (n != 1 || directed.count({e.second, e.first}) == 0 ||
            directed.at({e.second, e.first}) != 1)
            ++bad;
    EXPECT_EQ(bad, 0u) << "edges not shared by exactly two triangles";
    double volume = 0;
    for (const auto& t : m.triangles)
        volume += dot(m.vertices[t[0]], cross(m.vertices[t[1]], m.vertices[t[2]])) / 6.0;
    EXPECT_GT(volume, 0) << "triangles wound inwards";
    EXPECT_NEAR(volume, kBall, 0.02 * kBall);
    for (const Vec3& v : m.vertices) ASSERT_NEAR(length(v - Vec3{0, 4, 0}), kR, 0.02);
}

TEST_F(VolumeOutputSphere, PreviewHasThreeViewsAndTheManifestItsScale) {
    ASSERT_EQ(run_.code, 0) << run_.err;
    const Image im = readPng(out("preview.png"));
    ASSERT_EQ(im.width, 3 * 512);
    ASSERT_EQ(im.height, 512);
    const nlohmann::json j = nlohmann::json::parse(slurp(out("volumes.json")));
    EXPECT_EQ(j["species"], "ball");
    ASSERT_EQ(j["volumes"].size(), 1u);
    EXPECT_EQ(j["volumes"][0]["extent_m"], nlohmann::json({4.0, 4.0, 4.0}));
    EXPECT_NEAR(j["volumes"][0]["measure_m3"].get<double>(), kBall, 1e-9);
    const double mpp = j["preview"]["metres_per_pixel"];
    // The frame holds the ball and the root point: 6 m high, 92% of a tile.
    EXPECT_NEAR(mpp, 6.0 / (0.92 * 512), 1e-6);  // float vertices
    // Every view of a ball is a disc of radius r: count the drawn pixels above the ground line
    // (y = 0 sits 3 m below the frame centre) in each tile.
    const int groundRow = static_cast<int>(256 + 3.0 / mpp) - 3;
    const double disc = kPi * (kR / mpp) * (kR / mpp);
    for (int view = 0; view < 3; ++view) {
        double n = 0;
        for (int y = 0; y < (view == 2 ? 512 : groundRow); ++y)
            for (int x = view * 512 + 1; x < (view + 1) * 512; ++x) n += im.at(x, y) < 250;
        EXPECT_NEAR(n, disc, 0.02 * disc) << "view " << view;
    }
}

// --- preview orientation, the per-instance draw, named volumes -----------------------------

// Centroid of the drawn (not white) pixels of one tile above row `rows` (the ground line),
// away from `skip` (the root-point cross).
Vec2 centroid(const VolumePreview& p, int tile, int column, int rows, Vec2 skip) {
    double sx = 0, sy = 0, n = 0;
    for (int y = 0; y < rows; ++y)
        for (int x = 1; x < tile; ++x) {
            if (std::hypot(x + 0.5 - skip.x, y + 0.5 - skip.y) < 10) continue;
            if (p.pixels[static_cast<size_t>(y) * p.width + column * tile + x] < 250) {
                sx += x + 0.5;
                sy += y + 0.5;
                n += 1;
            }
        }
    return {sx / n, sy / n};
}

TEST(VolumeOutput, PreviewViewsLookAlongMinusZMinusXAndMinusY) {
    Scratch s;
    spit(s / "off.toml", species("off", "type = \"sphere\"\nradius = 1.0\nposition = [1.5, 3, 2]"));
    VolumeOutputOptions o;
    o.tile = 256;
    const VolumeOutputResult r = writeSpeciesVolumes((s / "off.toml").string(), s / "out", o);
    const VolumePreview p{r.previewWidth, r.previewHeight, r.metresPerPixel,
                          readPng(s / "out" / "preview.png").pixels};
    ASSERT_EQ(p.width, 3 * 256);
    // Frame: the ball's bounds and the origin, x [0, 2.5], y [0, 4], z [0, 3]; centre
    // (1.25, 2, 1.5); the largest extent 4 m spans 92% of a tile.
    const double k = 1.0 / p.metresPerPixel;
    EXPECT_NEAR(p.metresPerPixel, 4.0 / (0.92 * 256), 1e-6);  // float vertices
    const double c = 128;
    // front (from +z): x right, y up
    const int ground = static_cast<int>(c + 2.0 * k) - 3;  // y = 0, 2 m below the centre
    Vec2 f = centroid(p, 256, 0, ground, {-100, -100});
    EXPECT_NEAR(f.x, c + 0.25 * k, 1.5);
    EXPECT_NEAR(f.y, c - 1.0 * k, 1.5);
    // side (from +x): −z right, y up
    Vec2 sd = centroid(p, 256, 1, ground, {-100, -100});
    EXPECT_NEAR(sd.x, c - 0.5 * k, 1.5);
    EXPECT_NEAR(sd.y, c - 1.0 * k, 1.5);
    // top (from +y): x right, −z up; the cross at the origin is left out
    Vec2 t = centroid(p, 256, 2, 256, {c - 1.25 * k, c - 1.5 * k});
    EXPECT_NEAR(t.x, c + 0.25 * k, 1.5);
    EXPECT_NEAR(t.y, c + 0.5 * k, 1.5);
}

TEST(VolumeOutput, DrawnCrownIsTheOneGrowDrawsForTheSeed) {
    Scratch s;
    const fs::path spec = s / "drawn.toml";
    spit(spec, species("drawn", "type = \"sphere\"\nradius = { uniform = [1.0, 3.0] }"));
    const SpeciesFile sp = loadSpecies(spec.string());
    std::vector<double> measures;
    for (uint64_t seed : {3u, 4u}) {
        const double r = growSpecies(sp, seed, nullptr, false).sampled.at("crown.radius");
        VolumeOutputOptions o;
        o.seed = seed;
        o.tile = 64;
        const VolumeOutputResult res = writeSpeciesVolumes(spec.string(), s / "out", o);
        ASSERT_EQ(res.volumes.size(), 1u);
        EXPECT_NEAR(res.volumes[0].measure, 4.0 / 3.0 * kPi * r * r * r, 1e-9 * r * r * r);
        EXPECT_NEAR(res.volumes[0].voxel, 2 * r / 128, 1e-12);
        measures.push_back(res.volumes[0].measure);
    }
    EXPECT_NE(measures[0], measures[1]);
}

TEST(VolumeOutput, EndpointsAndRootsAreWrittenInTheirOwnRows) {
    Scratch s;
    const std::string roots =
        "[endpoints]\ntype = \"box\"\nsize = [2, 1, 2]\nposition = [0.05, 3.05, 0.05]\n\n"
        "[roots]\ntaproot_depth = 1.0\n[roots.volume]\ntype = \"sphere\"\nradius = 1.5\n"
        "[[roots.levels]]\nnodes = 20\nendpoints = 2\n";
    spit(s / "three.toml",
         species("three", "type = \"sphere\"\nradius = 1.0\nposition = [0, 3, 0]", roots));
    VolumeOutputOptions o;
    o.tile = 64;
    o.voxel = 0.1;
    const VolumeOutputResult r = writeSpeciesVolumes((s / "three.toml").string(), s / "out", o);
    ASSERT_EQ(r.volumes.size(), 3u);
    EXPECT_EQ(r.volumes[0].name, "crown");
    EXPECT_EQ(r.volumes[1].name, "endpoints");
    EXPECT_EQ(r.volumes[2].name, "roots");
    EXPECT_EQ(r.previewHeight, 3 * 64);
    for (const auto& v : r.volumes) {
        EXPECT_DOUBLE_EQ(v.voxel, 0.1);
        EXPECT_TRUE(fs::exists(s / "out" / (v.name + ".ply"))) << v.name;
        openvdb::FloatGrid::Ptr g = readVdb(s / "out" / (v.name + ".vdb"), v.name);
        ASSERT_TRUE(g) << v.name;
        EXPECT_EQ(g->getName(), v.name);
    }
    // The 2 × 1 × 2 m box, its faces half-way between voxel centres: 20 × 10 × 20 voxels.
    EXPECT_NEAR(r.volumes[1].levelSetMeasure, 4.0, 1e-9);
    EXPECT_NEAR(r.volumes[1].meshVolume, 4.0, 0.02 * 4.0);
}

TEST(VolumeOutput, LevelSetGridMatchesTheLevelSetVolume) {
    // makeLevelSet answers from the same grid levelSetGrid builds.
    VolumePtr sphere = makePlaced(makeSphere(1.0), Placement{{0.3, 2, -0.1}, {0, 1, 0}, {1, 1, 1}});
    const double voxel = 0.05;
    const openvdb::FloatGrid::Ptr g = levelSetGrid(*sphere, voxel)->grid;
    VolumePtr ls = makeLevelSet(*sphere, voxel);
    auto acc = g->getConstAccessor();
    int compared = 0;
    for (auto it = g->cbeginValueOn(); it; ++it, ++compared) {
        const openvdb::Coord c = it.getCoord();
        const Vec3 p{c.x() * voxel, c.y() * voxel, c.z() * voxel};
        ASSERT_NEAR(ls->signedDistance(p), *it, 1e-6);  // trilinear at a voxel centre
        ASSERT_NEAR(*it, sphere->signedDistance(p), 1e-6);
    }
    EXPECT_GT(compared, 1000);
    EXPECT_THROW(levelSetGrid(*sphere, 0.0), std::invalid_argument);
    EXPECT_THROW(levelSetGrid(*sphere, voxel, 0.5), std::invalid_argument);
}

// --- bad input -------------------------------------------------------------------------------

TEST(VolumeOutput, BadSpeciesExitsTwoWithOneLineAndWritesNothing) {
    Scratch s;
    spit(s / "bad.toml", species("bad", "type = \"sphere\"\nradius = -1.0"));
    const fs::path out = s / "out";
    const CliRun r =
        sylvaCli("volume " + (s / "bad.toml").string() + " --out " + out.string(), s / "cli");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("bad.toml:6:10: crown.radius: expected a number > 0"), std::string::npos)
        << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

TEST(VolumeOutput, TooFineVoxelExitsTwoAndWritesNothing) {
    Scratch s;
    spit(s / "big.toml", species("big", "type = \"sphere\"\nradius = 10.0"));
    const fs::path out = s / "out";
    const CliRun r = sylvaCli(
        "volume " + (s / "big.toml").string() + " --voxel 0.001 --out " + out.string(), s / "cli");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("too fine for the crown volume"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

// Every species fixture in tests/data/bad/ fails writeSpeciesVolumes with its SpecError (the
// CLI maps SpecError to exit 2, checked above) before anything is written. In-process: one
// CLI start per fixture would take a quarter of a second each.
TEST(VolumeOutput, BadFixturesFailBeforeWriting) {
    Scratch s;
    int checked = 0;
    for (const auto& e : fs::directory_iterator(kSource / "tests" / "data" / "bad")) {
        if (e.path().extension() != ".toml") continue;
        const std::string text = slurp(e.path());
        if (text.find("[[species]]") != std::string::npos) continue;  // a dataset file
        std::vector<std::string> expects;
        std::string line;
        std::istringstream in(text);
        while (std::getline(in, line) && line.rfind("#", 0) == 0) {
            if (line.rfind("# expect: ", 0) == 0) expects.push_back(line.substr(10));
            if (line.rfind("# line: ", 0) == 0) expects.push_back(":" + line.substr(8) + ":");
        }
        const fs::path out = s / ("out_" + e.path().stem().string());
        try {
            writeSpeciesVolumes(e.path().string(), out, VolumeOutputOptions{});
            ADD_FAILURE() << e.path() << " was accepted";
        } catch (const SpecError& err) {
            for (const auto& x : expects)
                EXPECT_NE(std::string(err.what()).find(x), std::string::npos)
                    << e.path() << ": " << err.what();
        }
        EXPECT_FALSE(fs::exists(out)) << e.path();
        ++checked;
    }
    EXPECT_GE(checked, 10);
}

}  // namespace
