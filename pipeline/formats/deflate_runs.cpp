// See deflate_runs.h. Section numbers are RFC 1951's (DEFLATE) unless marked RFC 1950 (zlib).
#include "pipeline/formats/deflate_runs.h"

#include <algorithm>
#include <array>
#include <vector>

#include "pipeline/formats/little_endian.h"

namespace sylva {

namespace {

constexpr int kMaxCodeBits = 15;       // literal/length and distance codes (§3.2.7)
constexpr int kMaxCodeLengthBits = 7;  // the code-length code (§3.2.7)
constexpr size_t kMaxCopy = 258;       // §3.2.5
constexpr uint64_t kAdlerMod = 65521;  // RFC 1950 §8.2
constexpr int kEndOfBlock = 256;

// Length codes 257…285: base lengths and extra bits (§3.2.5).
constexpr std::array<uint16_t, 29> kLengthBase = {3,  4,  5,  6,   7,   8,   9,   10,  11, 13,
                                                  15, 17, 19, 23,  27,  31,  35,  43,  51, 59,
                                                  67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::array<uint8_t, 29> kLengthExtra = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                                  2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
// The order in which the code-length code's lengths are stored (§3.2.7).
constexpr std::array<uint8_t, 19> kCodeLengthOrder = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                                      11, 4,  12, 3, 13, 2, 14, 1, 15};

// Copy length 3…258 → index of its length code (0…28).
const std::array<uint8_t, kMaxCopy + 1>& lengthCodeOf() {
    static const auto table = [] {
        std::array<uint8_t, kMaxCopy + 1> t{};
        for (size_t c = 0; c < 28; ++c) {
            for (size_t len = kLengthBase[c]; len < kLengthBase[c + 1]; ++len) {
                t[len] = static_cast<uint8_t>(c);
            }
        }
        t[kMaxCopy] = 28;  // 258 has a code of its own (285), not 284 with extra bits 31
        return t;
    }();
    return table;
}

// At least two symbols with a code, as zlib does: a lone code would be one bit long and
// incomplete, which some decoders refuse.
void atLeastTwo(std::vector<uint32_t>& freq) {
    size_t used = 0;
    for (uint32_t f : freq) used += f > 0;
    for (size_t s = 0; used < 2 && s < freq.size(); ++s) {
        if (freq[s] == 0) {
            freq[s] = 1;
            ++used;
        }
    }
}

// Huffman code lengths for `freq` (at least two nonzero), none longer than `limit` bits; zero
// for unused symbols. Two-queue Huffman over the symbols sorted by frequency, then lengths
// beyond the limit folded in by the adjustment of JPEG's Annex K.3 (which keeps the code
// complete), and the lengths dealt out again, the shortest to the most frequent.
std::vector<uint8_t> codeLengths(const std::vector<uint32_t>& freq, int limit) {
    std::vector<uint32_t> symbols;
    for (uint32_t s = 0; s < freq.size(); ++s) {
        if (freq[s] > 0) symbols.push_back(s);
    }
    std::stable_sort(symbols.begin(), symbols.end(),
                     [&](uint32_t a, uint32_t b) { return freq[a] < freq[b]; });
    const size_t n = symbols.size();
    std::vector<uint64_t> weight(2 * n - 1);
    std::vector<size_t> parent(2 * n - 1, 0);
    for (size_t i = 0; i < n; ++i) weight[i] = freq[symbols[i]];
    // Leaves come in increasing weight and so do the inner nodes as they are made: the two
    // lightest are at the fronts of the two queues.
    size_t leaf = 0, inner = n;
    auto lightest = [&](size_t made) {
        if (leaf < n && (inner >= made || weight[leaf] <= weight[inner])) return leaf++;
        return inner++;
    };
    for (size_t made = n; made < 2 * n - 1; ++made) {
        const size_t a = lightest(made);
        const size_t b = lightest(made);
        weight[made] = weight[a] + weight[b];
        parent[a] = parent[b] = made;
    }
    // A parent is made after its children, so depths follow from the root downwards.
    std::vector<int> depth(2 * n - 1, 0);
    int deepest = 0;
    for (size_t i = 2 * n - 1; i-- > 0;) {
        if (i + 1 < 2 * n - 1) depth[i] = depth[parent[i]] + 1;
        if (i < n) deepest = std::max(deepest, depth[i]);
    }
    std::vector<int> count(static_cast<size_t>(std::max(deepest, limit)) + 1, 0);
    for (size_t i = 0; i < n; ++i) ++count[depth[i]];
    for (int len = deepest; len > limit; --len) {
        while (count[len] > 0) {
            int j = len - 2;
            while (count[j] == 0) --j;
            count[len] -= 2;
            count[len - 1] += 1;
            count[j + 1] += 2;
            count[j] -= 1;
        }
    }
    std::vector<uint8_t> lengths(freq.size(), 0);
    size_t next = 0;  // symbols[] is least frequent first
    for (int len = limit; len >= 1; --len) {
        for (int k = 0; k < count[len]; ++k) lengths[symbols[next++]] = static_cast<uint8_t>(len);
    }
    return lengths;
}

// Canonical codes for the lengths (§3.2.2), bit-reversed: DEFLATE sends a Huffman code from
// its most significant bit, into a stream packed from each byte's least significant bit.
std::vector<uint16_t> canonicalCodes(const std::vector<uint8_t>& lengths) {
    std::array<uint32_t, kMaxCodeBits + 2> perLength{};
    for (uint8_t len : lengths) ++perLength[len];
    perLength[0] = 0;
    std::array<uint32_t, kMaxCodeBits + 2> next{};
    uint32_t code = 0;
    for (int bits = 1; bits <= kMaxCodeBits; ++bits) {
        code = (code + perLength[bits - 1]) << 1;
        next[bits] = code;
    }
    std::vector<uint16_t> codes(lengths.size(), 0);
    for (size_t s = 0; s < lengths.size(); ++s) {
        const int len = lengths[s];
        if (len == 0) continue;
        const uint32_t c = next[len]++;
        uint32_t reversed = 0;
        for (int i = 0; i < len; ++i) reversed |= ((c >> i) & 1u) << (len - 1 - i);
        codes[s] = static_cast<uint16_t>(reversed);
    }
    return codes;
}

// Bits packed from the least significant bit of each byte, into a buffer sized beforehand
// with at least 8 bytes to spare past the last bit. Each put stores the whole accumulator and
// moves on by the bytes it completed, so no branch depends on the data (the loop that flushed
// 32 bits at a time mispredicted on the short runs of label images).
class BitWriter {
  public:
    explicit BitWriter(char* out) : out_(out) {}
    // count ≤ 56: fewer than 8 bits wait in the accumulator, so nothing passes bit 63.
    void put(uint64_t bits, int count) {
        acc_ |= bits << used_;
        used_ += count;
        storeU64(out_, acc_);
        const int bytes = used_ >> 3;
        out_ += bytes;
        acc_ >>= 8 * bytes;  // bytes ≤ 7, as used_ ≤ 7 + 56
        used_ &= 7;
    }
    // Pads the last byte with zero bits; returns the end of the output.
    char* finish() {
        if (used_ > 0) *out_++ = static_cast<char>(acc_ & 0xff);
        acc_ = 0;
        used_ = 0;
        return out_;
    }

