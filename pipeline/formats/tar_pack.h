// Tar archives as the WebDataset convention uses them: regular-file members only, written with
// fixed metadata so that the same members give the same bytes. POSIX ustar headers (pax `path`
// records for names longer than the ustar field), mode 0644, owner 0/0, empty user and group
// names, mtime 0; the archive ends with two zero blocks, padded to a 10,240-byte record. GNU
// tar, Python's tarfile and webdataset read them. No library: Debian's libarchive would write
// the same headers, but its writer stamps the host's user and time into them unless every
// field is overridden per entry, and the format is 60 lines here.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/atomic_file.h"

namespace sylva {

// A regular-file member: its name, where its data starts in the archive and its size.
struct TarMember {
    std::string name;
    uint64_t offset = 0;
    uint64_t size = 0;
};

// A tar archive written member by member through an AtomicFileWriter: the target appears
// complete at commit(), never torn.
class TarWriter {
  public:
    explicit TarWriter(std::filesystem::path path);
    // Appends a regular file `name` (UTF-8, no NUL, at most 64 KiB) with `data`; returns the
    // member with the offset of its data. Throws as AtomicFileWriter::write does.
    TarMember add(std::string_view name, std::string_view data);
    // Writes the end-of-archive blocks and renames the file over its target.
    void commit();
    uint64_t bytesWritten() const { return file_.bytesWritten(); }

  private:
    void header(std::string_view name, uint64_t size, char type);
    AtomicFileWriter file_;
};

// The regular-file members of a tar archive, in archive order, from its headers (ustar, with
// pax `path` / `size` records and GNU long names honoured; directories, links and other entries
// skipped). Stops at the first zero block. Throws InputError (core/errors.h) naming the file
// and the byte offset on a header that is not tar, a bad checksum, or a member running past the
// end of the file.
std::vector<TarMember> indexTar(const std::filesystem::path& path);

// The bytes of one member (offset and size from TarWriter::add or indexTar).
std::string readTarMember(const std::filesystem::path& path, const TarMember& member);

}  // namespace sylva
