// Typed, position-aware parameter reading from TOML (after pbrt-v4's ParameterDictionary).
// Every read names its key; values remember file:line:col; unknown keys are errors with a
// "did you mean" suggestion; any number may be a distribution ({uniform = [a, b]} or
// {normal = [mu, sigma]}) drawn once per instance from a stream keyed by the parameter's
// path, so adding or removing one parameter never changes another's draw.
#pragma once

#include <toml++/toml.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/errors.h"
#include "core/math.h"
#include "core/rng.h"

namespace sylva {

// A file's bytes ("" when it cannot be read): what a spec's fingerprint hashes.
std::string fileBytes(const std::string& path);

// A number for an error message: printf "%.*g" with `significantDigits` digits.
std::string formatNumber(double v, int significantDigits = 12);
// Fixed decimals for tables (CSV): never "-0.000"; "" for a non-finite value.
std::string formatFixed(double v, int decimals);

// The largest magnitude a number in a spec may have when its key's range sets no bound of its
// own (Range::any(), positive(), nonNegative(), atLeast()): 10⁹ (metres, degrees, counts). Larger
// values are typos or hostile input, and their squares and cubes (areas, volumes, 32-bit float
// vertices) must stay finite. Keys whose values are larger (seeds) state their range.
constexpr double kMaxSpecMagnitude = 1e9;

// Closed/open numeric interval for validation, with a readable description. A bound of ±1e300
// means "none of its own": kMaxSpecMagnitude applies on that side.
struct Range {
    double lo = -1e300, hi = 1e300;
    bool loOpen = false, hiOpen = false;
    static Range any() { return {}; }
    static Range positive() { return {0, 1e300, true, false}; }
    static Range nonNegative() { return {0, 1e300, false, false}; }
    static Range closed(double a, double b) { return {a, b, false, false}; }
    static Range leftOpen(double a, double b) { return {a, b, true, false}; }
    static Range atLeast(double a) { return {a, 1e300, false, false}; }
    bool contains(double v) const;  // with kMaxSpecMagnitude on a side without a bound
    std::string describe(bool integer = false) const;
};

// A value forced onto a parameter path by a dataset sweep, with the sweep's location.
struct Override {
    toml::table holder;  // the value is holder["v"]
    SourcePos where;
    mutable bool used = false;
};
using Overrides = std::map<std::string, Override>;  // full key path -> value

// Every key a reader asks for, as a documentation path: "<context>.<key>.<key>…", with the
// elements of an array of tables as "name[]" and keys whose names the user chooses (grammar
// states, L-system letters) as "*"; the contexts are "species", "dataset", a method's name,
// "volume" and "volume.<type>". docs/ lists exactly these (tests/project/spec_keys_test.cpp).
using KeyLog = std::set<std::string>;

// Per-instance draw state: the instance seed, and the values drawn (for the manifest).
struct DrawContext {
    uint64_t seed = 0;
    bool draw = true;  // false: validation — use the distribution's centre, check its bounds
    std::map<std::string, double> sampled;  // key path -> drawn value
    // Set when a random stream was handed out (a volume drawn per instance, e.g. canopy blobs
    // or refinement spheres): such a species is not cached across instances.
    bool perInstance = false;
    KeyLog* keyLog = nullptr;  // when set, every key asked is recorded (documentation check)
};

class Params {
  public:
    Params(const toml::table& table, std::string file, std::string prefix, DrawContext* draw,
           const Overrides* overrides = nullptr);

    bool has(std::string_view key) const;

    // Numbers (floats or integers in TOML; distributions allowed).
    double number(std::string_view key, const Range& range);
    double number(std::string_view key, double fallback, const Range& range);
    // Integers: TOML integers only (`count = 1e9` or `nodes = 300.0` is an error: a float is
    // not an integer key's value even when it is whole), or a distribution, whose draw is
    // rounded.
    int64_t integer(std::string_view key, const Range& range);
    int64_t integer(std::string_view key, int64_t fallback, const Range& range);
    bool boolean(std::string_view key, bool fallback);
    std::string string(std::string_view key);
    std::string string(std::string_view key, std::string fallback);
    // One of the listed words; the error lists them.
    std::string choice(std::string_view key, std::string fallback,
                       const std::vector<std::string>& allowed);
    // One of the listed words, as the enum value it names; `fallback` when absent (its word
    // is the default the error shows). Each enum's words are written once, in `words`.
    template <class E, class = std::enable_if_t<std::is_enum_v<E>>>
    E choice(std::string_view key, E fallback, const std::vector<std::pair<std::string, E>>& words);
    // An angle written in degrees (a `*_deg` key, `rangeDeg` in degrees), returned in radians;
    // `fallbackRad` unchanged when the key is absent.
    double degrees(std::string_view key, double fallbackRad, const Range& rangeDeg);
    // [lo, hi] in degrees (as interval()), returned in radians; `fallbackRad` when absent.
    std::pair<double, double> degreeInterval(std::string_view key,
                                             std::pair<double, double> fallbackRad,
                                             const Range& rangeDeg);
    // [x, y, z]; each component may be a distribution.
    Vec3 vec3(std::string_view key, const Vec3& fallback, const Range& range = Range::any());
    // [lo, hi] pair with lo ≤ hi (plain numbers).
    std::pair<double, double> interval(std::string_view key, std::pair<double, double> fallback,
                                       const Range& range);

