// The files a simulated laser scan is written as (docs/scanning.md, "Outputs"): LAS 1.4 with the
// labels as Extra Bytes, the PLY that ForestFormer3D / ForAINetV2 load, TreeLearn's .npy, and
// the scanner's trajectory and stations.
//
// Frame: a ScanResult is in the scene's metres with +y up (pipeline/scan/scan_point.h); every
// file here is in the survey frame readers expect, x east, y north, z up:
// survey (x, y, z) = scene (x, −z, y) (surveyFrame()). Headings are compass degrees
// (0 = north = survey +y, 90 = east = +x), as the scanner reports them.
//
// Every file is written atomically (temp + rename, core/atomic_file.h) and the
// same ScanResult and options give the same bytes. Bad points (a non-finite coordinate, a
// return number outside 1 … number of returns ≤ 15, a channel > 3) are a programmer error of
// the scanner: std::invalid_argument, nothing written.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "core/math.h"
#include "pipeline/scan/scan_point.h"
#include "pipeline/scan/scan_spool.h"

namespace sylva {

// Scene (+y up) to survey (z up) coordinates: (x, y, z) → (x, −z, y).
inline Vec3 surveyFrame(double x, double y, double z) { return {x, -z, y}; }

// --- LAS 1.4 -----------------------------------------------------------------------------------
//
// Hand-written to the ASPRS LAS 1.4 R15 specification: Debian 12 packages no LAS library
// (`apt-cache search` finds no liblas, PDAL or LASzip; GDAL has no LAS driver), and the writer is
// a header, two VLRs and fixed-size records (some 250 lines of scan_writers.cpp). LAZ (below)
// compresses them with the vendored laz-perf. Measured: 12 M points/s per core for format 6 (bench
// ScanWrite), far above the scanner's pulse rate.
//
// Header: version 1.4, 375 bytes; global encoding 17 = bit 0 (GPS time is adjusted standard
// GPS time, GPS seconds − 10⁹) | bit 4 (the CRS is WKT, required for point formats 6–10);
// legacy point counts 0 (formats ≥ 6), the 64-bit count and 15 counts by return; scale
// `LasOptions::scale` on every axis, offset floor(min) of each survey axis; bounds of the
// coordinates as stored (scaled integers × scale + offset, so every point read back lies
// inside them); system identifier LasOptions::systemIdentifier; generating software
// "sylva <version>"; file creation day and year: the UTC date of the survey start
// (LasOptions::gpsStart), not the clock, so reruns write identical bytes.
// VLRs: (1) LASF_Projection 2112, the OGC WKT of a local engineering CRS in metres (kLasWkt);
// (2) LASF_Spec 4, the Extra Bytes descriptors of kLasExtraBytes.
// Records: point format 6 (30 bytes) or 7 (36, with RGB), then 19 extra bytes.

// The fields after each base record, in this order: the labels (names as ForestFormer3D's and
// FOR-instance's LAS files spell them; unscaled integers, with their min and max), then the
// beam's elevation and the label's purity (scaled: stored integer × scale; no min or max, whose
// encoding for scaled fields readers disagree on).
struct LasExtraByte {
    const char* name;         // ≤ 32 characters
    uint8_t dataType;         // LAS 1.4 R15 Table "Values for data_type": 1 u8, 3 u16, 4 i16, 6 i32
    uint8_t size;             // bytes
    const char* description;  // ≤ 32 characters
    double scale;             // 0: an unscaled integer
};
inline constexpr std::array<LasExtraByte, 8> kLasExtraBytes{{
    {"treeID", 6, 4, "tree id, 0 = no tree", 0},
    {"treeSP", 3, 2, "species index", 0},
    {"semantic_seg", 1, 1, "1 ground, 2 wood, 3 leaf", 0},
    {"hitObjectId", 6, 4, "scene object hit", 0},
    {"branch_order", 1, 1, "branch order, 0 = stem", 0},
    {"node_id", 6, 4, "skeleton node hit, -1 = none", 0},
    {"elevation", 4, 2, "beam above the horizon, deg", 0.01},
    {"label_purity", 1, 1, "label's share of the echo", 0.01},
}};
constexpr int kLasExtraBytesSize = 19;  // sum of the sizes above

// OGC WKT (CT 1.0, section 7) of the scene's local engineering CRS: metres, x east, y north, its
// origin the scene origin (a tree's base, or the plot centre at x = z = 0, height 0); z is up in
// the same metres. It has no geodetic datum: sylva's scenes are not georeferenced. Two axes,
// local datum type 32767, as GDAL writes a local CS: PROJ 9.1 (Debian 12, what GDAL and PDAL
// read LAS CRSs with) refuses a LOCAL_CS with a third axis ("unexpected AXIS count") and warns
// on a COMPD_CS of LOCAL_CS and VERT_CS; this one it parses without a word (`projinfo`).
extern const char* const kLasWkt;

// How format-7 points are coloured (16 bits a channel, an 8-bit colour × 257).
// What the LAS classification byte holds: the FOR-instance codes (ScanPoint::classification,
// what FOR-instance, ForestFormer3D and TreeLearn read), or ASPRS's standard classes (LAS 1.4
// R15, Table 17), which LAS tools name: ground 2, low vegetation 3 (the ground cover), high
// vegetation 5 (every tree point: stem, branches and leaves), unclassified 1 otherwise. LAS
// tools show the FOR-instance codes under ASPRS names (a stem as "medium vegetation", woody
// branches as "building"); the extra bytes keep wood and leaf (`semantic_seg`) either way.
enum class LasClasses : uint8_t { kForInstance, kAsprs };
uint8_t asprsClass(uint8_t forInstanceClass);

enum class LasColour : uint8_t {
    kNone,   // point format 6: no colour
    kClass,  // format 7, by FOR-instance class (lasClassColour)
    kTree,   // format 7, by tree id: 0 grey, each tree a hue of its own (lasTreeColour)
};

struct LasOptions {
    LasColour colour = LasColour::kNone;            // kNone writes format 6, the others format 7
    LasClasses classes = LasClasses::kForInstance;  // the classification byte
    double scale = 0.001;  // metres per stored integer unit, every axis (> 0)
    // The survey start as adjusted standard GPS time (GPS seconds − 10⁹): written GPS time =
    // gpsStart + ScanPoint::gpsTime. Its UTC date (leap seconds ignored) is the header's file
    // creation day and year. The default 0 is 2011-09-14 01:46:40 GPS (day 257 of 2011).
    double gpsStart = 0;
    std::string systemIdentifier = "SIMULATION";  // ASCII, cut to 32 bytes (e.g. "sylva TLS")
    uint16_t fileSourceId = 0;                    // 0 = not assigned
    uint32_t lazChunkPoints = 50000;  // points per LAZ chunk (writeLaz; ≥ 1), LASzip's default
};

// The header's creation date for an adjusted standard GPS time: {day of year (1 …), year}.
std::array<uint16_t, 2> lasCreationDate(double gpsStart);
// 8-bit colours (the file holds them × 257).
std::array<uint8_t, 3> lasClassColour(uint8_t forInstanceClass);
std::array<uint8_t, 3> lasTreeColour(int32_t treeId);

// Writes `scan` as a LAS 1.4 file (streamed: the points are encoded in blocks, never the whole
// file in memory). Point record fields: docs/scanning.md, "LAS fields". A ScanPointSource (a
// spool on disk, pipeline/scan/scan_spool.h) is read twice: the header's bounds, offsets and
// counts, then the records; the bytes are those of the same points in a ScanResult.
void writeLas(const std::filesystem::path& path, const ScanResult& scan,
              const LasOptions& options = {});
void writeLas(const std::filesystem::path& path, const ScanPointSource& points,
              const LasOptions& options = {});
// The same bytes in memory (tests, small scans).
std::string lasBytes(const ScanResult& scan, const LasOptions& options = {});

// --- LAZ ---------------------------------------------------------------------------------------
//
// The LAS file above compressed as LASzip compresses it (LAZ 1.4, laszip.org): the same header,
// VLRs and point records, with the header's point format bit 7 set (so 134 or 135), the LASzip
// VLR ("laszip encoded" 22204) as a third VLR, and the records in chunks of
// LasOptions::lazChunkPoints points, each compressed on its own with the layered compression of
// point formats 6–10 (LASzip's compressor 3; the extra bytes as BYTE14), then the chunk table,
// whose offset the 8 bytes at the start of the point data hold. The coder is laz-perf's
// (third_party/laz-perf/README.md: Debian 12 packages no LAZ library). Streamed and read twice
// as writeLas; decompressed, the records are writeLas's byte for byte.
void writeLaz(const std::filesystem::path& path, const ScanResult& scan,
              const LasOptions& options = {});
void writeLaz(const std::filesystem::path& path, const ScanPointSource& points,
              const LasOptions& options = {});
std::string lazBytes(const ScanResult& scan, const LasOptions& options = {});

// --- the layouts models load directly ----------------------------------------------------------

// ForestFormer3D / ForAINetV2: binary little-endian PLY, one `vertex` element with double x, y, z
// (survey frame, metres, not offset: the loader centres the cloud itself) and int semantic_seg
// (1 ground, 2 wood, 3 leaf: ScanPoint::semantic, written as is) and int treeID (0 = no tree).
// The official loader subtracts 1 from semantic_seg (ground becomes class 0, background) —
// SmartForest-no/ForestFormer3D, data/ForAINetV2/load_forainetv2_data.py lines 162–163 — so the
// file holds 1/2/3 and the network's classes are 0/1/2. No comment lines: that loader's header
// parser takes any line containing "element" or "property" for one.
void writeForestFormerPly(const std::filesystem::path& path, const ScanResult& scan);
void writeForestFormerPly(const std::filesystem::path& path, const ScanPointSource& points);
std::string forestFormerPlyBytes(const ScanResult& scan);

// TreeLearn (ecker-lab/TreeLearn, tree_learn/util/data_preparation.py, load_data): an .npy
// array of float64, shape (N, 4): x, y, z (survey frame, metres) and the label −1 unclassified,
// 0 non-tree, ≥ 1 tree id. The label is what load_data derives from a FOR-instance LAS file, so
// the .npy and sylva's LAS give TreeLearn the same input: treeID where treeID ≠ 0, then 0 where
// the class is 1 (low vegetation) or 2 (terrain), −1 for everything else (out-points, or hits
// without a tree and without a ground class).
int32_t treeLearnLabel(const ScanPoint& point);
void writeTreeLearnNpy(const std::filesystem::path& path, const ScanResult& scan);
void writeTreeLearnNpy(const std::filesystem::path& path, const ScanPointSource& points);
std::string treeLearnNpyBytes(const ScanResult& scan);

// --- the scanner -------------------------------------------------------------------------------

// trajectory.csv: a header row, then one row per ScanPose in order:
//   gps_time  adjusted standard GPS seconds (gpsStart + pose time, as the LAS points), 6 decimals
//   x, y, z   the scanner's position, survey frame, metres, 4 decimals
//   heading_deg  compass heading of travel, degrees (0 for a TLS station), 4 decimals
//   channel   the LAS scanner channel of the points shot from here (0 … 3)
std::string trajectoryCsv(const ScanResult& scan, double gpsStart = 0);
void writeTrajectory(const std::filesystem::path& path, const ScanResult& scan,
                     double gpsStart = 0);

// stations.json (TLS): an array with one object per pose (a TLS scan has one per station), in
// order: {"station": k (0-based), "channel", "x", "y", "z" (survey frame, metres), "gps_time"
// (adjusted standard GPS seconds of its first pulse)}.
nlohmann::json stationsJson(const ScanResult& scan, double gpsStart = 0);
void writeStations(const std::filesystem::path& path, const ScanResult& scan, double gpsStart = 0);

}  // namespace sylva
