#include "pipeline/formats/tar_pack.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <optional>
#include <stdexcept>

#include "core/errors.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

constexpr size_t kBlock = 512;
constexpr uint64_t kRecord = 20 * kBlock;  // the default blocking factor of tar(1)
constexpr size_t kMaxName = 64 << 10;

uint64_t padTo(uint64_t n, uint64_t unit) { return (unit - n % unit) % unit; }

// An unsigned number in a header field: octal digits with a NUL, or (too large for them)
// base-256 — the first byte 0x80, the rest big-endian — as GNU tar and POSIX pax readers take.
void putNumber(char* field, size_t width, uint64_t v) {
    const uint64_t octalMax =
        (width - 1) * 3 >= 64 ? ~uint64_t{0} : (uint64_t{1} << ((width - 1) * 3)) - 1;
    if (v <= octalMax) {
        std::snprintf(field, width, "%0*llo", static_cast<int>(width - 1),
                      static_cast<unsigned long long>(v));
        return;
    }
    std::memset(field, 0, width);
    field[0] = static_cast<char>(0x80);
    for (size_t i = width - 1; i > 0 && v; --i, v >>= 8) field[i] = static_cast<char>(v & 0xff);
}

std::optional<uint64_t> getNumber(const unsigned char* field, size_t width) {
    if (field[0] & 0x80) {
        uint64_t v = 0;
        for (size_t i = 1; i < width; ++i) {
            if (v >> 56) return std::nullopt;
            v = (v << 8) | field[i];
        }
        return v;
    }
    uint64_t v = 0;
    size_t i = 0;
    while (i < width && field[i] == ' ') ++i;
    bool any = false;
    for (; i < width && field[i] >= '0' && field[i] <= '7'; ++i) {
        if (v >> 61) return std::nullopt;
        v = v * 8 + (field[i] - '0');
        any = true;
    }
    if (i < width && field[i] != 0 && field[i] != ' ') return std::nullopt;
    return any ? std::optional<uint64_t>(v) : std::optional<uint64_t>(0);
}

uint64_t checksum(const unsigned char* h) {
    uint64_t sum = 0;
    for (size_t i = 0; i < kBlock; ++i) sum += (i >= 148 && i < 156) ? ' ' : h[i];
    return sum;
}

// A pax extended-header record: "<length> <key>=<value>\n", the length counting itself.
std::string paxRecord(std::string_view key, std::string_view value) {
    const size_t body = 1 + key.size() + 1 + value.size() + 1;
    size_t len = body + 1;
    while (std::to_string(len).size() + body != len) len = std::to_string(len).size() + body;
    return std::to_string(len) + " " + std::string(key) + "=" + std::string(value) + "\n";
}

}  // namespace

TarWriter::TarWriter(fs::path path) : file_(std::move(path)) {}

void TarWriter::header(std::string_view name, uint64_t size, char type) {
    std::array<char, kBlock> h{};
    std::memcpy(h.data(), name.data(), std::min<size_t>(name.size(), 100));
    putNumber(&h[100], 8, 0644);
    putNumber(&h[108], 8, 0);
    putNumber(&h[116], 8, 0);
    putNumber(&h[124], 12, size);
    putNumber(&h[136], 12, 0);
    h[156] = type;
    std::memcpy(&h[257], "ustar", 6);  // magic "ustar\0", version "00"
    std::memcpy(&h[263], "00", 2);
    const uint64_t sum = checksum(reinterpret_cast<const unsigned char*>(h.data()));
    std::snprintf(&h[148], 8, "%06llo", static_cast<unsigned long long>(sum));
    h[155] = ' ';
    file_.write(std::string_view(h.data(), h.size()));
}

TarMember TarWriter::add(std::string_view name, std::string_view data) {
    if (name.empty() || name.size() > kMaxName || name.find('\0') != std::string_view::npos) {
        throw std::invalid_argument("tar member name: empty, longer than 64 KiB or with a NUL");
    }
    if (name.size() > 100) {  // the full name in a pax record, the first 100 bytes in ustar
        const std::string pax = paxRecord("path", name);
        header("PaxHeaders/" + std::string(name.substr(0, 89)), pax.size(), 'x');
        file_.write(pax);
        file_.write(std::string(padTo(pax.size(), kBlock), '\0'));
    }
    header(name, data.size(), '0');
    TarMember m{std::string(name), file_.bytesWritten(), data.size()};
    file_.write(data);
    file_.write(std::string(padTo(data.size(), kBlock), '\0'));
    return m;
}

