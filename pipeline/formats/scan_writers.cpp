#include "pipeline/formats/scan_writers.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <lazperf/lazperf.hpp>
#include <lazperf/vlr.hpp>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string_view>

#include "core/atomic_file.h"
#include "core/params.h"

namespace sylva {

namespace fs = std::filesystem;

const char* const kLasWkt =
    "LOCAL_CS[\"sylva scene (metres; x east, y north, z up)\","
    "LOCAL_DATUM[\"sylva scene origin\",32767],"
    "UNIT[\"metre\",1,AUTHORITY[\"EPSG\",\"9001\"]],"
    "AXIS[\"X\",EAST],AXIS[\"Y\",NORTH]]";

namespace {

using Sink = std::function<void(std::string_view)>;
// Stores `bytes` over bytes already sunk, at byte `offset` of the output: the one value a LAZ
// file needs that is known only after its points (the chunk table's offset).
using Patch = std::function<void(uint64_t offset, std::string_view bytes)>;

// Points encoded per block before they go to the sink: bounded memory whatever the scan size.
constexpr size_t kBlockPoints = 1 << 16;

// Little-endian appends (explicit byte order: identical files on any host).
void putU8(std::string& o, uint8_t v) { o.push_back(static_cast<char>(v)); }
void putU16(std::string& o, uint16_t v) {
    for (int i = 0; i < 2; ++i) o.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void putU32(std::string& o, uint32_t v) {
    for (int i = 0; i < 4; ++i) o.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void putU64(std::string& o, uint64_t v) {
    for (int i = 0; i < 8; ++i) o.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void putI64(std::string& o, int64_t v) { putU64(o, static_cast<uint64_t>(v)); }
void putF64(std::string& o, double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    putU64(o, bits);
}
// A char[n] field: the text cut to n bytes, the rest NUL (as the specification asks).
void putText(std::string& o, std::string_view text, size_t n) {
    const size_t k = std::min(text.size(), n);
    o.append(text.data(), k);
    o.append(n - k, '\0');
}

// Little-endian stores at a cursor that then moves on, into a block sized beforehand (appending
// byte by byte took 1.6x the time for the PLY: bench ScanWrite).
struct Cursor {
    char* p;
    template <typename T>
    void le(T v, int bytes) {
        for (int i = 0; i < bytes; ++i) *p++ = static_cast<char>((uint64_t(v) >> (8 * i)) & 0xff);
    }
    void u8(uint8_t v) { *p++ = static_cast<char>(v); }
    void u16(uint16_t v) { le(v, 2); }
    void i16(int16_t v) { le(static_cast<uint16_t>(v), 2); }
    void i32(int32_t v) { le(static_cast<uint32_t>(v), 4); }
    void f64(double v) {
        uint64_t bits;
        std::memcpy(&bits, &v, 8);
        le(bits, 8);
    }
};

// Encodes one record of `size` bytes per point with record(cursor, point), up to kBlockPoints
// at a time into the sink, reading the points as `points` hands them out.
template <typename Record>
void encodeRecords(const ScanPointSource& points, size_t size, const Sink& sink, Record&& record) {
    std::string block;
    points.forEachBlock([&](const ScanPoint* p, size_t n) {
        for (size_t first = 0; first < n; first += kBlockPoints) {
            const size_t count = std::min(kBlockPoints, n - first);
            block.resize(count * size);
            Cursor c{block.data()};
            for (size_t i = first; i < first + count; ++i) record(c, p[i]);
            if (c.p != block.data() + block.size()) throw std::logic_error("record size mismatch");
            sink(block);
        }
    });
}

void checkPoint(const ScanPoint& p, size_t index) {
    auto fail = [&](const std::string& what) {
        throw std::invalid_argument("scan point " + std::to_string(index) + ": " + what);
    };
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        fail("non-finite coordinate");
    }
    if (!std::isfinite(p.gpsTime)) fail("non-finite GPS time");
    if (!std::isfinite(p.scanAngleDeg)) fail("non-finite scan angle");
    if (!std::isfinite(p.elevationDeg)) fail("non-finite elevation");
    if (!std::isfinite(p.labelPurity)) fail("non-finite label purity");
    if (p.numberOfReturns < 1 || p.numberOfReturns > 15) {
        fail("number of returns " + std::to_string(p.numberOfReturns) + " outside 1 … 15");
    }
    if (p.returnNumber < 1 || p.returnNumber > p.numberOfReturns) {
        fail("return number " + std::to_string(p.returnNumber) + " outside 1 … " +
             std::to_string(p.numberOfReturns));
    }
    if (p.channel > 3) fail("scanner channel " + std::to_string(p.channel) + " > 3");
}

// Rounds half away from zero, as std::llround, inline: the libm calls for the coordinates and
// the scan angle were a fifth of the LAS encoding time (bench ScanWrite: 100 → 79 ms per
// million points). Finite |x| < 2⁶³ only; the callers check.
int64_t roundHalfAway(double x) {
    return x >= 0 ? static_cast<int64_t>(x + 0.5) : -static_cast<int64_t>(0.5 - x);
}

// The extra-byte values of a point, in kLasExtraBytes order.
std::array<int64_t, kLasExtraBytes.size()> extraValues(const ScanPoint& p) {
    return {p.label.treeId,
            p.label.species,
            p.semantic,
            p.label.objectId,
            p.label.branchOrder,
            p.label.nodeId,
            roundHalfAway(std::clamp(static_cast<double>(p.elevationDeg), -90.0, 90.0) / 0.01),
            roundHalfAway(std::clamp(static_cast<double>(p.labelPurity), 0.0, 1.0) / 0.01)};
}

// Everything the header needs, from one pass over the points (which it also checks).
struct LasSummary {
    Vec3 rawMin{0, 0, 0}, rawMax{0, 0, 0};  // survey frame, metres
    Vec3 offset{0, 0, 0};
    std::array<uint64_t, 15> byReturn{};
    std::array<int64_t, kLasExtraBytes.size()> ebMin{}, ebMax{};
};

// The stored integer of coordinate v on an axis.
int64_t quantize(double v, double offset, double scale) {
    return roundHalfAway((v - offset) / scale);
}

LasSummary summarize(const ScanPointSource& points, const LasOptions& options) {
    if (!(options.scale > 0) || !std::isfinite(options.scale)) {
        throw std::invalid_argument("LAS scale must be a positive finite number");
    }
    LasSummary s;
    const double inf = std::numeric_limits<double>::infinity();
    Vec3 lo{inf, inf, inf}, hi{-inf, -inf, -inf};
    s.ebMin.fill(std::numeric_limits<int64_t>::max());
    s.ebMax.fill(std::numeric_limits<int64_t>::min());
    uint64_t index = 0;
    points.forEachBlock([&](const ScanPoint* block, size_t n) {
        for (size_t i = 0; i < n; ++i, ++index) {
            const ScanPoint& p = block[i];
            checkPoint(p, index);
            const Vec3 q = surveyFrame(p.x, p.y, p.z);
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], q[a]);
                hi[a] = std::max(hi[a], q[a]);
            }
            ++s.byReturn[p.returnNumber - 1];
            const auto eb = extraValues(p);
            for (size_t k = 0; k < eb.size(); ++k) {
                s.ebMin[k] = std::min(s.ebMin[k], eb[k]);
                s.ebMax[k] = std::max(s.ebMax[k], eb[k]);
            }
        }
    });
    if (index == 0) return s;  // bounds, offset and extra-byte ranges all 0
    for (int a = 0; a < 3; ++a) {
        s.offset[a] = std::floor(lo[a]);
        for (double v : {lo[a], hi[a]}) {
            const double units = (v - s.offset[a]) / options.scale;  // checked before rounding
            if (!(std::fabs(units) < 2147483647.0)) {
                throw std::invalid_argument("scan extent " + formatFixed(hi[a] - lo[a], 3) +
                                            " m too large for LAS scale " +
                                            formatFixed(options.scale, 6) + " m");
            }
        }
        // The bounds of the coordinates as stored: rounding is monotonic, so the extreme points
        // stay the extremes and every point read back lies inside.
        s.rawMin[a] = quantize(lo[a], s.offset[a], options.scale) * options.scale + s.offset[a];
        s.rawMax[a] = quantize(hi[a], s.offset[a], options.scale) * options.scale + s.offset[a];
    }
    return s;
}

constexpr int kLasHeaderSize = 375;
constexpr int kVlrHeaderSize = 54;
constexpr int kExtraBytesDescriptorSize = 192;

// A VLR: 54-byte header, then `data`.
void putVlr(std::string& o, std::string_view userId, uint16_t recordId,
            std::string_view description, std::string_view data) {
    putU16(o, 0);  // reserved
    putText(o, userId, 16);
    putU16(o, recordId);
    putU16(o, static_cast<uint16_t>(data.size()));
    putText(o, description, 32);
    o.append(data.data(), data.size());
}

// The Extra Bytes VLR payload: one 192-byte descriptor per field (LAS 1.4 R15, "Extra Bytes").
// Options: for the unscaled fields min and max (bits 1, 2) when the file has points, the no_data
// value −1 (bit 0) for node_id, integers upcast to 8 bytes (signed as int64, unsigned as
// uint64); for the scaled ones the scale (bit 3) alone.
std::string extraBytesPayload(const LasSummary& s, bool hasPoints) {
    std::string o;
    for (size_t k = 0; k < kLasExtraBytes.size(); ++k) {
        const LasExtraByte& eb = kLasExtraBytes[k];
        const bool noData = std::string_view(eb.name) == "node_id";
        const bool isSigned = eb.dataType == 2 || eb.dataType == 4 || eb.dataType == 6;
        auto put8 = [&](int64_t v) {
            isSigned ? putI64(o, v) : putU64(o, static_cast<uint64_t>(v));
        };
        const bool scaled = eb.scale > 0, range = hasPoints && !scaled;
        const size_t start = o.size();
        putU16(o, 0);  // reserved
        putU8(o, eb.dataType);
        putU8(o, static_cast<uint8_t>((noData ? 1 : 0) | (range ? 2 | 4 : 0) | (scaled ? 8 : 0)));
        putText(o, eb.name, 32);
        o.append(4, '\0');  // unused
        put8(noData ? -1 : 0);
        o.append(16, '\0');  // deprecated1
        put8(range ? s.ebMin[k] : 0);
        o.append(16, '\0');  // deprecated2
        put8(range ? s.ebMax[k] : 0);
        o.append(16, '\0');   // deprecated3
        putF64(o, eb.scale);  // scale (0 when unused)
        o.append(16, '\0');   // deprecated4
        putF64(o, 0);         // offset (unused)
        o.append(16, '\0');   // deprecated5
        putText(o, eb.description, 32);
        if (o.size() - start != kExtraBytesDescriptorSize) {
            throw std::logic_error("extra bytes descriptor is not 192 bytes");
        }
    }
    return o;
}

uint8_t to8(double unit) {
    return static_cast<uint8_t>(std::lround(std::clamp(unit, 0.0, 1.0) * 255));
}

// Days since 1970-01-01 to a civil date (Hinnant's days_from_civil inverse, proleptic
// Gregorian).
void civilFromDays(int64_t z, int64_t& y, unsigned& m, unsigned& d) {
    z += 719468;
    const int64_t era = (z >= 0 ? z : z - 146096) / 146097;
    const unsigned doe = static_cast<unsigned>(z - era * 146097);
    const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    y = static_cast<int64_t>(yoe) + era * 400;
    const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const unsigned mp = (5 * doy + 2) / 153;
    d = doy - (153 * mp + 2) / 5 + 1;
    m = mp < 10 ? mp + 3 : mp - 9;
    y += m <= 2;
}

// Days since 1970-01-01 of a proleptic Gregorian date (Hinnant's days_from_civil).
int64_t daysFromCivil(int64_t y, unsigned m, unsigned d) {
    y -= m <= 2;
    const int64_t era = (y >= 0 ? y : y - 399) / 400;
    const unsigned yoe = static_cast<unsigned>(y - era * 400);
    const unsigned doy = (153 * (m > 2 ? m - 3 : m + 9) + 2) / 5 + d - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + static_cast<int64_t>(doe) - 719468;
}

// LAZ point data (LASzip's chunked compression, layered for formats 6–10 as LAZ 1.4 asks; the
// coder is laz-perf's, third_party/laz-perf): the records in chunks of `chunkPoints`, each
// compressed on its own, then the chunk table: version 0, the number of chunks and, arithmetic
// coded, each chunk's size in bytes (as LASzip's LASwritePoint::write_chunk_table; no point
// counts, the chunks being of fixed size). A chunk's compressed layers are held until it ends:
// memory is bounded by the chunk, not the file.
class LazChunks {
  public:
    // `at`: the byte offset in the file where the first chunk starts.
    LazChunks(int format, size_t recordSize, uint32_t chunkPoints, const Sink& sink, uint64_t at)
        : format_(format),
          recordSize_(recordSize),
          chunkPoints_(chunkPoints),
          sink_(sink),
          at_(at),
          out_([this](const unsigned char* b, size_t n) {
              sink_(std::string_view(reinterpret_cast<const char*>(b), n));
              at_ += n;
          }) {}
    LazChunks(const LazChunks&) = delete;  // out_ points at this object
    LazChunks& operator=(const LazChunks&) = delete;