  private:
    char* out_;
    uint64_t acc_ = 0;
    int used_ = 0;
};

// The data as maximal runs of equal bytes.
struct Run {
    uint64_t length;
    uint8_t value;
};

class RunList {
  public:
    void add(const uint8_t* data, size_t size) {
        size_t i = 0;
        while (i < size) {
            const uint8_t v = data[i];
            const size_t j = runEnd(data, i + 1, size, v);
            add(v, j - i);
            i = j;
        }
    }
    void add(uint8_t value, uint64_t length) {
        if (!runs_.empty() && runs_.back().value == value) {
            runs_.back().length += length;
        } else {
            // Field by field into the vector: push_back({length, value}) built the run on the
            // stack with an 8- and a 1-byte store and copied it with one 16-byte load, which
            // cannot take its bytes from two stores (a store-forwarding stall). On a label
            // image of short runs the whole zlib stream took 15 % less time this way.
            Run& r = runs_.emplace_back();
            r.length = length;
            r.value = value;
        }
    }
    const std::vector<Run>& runs() const { return runs_; }
    void clear() { runs_.clear(); }
    // Gives the storage back when it holds more than `keep` runs.
    void trim(size_t keep) {
        if (runs_.capacity() > keep) std::vector<Run>().swap(runs_);
    }