    Params table(std::string_view key);
    std::optional<Params> optionalTable(std::string_view key);
    std::vector<Params> tableArray(std::string_view key);  // empty when absent
    // Array of plain strings.
    std::vector<std::string> stringArray(std::string_view key);
    // Array of [a, b] number pairs (plain numbers), e.g. a sketched stroke; at least `minCount`.
    std::vector<Vec2> pairArray(std::string_view key, size_t minCount = 1);
    // A file named by a string key, resolved relative to the spec file's directory; it must
    // exist ("file not found" otherwise).
    std::string filePath(std::string_view key);
    // A random stream for what `key` builds per instance (keyed by the key path and the
    // instance seed; fixed when validating). Marks the draw context per-instance.
    Rng randomStream(std::string_view key);

    // The raw node (marks the key used); nullptr when absent.
    const toml::node* raw(std::string_view key);

    // Errors at this table, or at a key of it.
    [[noreturn]] void fail(std::string_view key, const std::string& message) const;
    [[noreturn]] void failHere(const std::string& message) const;
    SourcePos where(std::string_view key) const;
    SourcePos whereTable() const;
    std::string path(std::string_view key) const;
    const std::string& file() const { return file_; }
    const std::string& prefix() const { return prefix_; }

    // Every key of this table that no read asked for is an error (with a suggestion).
    void finish() const;

    // The documentation path of this table (see KeyLog); a reader shared by several places
    // (a volume, the canopy envelope) names its own context. Returns the previous path.
    std::string documentAs(std::string docPath);
    // This table's keys are names the user chooses (grammar states, L-system letters): they
    // are recorded as "*".
    void keysAreUserNames() { userNames_ = true; }
    // From here on, in this table and the tables read from it, a number must be a plain
    // number: a distribution is an error at its key, except through numberOrDistribution().
    void plainNumbersOnly() { plainNumbers_ = true; }
    // A number that may be a distribution also where plainNumbersOnly() is set (as number()).
    double numberOrDistribution(std::string_view key, const Range& range);

  private:
    const toml::node* lookup(std::string_view key, SourcePos* where) const;
    // Marks `key` asked (and records its documentation path when a KeyLog is attached).
    void ask(std::string_view key);
    std::string docPath(std::string_view key) const;
    Params child(const toml::table& table, std::string path, std::string docPath) const;
    double readNumber(const toml::node& node, const SourcePos& where, const std::string& path,
                      const Range& range, bool wantInteger);
    int64_t readInteger(const toml::node& node, const SourcePos& where, const std::string& path,
                        const Range& range);

    const toml::table* table_;
    std::string file_;
    std::string prefix_;
    DrawContext* draw_;
    const Overrides* overrides_;
    std::set<std::string> asked_;
    std::string docPath_;
    bool userNames_ = false;
    bool plainNumbers_ = false;       // distributions refused (plainNumbersOnly)
    bool allowDistribution_ = false;  // set during numberOrDistribution
};

template <class E, class>
E Params::choice(std::string_view key, E fallback,
                 const std::vector<std::pair<std::string, E>>& words) {
    std::string fallbackWord;
    std::vector<std::string> allowed;
    for (const auto& [word, value] : words) {
        allowed.push_back(word);
        if (value == fallback && fallbackWord.empty()) fallbackWord = word;
    }
    const std::string word = choice(key, fallbackWord, allowed);
    for (const auto& [w, value] : words) {
        if (w == word) return value;
    }
    return fallback;
}

// Names the documentation context of `params` for a scope (a shared reader's keys are
// documented once, wherever its table sits), restoring the previous one at its end.
class DocumentAs {
  public:
    DocumentAs(Params& params, std::string docPath)
        : params_(params), previous_(params.documentAs(std::move(docPath))) {}
    ~DocumentAs() { params_.documentAs(previous_); }
    DocumentAs(const DocumentAs&) = delete;
    DocumentAs& operator=(const DocumentAs&) = delete;

  private:
    Params& params_;
    std::string previous_;
};

SourcePos sourceOf(const toml::node& node, const std::string& file);
// Closest word by edit distance, if close enough to be a plausible misspelling.
std::optional<std::string> closestWord(std::string_view word, const std::set<std::string>& words);

// A name that is also used as a file or directory name: 1–64 letters, digits, '-' or '_'.
bool isFileSafeName(const std::string& name);

// Parses a TOML file; parse errors and missing files become SpecError.
toml::table parseTomlFile(const std::string& file);

}  // namespace sylva