    // Whole records, `recordSize` bytes each.
    void add(std::string_view records) {
        for (size_t k = 0; k < records.size(); k += recordSize_) {
            if (!compressor_) {
                compressor_ = lazperf::build_las_compressor(out_, format_, kLasExtraBytesSize);
                chunkStart_ = at_;
            }
            compressor_->compress(records.data() + k);
            if (++inChunk_ == chunkPoints_) endChunk();
        }
    }

    // Ends the last chunk and writes the table; returns the table's byte offset.
    uint64_t finish() {
        if (compressor_) endChunk();
        const uint64_t table = at_;
        std::string head;
        putU32(head, 0);  // version
        putU32(head, static_cast<uint32_t>(sizes_.size()));
        out_(reinterpret_cast<const unsigned char*>(head.data()), head.size());
        if (!sizes_.empty()) lazperf::compress_chunk_table(out_, sizes_);
        return table;
    }

  private:
    void endChunk() {
        compressor_->done();
        compressor_.reset();
        const uint64_t size = at_ - chunkStart_;
        if (size > std::numeric_limits<uint32_t>::max()) {
            throw std::logic_error("LAZ chunk over 4 GiB");
        }
        sizes_.push_back(static_cast<uint32_t>(size));
        inChunk_ = 0;
    }

