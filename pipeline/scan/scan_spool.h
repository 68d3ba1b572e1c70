// A scan's points read in order a block at a time, from memory or from a spool on disk, so the
// writers (pipeline/formats/scan_writers.h) can make their two passes — one for a header's
// counts, bounds and offsets, one for the records — over a survey of up to 10⁹ pulses without
// holding its points in memory.
//
//   ScanPointSpool spool(dir);                       // nothing on disk yet
//   scanInto(scene, o, seed, [&](auto& b) { spool.append(b); });
//   writeLas(path, spool, lasOptions);               // reads the points twice
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "pipeline/scan/scan_point.h"

namespace sylva {

class ScanPointSource {
  public:
    using Block = std::function<void(const ScanPoint* points, size_t count)>;
    virtual ~ScanPointSource() = default;
    virtual uint64_t size() const = 0;
    // Calls `block` with every point in order, in blocks of any size; may be called again.
    virtual void forEachBlock(const Block& block) const = 0;
};

// The points of a vector (not copied: the vector must outlive the view).
class ScanPointView : public ScanPointSource {
  public:
    explicit ScanPointView(const std::vector<ScanPoint>& points) : points_(points) {}
    uint64_t size() const override { return points_.size(); }
    void forEachBlock(const Block& block) const override {
        if (!points_.empty()) block(points_.data(), points_.size());
    }

  private:
    const std::vector<ScanPoint>& points_;
};

// Points appended in order and kept in memory up to `memoryPoints`; beyond that each full
// block goes to an unnamed temporary file in `dir`, made (with `dir`) at the first full block
// (O_TMPFILE, or a file unlinked as soon as it
// is made where the file system has no O_TMPFILE), so nothing is left behind when the process
// ends or is killed. The file is host-local scratch: raw ScanPoint records, read back by the same
// process. Disk errors throw as AtomicFileWriter's do (ResourceError on a full disk or quota,
// else std::runtime_error naming the directory).
class ScanPointSpool : public ScanPointSource {
  public:
    // 2¹⁶ points (5 MiB) in memory: the scanner's blocks in flight add a few more per thread.
    static constexpr size_t kDefaultMemoryPoints = size_t(1) << 16;

    explicit ScanPointSpool(std::filesystem::path dir, size_t memoryPoints = kDefaultMemoryPoints);
    ~ScanPointSpool() override;
    ScanPointSpool(const ScanPointSpool&) = delete;
    ScanPointSpool& operator=(const ScanPointSpool&) = delete;

    void append(const ScanPoint* points, size_t count);
    void append(const std::vector<ScanPoint>& points) { append(points.data(), points.size()); }

    uint64_t size() const override { return onDisk_ + memory_.size(); }
    // Points on disk are read back a memory block at a time.
    void forEachBlock(const Block& block) const override;
    // Bytes of the temporary file (0 while every point fits in memory).
    uint64_t bytesOnDisk() const { return onDisk_ * sizeof(ScanPoint); }

  private:
    void spill();

    std::filesystem::path dir_;
    size_t memoryPoints_;
    std::vector<ScanPoint> memory_;
    int fd_ = -1;
    uint64_t onDisk_ = 0;  // points in the file
};

}  // namespace sylva