  private:
    std::vector<Run> runs_;
};

// A run as DEFLATE tokens: its first byte a literal, the rest copies of the byte before
// (`copy(length)`, 3…258) and at most two literals (`literal()`).
template <typename Copy, typename Literal>
void forEachToken(uint64_t length, Copy&& copy, Literal&& literal) {
    literal();
    uint64_t rest = length - 1;
    while (rest >= 3) {
        uint64_t len = std::min<uint64_t>(rest, kMaxCopy);
        // Leave at least three for the next copy rather than one or two literals.
        if (rest > kMaxCopy && rest - kMaxCopy < 3) len = rest - 3;
        copy(static_cast<size_t>(len));
        rest -= len;
    }
    for (; rest > 0; --rest) literal();
}

// The Adler-32 of the data (RFC 1950 §8.2) a run at a time: a run of L bytes v adds v·L to a
// and a·L + v·L(L+1)/2 to b. The sums are taken modulo 65521 only once kDeferBytes bytes have
// gone in since the last reduction (as zlib defers its own, there every 5,552 bytes), a longer
// run going in as pieces of at most kDeferBytes: between reductions fewer than 2^21 bytes go
// in, so a < 65521 + 255·2^21 and b < 65521 + 2^21·a + 255·2^41, far inside 64 bits.
// (Reducing after every run was 40 % of the encoder's time on label images, whose runs are
// short.)
class RunAdler {
  public:
    void add(uint64_t v, uint64_t length) {
        while (length > 0) {
            const uint64_t l = std::min(length, kDeferBytes);
            b_ += l * a_ + v * (l * (l + 1) / 2);
            a_ += v * l;
            pending_ += l;
            if (pending_ >= kDeferBytes) reduce();
            length -= l;
        }
    }
    uint32_t value() {
        reduce();
        return static_cast<uint32_t>((b_ << 16) | a_);
    }