    int format_;
    size_t recordSize_;
    uint32_t chunkPoints_;
    const Sink& sink_;
    uint64_t at_, chunkStart_ = 0;
    lazperf::OutputCb out_;
    lazperf::las_compressor::ptr compressor_;
    uint32_t inChunk_ = 0;
    std::vector<uint32_t> sizes_;
};

// LAS, or with `patch` LAZ: the same header, VLRs and records, the LAZ with the point format's
// bit 7 set (compressed), the LASzip VLR (user id "laszip encoded", record 22204) after the two
// others, and in place of the records the chunk table's offset (8 bytes, patched in at the end)
// followed by the compressed chunks and the chunk table (LASzip's layout, laszip.org).
void encodeLas(const ScanPointSource& points, const LasOptions& options, const Sink& sink,
               const Patch* patch = nullptr) {
    const LasSummary s = summarize(points, options);
    const bool rgb = options.colour != LasColour::kNone;
    const bool asprs = options.classes == LasClasses::kAsprs;
    const bool laz = patch != nullptr;
    if (laz && options.lazChunkPoints == 0) {
        throw std::invalid_argument("LAZ chunk size must be at least 1 point");
    }
    const uint8_t format = rgb ? 7 : 6;
    const int baseSize = rgb ? 36 : 30;
    const int recordSize = baseSize + kLasExtraBytesSize;
    const bool hasPoints = points.size() > 0;

    std::string vlrs;
    const std::string wkt = std::string(kLasWkt) + '\0';  // null-terminated, as R15 asks
    putVlr(vlrs, "LASF_Projection", 2112, "OGC coordinate system WKT", wkt);
    putVlr(vlrs, "LASF_Spec", 4, "sylva labels", extraBytesPayload(s, hasPoints));
    if (laz) {
        // compressor 3 (layered chunked), coder 0 (arithmetic), the LASzip version the coder
        // matches, options 0, the chunk size, two −1 (no special EVLRs), then the items:
        // POINT14, RGB14 (format 7) and BYTE14 (the extra bytes), version 3 each.
        const std::vector<char> v =
            lazperf::laz_vlr(format, kLasExtraBytesSize, options.lazChunkPoints).data();
        putVlr(vlrs, "laszip encoded", 22204, "laz-perf 3.4.0 (sylva)",
               std::string_view(v.data(), v.size()));
    }
    const uint32_t pointOffset = static_cast<uint32_t>(kLasHeaderSize + vlrs.size());

    const std::array<uint16_t, 2> date = lasCreationDate(options.gpsStart);
    std::string h;
    h.reserve(kLasHeaderSize);
    putText(h, "LASF", 4);
    putU16(h, options.fileSourceId);
    putU16(h, 1 | 16);   // adjusted standard GPS time | WKT
    h.append(16, '\0');  // project GUID
    putU8(h, 1);
    putU8(h, 4);
    putText(h, options.systemIdentifier, 32);
    putText(h, std::string("sylva ") + SYLVA_VERSION, 32);
    putU16(h, date[0]);
    putU16(h, date[1]);
    putU16(h, kLasHeaderSize);
    putU32(h, pointOffset);
    putU32(h, laz ? 3 : 2);                                    // VLRs
    putU8(h, static_cast<uint8_t>(format | (laz ? 128 : 0)));  // bit 7: LAZ-compressed
    putU16(h, static_cast<uint16_t>(recordSize));
    putU32(h, 0);        // legacy point count: 0 for formats ≥ 6
    h.append(20, '\0');  // legacy points by return
    for (int a = 0; a < 3; ++a) putF64(h, options.scale);
    for (int a = 0; a < 3; ++a) putF64(h, s.offset[a]);
    for (int a = 0; a < 3; ++a) {
        putF64(h, s.rawMax[a]);
        putF64(h, s.rawMin[a]);
    }
    putU64(h, 0);  // waveform data packets
    putU64(h, 0);  // first EVLR
    putU32(h, 0);  // EVLRs
    putU64(h, points.size());
    for (uint64_t n : s.byReturn) putU64(h, n);
    if (h.size() != kLasHeaderSize) throw std::logic_error("LAS header is not 375 bytes");
    sink(h);
    sink(vlrs);

    auto record = [&](Cursor& c, const ScanPoint& p) {
        const Vec3 q = surveyFrame(p.x, p.y, p.z);
        for (int a = 0; a < 3; ++a) {
            c.i32(static_cast<int32_t>(quantize(q[a], s.offset[a], options.scale)));
        }
        c.u16(p.intensity);
        c.u8(static_cast<uint8_t>(p.returnNumber | (p.numberOfReturns << 4)));
        // Classification flags (bits 0–3) 0: the points are the simulated instrument's returns.
        c.u8(static_cast<uint8_t>((p.channel << 4) | (p.scanDirection ? 64 : 0) |
                                  (p.edgeOfFlightLine ? 128 : 0)));
        c.u8(asprs ? asprsClass(p.classification) : p.classification);
        c.u8(p.label.part);  // user data: the ScanPart hit
        const double angle = std::clamp(p.scanAngleDeg / 0.006, -30000.0, 30000.0);
        c.i16(static_cast<int16_t>(roundHalfAway(angle)));
        c.u16(p.sourceId);  // point source ID: the TLS station or flight strip index + 1
        c.f64(options.gpsStart + p.gpsTime);
        if (rgb) {
            const auto col = options.colour == LasColour::kClass ? lasClassColour(p.classification)
                                                                 : lasTreeColour(p.label.treeId);
            for (uint8_t v : col) c.u16(static_cast<uint16_t>(v * 257));
        }
        // The extra bytes, as their descriptors say: each value's low `size` bytes, little-endian
        // (two's complement for the signed ones).
        const auto eb = extraValues(p);
        for (size_t k = 0; k < eb.size(); ++k) {
            c.le(static_cast<uint64_t>(eb[k]), kLasExtraBytes[k].size);
        }
    };
    if (!laz) {
        encodeRecords(points, recordSize, sink, record);
        return;
    }
    sink(std::string(8, '\0'));  // the chunk table's offset, patched below
    LazChunks chunks(format, recordSize, options.lazChunkPoints, sink, pointOffset + 8);
    encodeRecords(
        points, recordSize, [&](std::string_view records) { chunks.add(records); }, record);
    std::string tableOffset;
    putU64(tableOffset, chunks.finish());
    (*patch)(pointOffset, tableOffset);
}

using Encoder = std::function<void(const Sink&, const Patch&)>;

std::string toBytes(const Encoder& encode) {
    std::string out;
    encode([&](std::string_view b) { out.append(b.data(), b.size()); },
           [&](uint64_t offset, std::string_view b) { out.replace(offset, b.size(), b); });
    return out;
}

// Straight into the atomic file, a block at a time. The file is created at the first bytes, so
// an encoder that throws while checking its points (before any output) leaves nothing behind,
// not even a directory.
void toFile(const fs::path& path, const Encoder& encode) {
    std::optional<AtomicFileWriter> file;
    encode(
        [&](std::string_view b) {
            if (!file) file.emplace(path);
            file->write(b);
        },
        [&](uint64_t offset, std::string_view b) { file->overwrite(offset, b); });
    if (!file) file.emplace(path);
    file->commit();
}

void checkAll(const ScanPointSource& points) {
    uint64_t index = 0;
    points.forEachBlock([&](const ScanPoint* p, size_t n) {
        for (size_t i = 0; i < n; ++i, ++index) checkPoint(p[i], index);
    });
}

void encodePly(const ScanPointSource& points, const Sink& sink) {
    checkAll(points);
    sink("ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(points.size()) +
         "\nproperty double x\nproperty double y\nproperty double z\n"
         "property int semantic_seg\nproperty int treeID\nend_header\n");
    encodeRecords(points, 32, sink, [&](Cursor& c, const ScanPoint& p) {
        const Vec3 q = surveyFrame(p.x, p.y, p.z);
        for (int a = 0; a < 3; ++a) c.f64(q[a]);
        c.i32(p.semantic);
        c.i32(p.label.treeId);
    });
}

// NPY format 1.0 (numpy.lib.format): magic, version, header length, then a Python dict literal
// padded with spaces to a multiple of 64 bytes and ended by '\n'.
void encodeNpy(const ScanPointSource& points, const Sink& sink) {
    checkAll(points);
    std::string dict = "{'descr': '<f8', 'fortran_order': False, 'shape': (" +
                       std::to_string(points.size()) + ", 4), }";
    const size_t unpadded = 10 + dict.size() + 1;
    dict.append((64 - unpadded % 64) % 64, ' ');
    dict.push_back('\n');
    std::string head = "\x93NUMPY";
    putU8(head, 1);
    putU8(head, 0);
    putU16(head, static_cast<uint16_t>(dict.size()));
    sink(head + dict);
    encodeRecords(points, 32, sink, [&](Cursor& c, const ScanPoint& p) {
        const Vec3 q = surveyFrame(p.x, p.y, p.z);
        for (int a = 0; a < 3; ++a) c.f64(q[a]);
        c.f64(treeLearnLabel(p));
    });
}

}  // namespace