void TarWriter::commit() {
    file_.write(std::string(2 * kBlock, '\0'));
    file_.write(std::string(padTo(file_.bytesWritten(), kRecord), '\0'));
    file_.commit();
}

std::vector<TarMember> indexTar(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::error_code ec;
    const uint64_t fileSize = fs::file_size(path, ec);
    if (!in || ec) throw InputError(path.string() + ": cannot read (" + ec.message() + ")");
    auto bad = [&](uint64_t at, const std::string& what) {
        return InputError(path.string() + ": byte " + std::to_string(at) + ": " + what);
    };
    std::vector<TarMember> members;
    std::optional<std::string> nextName;  // from a pax record or a GNU long name
    std::optional<uint64_t> nextSize;     // from a pax record
    uint64_t at = 0;
    std::array<unsigned char, kBlock> h{};
    while (at + kBlock <= fileSize) {
        in.seekg(static_cast<std::streamoff>(at));
        if (!in.read(reinterpret_cast<char*>(h.data()), kBlock)) throw bad(at, "read failed");
        if (std::all_of(h.begin(), h.end(), [](unsigned char c) { return c == 0; })) break;
        const std::optional<uint64_t> stored = getNumber(&h[148], 8);
        if (!stored || *stored != checksum(h.data())) throw bad(at, "not a tar header (checksum)");
        std::optional<uint64_t> size = getNumber(&h[124], 12);
        if (!size) throw bad(at, "not a tar header (size)");
        if (nextSize) size = nextSize;
        const uint64_t data = at + kBlock;
        if (*size > fileSize - data) throw bad(at, "member runs past the end of the file");
        const char type = static_cast<char>(h[156]);
        auto readData = [&] {
            if (*size > kMaxName + 64) throw bad(at, "extended header larger than 64 KiB");
            std::string s(static_cast<size_t>(*size), '\0');
            in.seekg(static_cast<std::streamoff>(data));
            if (!in.read(s.data(), static_cast<std::streamsize>(s.size()))) {
                throw bad(at, "read failed");
            }
            return s;
        };
        if (type == 'x') {  // pax records for the next member
            const std::string pax = readData();
            for (size_t p = 0; p < pax.size();) {
                const size_t space = pax.find(' ', p);
                if (space == std::string::npos) throw bad(at, "malformed pax record");
                const uint64_t len = std::strtoull(pax.c_str() + p, nullptr, 10);
                if (len <= space - p || p + len > pax.size() || pax[p + len - 1] != '\n') {
                    throw bad(at, "malformed pax record");
                }
                const std::string rec = pax.substr(space + 1, p + len - 1 - space - 1);
                const size_t eq = rec.find('=');
                if (eq == std::string::npos) throw bad(at, "malformed pax record");
                if (rec.compare(0, eq, "path") == 0) nextName = rec.substr(eq + 1);
                if (rec.compare(0, eq, "size") == 0) {
                    nextSize = std::strtoull(rec.c_str() + eq + 1, nullptr, 10);
                }
                p += len;
            }
        } else if (type == 'L') {  // GNU long name
            std::string s = readData();
            nextName = s.substr(0, s.find('\0'));
        } else {
            if (type == '0' || type == '\0' || type == '7') {
                std::string name;
                if (nextName) {
                    name = *nextName;
                } else {
                    const char* n = reinterpret_cast<const char*>(h.data());
                    name.assign(n, strnlen(n, 100));
                    const char* prefix = n + 345;
                    if (std::memcmp(&h[257], "ustar", 5) == 0 && prefix[0]) {
                        name = std::string(prefix, strnlen(prefix, 155)) + "/" + name;
                    }
                }
                members.push_back({name, data, *size});
            }
            nextName.reset();
            nextSize.reset();
        }
        at = data + *size + padTo(*size, kBlock);
    }
    return members;
}

std::string readTarMember(const fs::path& path, const TarMember& member) {
    std::ifstream in(path, std::ios::binary);
    std::string s(static_cast<size_t>(member.size), '\0');
    in.seekg(static_cast<std::streamoff>(member.offset));
    if (!in || !in.read(s.data(), static_cast<std::streamsize>(s.size()))) {
        throw InputError(path.string() + ": cannot read member " + member.name);
    }
    return s;
}

}  // namespace sylva