  private:
    static constexpr uint64_t kDeferBytes = uint64_t(1) << 20;
    void reduce() {
        a_ %= kAdlerMod;
        b_ %= kAdlerMod;
        pending_ = 0;
    }
    uint64_t a_ = 1, b_ = 0, pending_ = 0;
};

std::string deflateRuns(const std::vector<Run>& runs) {
    const auto& lengthCode = lengthCodeOf();
    // Symbol frequencies, a bound on the tokens' bits, and the Adler-32 of the data.
    std::vector<uint32_t> litFreq(286, 0), distFreq(30, 0);
    uint64_t tokenBits = 0;
    RunAdler adler;
    for (const Run& r : runs) {
        const uint64_t v = r.value;
        const uint64_t rest = r.length - 1;
        if (rest <= kMaxCopy) {  // forEachToken's tokens for such a run, without its loops
            const bool copy = rest >= 3;
            litFreq[v] += copy ? 1 : static_cast<uint32_t>(1 + rest);
            litFreq[257 + lengthCode[rest]] += copy;  // lengthCode[0…2] is 0: adds nothing
            distFreq[0] += copy;
            tokenBits += copy ? 15 + 15 + 5 + 15 : 15 * (1 + rest);
        } else {
            forEachToken(
                r.length,
                [&](size_t len) {
                    ++litFreq[257 + lengthCode[len]];
                    ++distFreq[0];
                    tokenBits += 15 + 5 + 15;
                },
                [&] {
                    ++litFreq[v];
                    tokenBits += 15;
                });
        }
        adler.add(v, r.length);
    }
    litFreq[kEndOfBlock] = 1;
    atLeastTwo(litFreq);
    atLeastTwo(distFreq);
    const std::vector<uint8_t> litLen = codeLengths(litFreq, kMaxCodeBits);
    const std::vector<uint8_t> distLen = codeLengths(distFreq, kMaxCodeBits);
    const std::vector<uint16_t> litCode = canonicalCodes(litLen);
    const std::vector<uint16_t> distCode = canonicalCodes(distLen);

    // The code lengths of both codes as one sequence, run-length coded with 16 (repeat the
    // previous 3–6 times), 17 (3–10 zeros) and 18 (11–138 zeros) (§3.2.7).
    size_t hlit = 286, hdist = 30;
    while (hlit > 257 && litLen[hlit - 1] == 0) --hlit;
    while (hdist > 1 && distLen[hdist - 1] == 0) --hdist;
    std::vector<uint8_t> lengths(litLen.begin(), litLen.begin() + static_cast<long>(hlit));
    lengths.insert(lengths.end(), distLen.begin(), distLen.begin() + static_cast<long>(hdist));
    std::vector<std::pair<uint8_t, uint8_t>> lengthTokens;  // symbol, extra bits' value
    for (size_t k = 0; k < lengths.size();) {
        const uint8_t v = lengths[k];
        size_t run = 1;
        while (k + run < lengths.size() && lengths[k + run] == v) ++run;
        k += run;
        if (v == 0) {
            for (; run >= 11; run -= std::min<size_t>(run, 138)) {
                lengthTokens.push_back({18, static_cast<uint8_t>(std::min<size_t>(run, 138) - 11)});
            }
            if (run >= 3) {
                lengthTokens.push_back({17, static_cast<uint8_t>(run - 3)});
                run = 0;
            }
        } else {
            lengthTokens.push_back({v, 0});
            --run;
            for (; run >= 3; run -= std::min<size_t>(run, 6)) {
                lengthTokens.push_back({16, static_cast<uint8_t>(std::min<size_t>(run, 6) - 3)});
            }
        }
        for (; run > 0; --run) lengthTokens.push_back({v, 0});
    }
    std::vector<uint32_t> clFreq(19, 0);
    for (const auto& t : lengthTokens) ++clFreq[t.first];
    atLeastTwo(clFreq);
    const std::vector<uint8_t> clLen = codeLengths(clFreq, kMaxCodeLengthBits);
    const std::vector<uint16_t> clCode = canonicalCodes(clLen);
    size_t hclen = 19;
    while (hclen > 4 && clLen[kCodeLengthOrder[hclen - 1]] == 0) --hclen;

    // The header under 400 bytes, then the tokens, and BitWriter's 8 bytes to spare.
    std::string z(2 + 400 + tokenBits / 8 + 16, '\0');
    z[0] = static_cast<char>(0x78);  // RFC 1950: deflate, 32 KiB window
    z[1] = static_cast<char>(0x01);  // no dictionary, "fastest"; 0x7801 is a multiple of 31
    BitWriter bits(z.data() + 2);
    bits.put(1, 1);  // the last block
    bits.put(2, 2);  // dynamic codes
    bits.put(static_cast<uint32_t>(hlit - 257), 5);
    bits.put(static_cast<uint32_t>(hdist - 1), 5);
    bits.put(static_cast<uint32_t>(hclen - 4), 4);
    for (size_t k = 0; k < hclen; ++k) bits.put(clLen[kCodeLengthOrder[k]], 3);
    static constexpr int kLengthTokenExtra[3] = {2, 3, 7};  // for 16, 17, 18
    for (const auto& [symbol, extra] : lengthTokens) {
        bits.put(clCode[symbol], clLen[symbol]);
        if (symbol >= 16) bits.put(extra, kLengthTokenExtra[symbol - 16]);
    }
    // A copy at distance 1 as one bit string: the length's code, its extra bits, then
    // distance code 0. The distance code has exactly two symbols (0, and 1 added by
    // atLeastTwo), so code 0 is one bit: at most 15 + 5 + 1 bits, within BitWriter's 56.
    std::array<uint64_t, kMaxCopy + 1> copyCode{};
    std::array<uint8_t, kMaxCopy + 1> copyBits{};
    for (size_t len = 3; len <= kMaxCopy; ++len) {
        const uint32_t c = lengthCode[len];
        const int codeBits = litLen[257 + c];
        copyCode[len] = litCode[257 + c] |
                        (static_cast<uint64_t>(len - kLengthBase[c]) << codeBits) |
                        (static_cast<uint64_t>(distCode[0]) << (codeBits + kLengthExtra[c]));
        copyBits[len] = static_cast<uint8_t>(codeBits + kLengthExtra[c] + distLen[0]);
    }
    for (const Run& r : runs) {
        const uint64_t literalCode = litCode[r.value];
        const int literalBits = litLen[r.value];
        const uint64_t rest = r.length - 1;
        if (rest <= kMaxCopy) {
            // The run's tokens in one put, as forEachToken has them: its literal, then one copy
            // of the rest (3…258) or the rest as literals (0…2). At most 15 + 21 or 3 × 15
            // bits; the choices are selects, not branches (run lengths are not predictable).
            const uint64_t two = literalCode | literalCode << literalBits;
            const uint64_t literals = rest == 0   ? literalCode
                                      : rest == 1 ? two
                                                  : two | literalCode << (2 * literalBits);
            const bool copy = rest >= 3;
            bits.put(copy ? literalCode | copyCode[rest] << literalBits : literals,
                     literalBits * (copy ? 1 : static_cast<int>(1 + rest)) +
                         (copy ? copyBits[rest] : 0));
        } else {
            forEachToken(
                r.length, [&](size_t len) { bits.put(copyCode[len], copyBits[len]); },
                [&] { bits.put(literalCode, literalBits); });
        }
    }
    bits.put(litCode[kEndOfBlock], litLen[kEndOfBlock]);
    char* end = bits.finish();
    end = storeU32BigEndian(end, adler.value());
    z.resize(static_cast<size_t>(end - z.data()));
    return z;
}

// The run list of the calling thread, emptied: its storage is reused from image to image.
// (Grown afresh for each, its reallocations' copies were 0.9 % of ez-size's instructions.) It
// keeps at most kKeptRuns' worth (4 MiB) between images: a large image's list is given back.
constexpr size_t kKeptRuns = size_t(1) << 18;
RunList& threadRuns() {
    thread_local RunList runs;
    runs.clear();
    return runs;
}
std::string deflateAndTrim(RunList& runs) {
    std::string z = deflateRuns(runs.runs());
    runs.trim(kKeptRuns);
    return z;
}

}  // namespace

std::string zlibRuns(const uint8_t* data, size_t size) {
    RunList& runs = threadRuns();
    runs.add(data, size);
    return deflateAndTrim(runs);
}

std::string zlibRunsOfRows(const uint8_t* pixels, size_t rowBytes, size_t rows,
                           uint8_t filterByte) {
    RunList& runs = threadRuns();
    for (size_t y = 0; y < rows; ++y) {
        runs.add(filterByte, 1);
        runs.add(pixels + y * rowBytes, rowBytes);
    }
    return deflateAndTrim(runs);
}

}  // namespace sylva