std::array<uint16_t, 2> lasCreationDate(double gpsStart) {
    // GPS time 0 is 1980-01-06 00:00, day 3657 after the Unix epoch; adjusted standard GPS time
    // is GPS time − 10⁹ s. Leap seconds (18 s since 1980) are ignored.
    const double gpsSeconds = gpsStart + 1e9;
    if (!std::isfinite(gpsStart) || gpsSeconds < 0 || gpsSeconds > 2e12) {
        throw std::invalid_argument("LAS gpsStart " + formatFixed(gpsStart, 3) +
                                    " is not an adjusted standard GPS time after 1980");
    }
    const int64_t days = 3657 + static_cast<int64_t>(std::floor(gpsSeconds / 86400));
    int64_t y;
    unsigned m, d;
    civilFromDays(days, y, m, d);
    const int64_t jan1 = daysFromCivil(y, 1, 1);
    return {static_cast<uint16_t>(days - jan1 + 1), static_cast<uint16_t>(y)};
}

uint8_t asprsClass(uint8_t forInstanceClass) {
    switch (forInstanceClass) {
        case kForTerrain:
            return 2;  // ground
        case kForLowVegetation:
            return 3;  // low vegetation
        case kForStem:
        case kForLiveBranches:
        case kForWoodyBranches:
            return 5;  // high vegetation
        default:
            return 1;  // unclassified
    }
}

std::array<uint8_t, 3> lasClassColour(uint8_t forInstanceClass) {
    switch (forInstanceClass) {
        case kForLowVegetation:
            return {154, 205, 50};  // yellow-green
        case kForTerrain:
            return {139, 115, 85};  // earth brown
        case kForOutPoints:
            return {255, 0, 255};  // magenta
        case kForStem:
            return {139, 69, 19};  // bark brown
        case kForLiveBranches:
            return {34, 139, 34};  // foliage green
        case kForWoodyBranches:
            return {210, 180, 140};  // tan
        default:
            return {128, 128, 128};  // unclassified, unknown codes: grey
    }
}

std::array<uint8_t, 3> lasTreeColour(int32_t treeId) {
    if (treeId == 0) return {128, 128, 128};
    // Hue stepped by the golden ratio per id (neighbouring ids far apart), saturation 0.65,
    // value 0.95.
    const double h = std::fmod(static_cast<double>(treeId) * 0.6180339887498949, 1.0) * 6.0;
    const double v = 0.95, c = v * 0.65, x = c * (1 - std::fabs(std::fmod(h, 2.0) - 1)), m = v - c;
    double r = 0, g = 0, b = 0;
    switch (static_cast<int>(h) % 6) {
        case 0:
            r = c, g = x;
            break;
        case 1:
            r = x, g = c;
            break;
        case 2:
            g = c, b = x;
            break;
        case 3:
            g = x, b = c;
            break;
        case 4:
            r = x, b = c;
            break;
        default:
            r = c, b = x;
            break;
    }
    return {to8(r + m), to8(g + m), to8(b + m)};
}

void writeLas(const fs::path& path, const ScanPointSource& points, const LasOptions& options) {
    toFile(path, [&](const Sink& sink, const Patch&) { encodeLas(points, options, sink); });
}

void writeLas(const fs::path& path, const ScanResult& scan, const LasOptions& options) {
    writeLas(path, ScanPointView(scan.points), options);
}

std::string lasBytes(const ScanResult& scan, const LasOptions& options) {
    return toBytes([&](const Sink& sink, const Patch&) {
        encodeLas(ScanPointView(scan.points), options, sink);
    });
}

void writeLaz(const fs::path& path, const ScanPointSource& points, const LasOptions& options) {
    toFile(path,
           [&](const Sink& sink, const Patch& patch) { encodeLas(points, options, sink, &patch); });
}

void writeLaz(const fs::path& path, const ScanResult& scan, const LasOptions& options) {
    writeLaz(path, ScanPointView(scan.points), options);
}

std::string lazBytes(const ScanResult& scan, const LasOptions& options) {
    return toBytes([&](const Sink& sink, const Patch& patch) {
        encodeLas(ScanPointView(scan.points), options, sink, &patch);
    });
}

void writeForestFormerPly(const fs::path& path, const ScanPointSource& points) {
    toFile(path, [&](const Sink& sink, const Patch&) { encodePly(points, sink); });
}

void writeForestFormerPly(const fs::path& path, const ScanResult& scan) {
    writeForestFormerPly(path, ScanPointView(scan.points));
}

std::string forestFormerPlyBytes(const ScanResult& scan) {
    return toBytes(
        [&](const Sink& sink, const Patch&) { encodePly(ScanPointView(scan.points), sink); });
}

int32_t treeLearnLabel(const ScanPoint& point) {
    // TreeLearn's load_data: tree points first, then terrain and low vegetation overrule them,
    // then what is neither is unlabelled.
    if (point.classification == kForLowVegetation || point.classification == kForTerrain) {
        return 0;
    }
    if (point.label.treeId != 0) return point.label.treeId;
    return -1;
}

void writeTreeLearnNpy(const fs::path& path, const ScanPointSource& points) {
    toFile(path, [&](const Sink& sink, const Patch&) { encodeNpy(points, sink); });
}

void writeTreeLearnNpy(const fs::path& path, const ScanResult& scan) {
    writeTreeLearnNpy(path, ScanPointView(scan.points));
}

std::string treeLearnNpyBytes(const ScanResult& scan) {
    return toBytes(
        [&](const Sink& sink, const Patch&) { encodeNpy(ScanPointView(scan.points), sink); });
}

std::string trajectoryCsv(const ScanResult& scan, double gpsStart) {
    std::string out = "gps_time,x,y,z,heading_deg,channel\n";
    for (const ScanPose& pose : scan.trajectory) {
        const Vec3 q = surveyFrame(pose.x, pose.y, pose.z);
        out += formatFixed(gpsStart + pose.gpsTime, 6) + "," + formatFixed(q.x, 4) + "," +
               formatFixed(q.y, 4) + "," + formatFixed(q.z, 4) + "," +
               formatFixed(pose.headingDeg, 4) + "," + std::to_string(pose.channel) + "\n";
    }
    return out;
}

void writeTrajectory(const fs::path& path, const ScanResult& scan, double gpsStart) {
    writeFileAtomic(path, trajectoryCsv(scan, gpsStart));
}

nlohmann::json stationsJson(const ScanResult& scan, double gpsStart) {
    nlohmann::json out = nlohmann::json::array();
    for (size_t k = 0; k < scan.trajectory.size(); ++k) {
        const ScanPose& pose = scan.trajectory[k];
        const Vec3 q = surveyFrame(pose.x, pose.y, pose.z);
        out.push_back({{"station", k},
                       {"channel", pose.channel},
                       {"x", q.x},
                       {"y", q.y},
                       {"z", q.z},
                       {"gps_time", gpsStart + pose.gpsTime}});
    }
    return out;
}

void writeStations(const fs::path& path, const ScanResult& scan, double gpsStart) {
    writeFileAtomic(path, stationsJson(scan, gpsStart).dump(2) + "\n");
}

}  // namespace sylva
