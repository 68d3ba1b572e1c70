#include "core/params.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/input_file.h"
#include "core/rng.h"

namespace sylva {

namespace {
// A range's bounds with kMaxSpecMagnitude on a side without a bound of its own.
bool unboundedBelow(const Range& r) { return r.lo <= -1e299; }
bool unboundedAbove(const Range& r) { return r.hi >= 1e299; }
}  // namespace

bool Range::contains(double v) const {
    if (loOpen ? !(v > lo) : !(v >= lo)) return false;
    if (hiOpen ? !(v < hi) : !(v <= hi)) return false;
    if (unboundedBelow(*this) && v < -kMaxSpecMagnitude) return false;
    if (unboundedAbove(*this) && v > kMaxSpecMagnitude) return false;
    return true;
}

std::string fileBytes(const std::string& path) {
    // Only what a spec reads is fingerprinted (species files, DEM rasters), each read and checked
    // by its own reader first; a FIFO or device here gives "" at once instead of blocking.
    constexpr uint64_t kMaxFingerprintedFileBytes = uint64_t(1) << 30;
    try {
        return readInputFile(path, kMaxFingerprintedFileBytes, "spec input");
    } catch (const InputError&) {
        return "";
    }
}

std::string formatNumber(double v, int significantDigits) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", significantDigits, v);
    return buf;
}

std::string formatFixed(double v, int decimals) {
    if (!std::isfinite(v)) return "";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    std::string s = buf;
    if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s = s.substr(1);
    return s;
}

std::string Range::describe(bool integer) const {
    std::string noun = integer ? "an integer" : "a number";
    bool noLo = lo <= -1e299, noHi = hi >= 1e299;
    if (noLo && noHi) return integer ? noun : "a finite number";
    if (noHi) return noun + (loOpen ? " > " : " ≥ ") + formatNumber(lo);
    if (noLo) return noun + (hiOpen ? " < " : " ≤ ") + formatNumber(hi);
    return noun + " in " + (loOpen ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) +
           (hiOpen ? ")" : "]");
}

static const char* typeName(const toml::node& n) {
    switch (n.type()) {
        case toml::node_type::table:
            return "a table";
        case toml::node_type::array:
            return "an array";
        case toml::node_type::string:
            return "a string";
        case toml::node_type::integer:
            return "an integer";
        case toml::node_type::floating_point:
            return "a float";
        case toml::node_type::boolean:
            return "a boolean";
        default:
            return "a date/time";
    }
}

SourcePos sourceOf(const toml::node& node, const std::string& file) {
    SourcePos p;
    p.file = file;
    p.line = static_cast<int>(node.source().begin.line);
    p.column = static_cast<int>(node.source().begin.column);
    return p;
}

std::optional<std::string> closestWord(std::string_view word, const std::set<std::string>& words) {
    auto editDistance = [](std::string_view a, std::string_view b) {
        std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
        for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
        for (size_t i = 1; i <= a.size(); ++i) {
            cur[0] = i;
            for (size_t j = 1; j <= b.size(); ++j) {
                size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
                cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
            }
            std::swap(prev, cur);
        }
        return prev[b.size()];
    };
    std::optional<std::string> best;
    size_t bestD = std::max<size_t>(2, word.size() / 3) + 1;
    for (const auto& w : words) {
        size_t d = editDistance(word, w);
        if (d < bestD) {
            bestD = d;
            best = w;
        }
    }
    return best;
}

bool isFileSafeName(const std::string& name) {
    if (name.empty() || name.size() > 64) return false;
    for (char c : name) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) return false;
    }
    return true;
}

toml::table parseTomlFile(const std::string& file) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
        throw SpecError(SourcePos{file, 0, 0}, "", "file not found or not a regular file");
    }
    try {
        return toml::parse_file(file);
    } catch (const toml::parse_error& e) {
        SourcePos p{file, static_cast<int>(e.source().begin.line),
                    static_cast<int>(e.source().begin.column)};
        throw SpecError(p, "", std::string("TOML syntax error: ") + std::string(e.description()));
    }
}

Params::Params(const toml::table& table, std::string file, std::string prefix, DrawContext* draw,
               const Overrides* overrides)
    : table_(&table),
      file_(std::move(file)),
      prefix_(std::move(prefix)),
      draw_(draw),
      overrides_(overrides) {}

std::string Params::path(std::string_view key) const {
    if (prefix_.empty()) return std::string(key);
    return prefix_ + "." + std::string(key);
}

SourcePos Params::whereTable() const { return sourceOf(*table_, file_); }

SourcePos Params::where(std::string_view key) const {
    SourcePos p;
    if (lookup(key, &p)) return p;
    return whereTable();
}

void Params::fail(std::string_view key, const std::string& message) const {
    throw SpecError(where(key), path(key), message);
}

void Params::failHere(const std::string& message) const {
    throw SpecError(whereTable(), prefix_, message);
}

const toml::node* Params::lookup(std::string_view key, SourcePos* where) const {
    if (overrides_) {
        auto it = overrides_->find(path(key));
        if (it != overrides_->end()) {
            it->second.used = true;
            if (where) *where = it->second.where;
            return it->second.holder.get("v");
        }
    }
    const toml::node* n = table_->get(key);
    if (n && where) *where = sourceOf(*n, file_);
    return n;
}

void Params::ask(std::string_view key) {
    asked_.insert(std::string(key));
    if (draw_ && draw_->keyLog) draw_->keyLog->insert(docPath(key));
}

std::string Params::docPath(std::string_view key) const {
    const std::string k = userNames_ ? std::string("*") : std::string(key);
    return docPath_.empty() ? k : docPath_ + "." + k;
}

std::string Params::documentAs(std::string docPath) {
    std::swap(docPath_, docPath);
    return docPath;
}

Params Params::child(const toml::table& table, std::string path, std::string docPath) const {
    Params c(table, file_, std::move(path), draw_, overrides_);
    c.docPath_ = std::move(docPath);
    c.plainNumbers_ = plainNumbers_;
    return c;
}

bool Params::has(std::string_view key) const { return lookup(key, nullptr) != nullptr; }

const toml::node* Params::raw(std::string_view key) {
    ask(key);
    return lookup(key, nullptr);
}

// The message for a finite value outside `range`: the range, and the magnitude limit when it is
// what the value breaks.
static std::string outOfRange(const Range& range, bool integer, double v, const std::string& got) {
    const bool tooLarge = (unboundedAbove(range) && v > kMaxSpecMagnitude) ||
                          (unboundedBelow(range) && v < -kMaxSpecMagnitude);
    return "expected " + range.describe(integer) +
           (tooLarge ? " of magnitude at most 1e9 (the largest a spec number may be)" : "") +
           ", got " + got;
}

double Params::readNumber(const toml::node& node, const SourcePos& where, const std::string& path,
                          const Range& range, bool wantInteger) {
    auto check = [&](double v, const char* what) {
        if (!std::isfinite(v)) {
            throw SpecError(where, path,
                            std::string("expected a finite number, got ") + formatNumber(v));
        }
        if (!range.contains(v)) {
            throw SpecError(where, path, outOfRange(range, wantInteger, v, what + formatNumber(v)));
        }
        if (wantInteger && std::floor(v) != v) {
            throw SpecError(where, path, "expected an integer, got " + formatNumber(v));
        }
    };
    if (auto i = node.as_integer()) {
        double v = static_cast<double>(i->get());
        check(v, "");
        return v;
    }
    if (auto f = node.as_floating_point()) {
        double v = f->get();
        if (wantInteger && std::isfinite(v) && std::floor(v) != v) {
            throw SpecError(where, path, "expected an integer, got " + formatNumber(v));
        }
        check(v, "");
        return v;
    }
    if (auto t = node.as_table()) {
        // A distribution: {uniform = [a, b]} or {normal = [mu, sigma]}.
        if (plainNumbers_ && !allowDistribution_) {
            throw SpecError(where, path,
                            "expected a number, got a distribution (here only the keys whose "
                            "documentation says so may be drawn)");
        }
        if (t->size() != 1) {
            throw SpecError(where, path,
                            "expected a number or a distribution {uniform = [a, b]} or "
                            "{normal = [mu, sigma]}");
        }
        auto first = t->begin();
        const std::string kind(first->first.str());
        const toml::array* arr = first->second.as_array();
        auto num = [&](size_t i) -> double {
            const toml::node* e = arr->get(i);
            double v;
            if (auto ii = e->as_integer()) {
                v = static_cast<double>(ii->get());
            } else if (auto ff = e->as_floating_point()) {
                v = ff->get();
                if (!std::isfinite(v)) {
                    throw SpecError(where, path, "distribution parameters must be finite");
                }
            } else {
                throw SpecError(where, path, "distribution parameters must be numbers");
            }
            if (std::abs(v) > kMaxSpecMagnitude) {
                throw SpecError(where, path,
                                "distribution parameters must have magnitude at most 1e9, got " +
                                    formatNumber(v));
            }
            return v;
        };
        if (kind != "uniform" && kind != "normal") {
            std::string hint;
            if (auto s = closestWord(kind, {"uniform", "normal"})) {
                hint = "; did you mean \"" + *s + "\"?";
            }
            throw SpecError(where, path,
                            "expected a distribution {uniform = [a, b]} or {normal = [mu, sigma]}, "
                            "got key \"" +
                                kind + "\"" + hint);
        }
        if (!arr || arr->size() != 2) {
            const std::string args = kind == "uniform" ? "a, b" : "mu, sigma";
            throw SpecError(where, path,
                            "expected {" + kind + " = [" + args + "]}: an array of two numbers");
        }
        double a = num(0), b = num(1);
        double value;
        Rng rng = Rng(draw_ ? draw_->seed : 0).derive(path);
        if (kind == "uniform") {
            if (!(a <= b)) throw SpecError(where, path, "uniform [a, b] needs a ≤ b");
            if (!range.contains(a) || !range.contains(b)) {
                throw SpecError(where, path,
                                "uniform bounds must lie in the valid range: expected " +
                                    range.describe(wantInteger));
            }
            value = (draw_ && draw_->draw) ? rng.uniform(a, b) : 0.5 * (a + b);
            if (wantInteger) value = std::floor(value + 0.5);
            if (wantInteger && (!range.contains(value))) value = std::round(a);
        } else {
            if (!(b >= 0)) throw SpecError(where, path, "normal [mu, sigma] needs sigma ≥ 0");
            if (!range.contains(a)) {
                throw SpecError(where, path,
                                "normal mean must lie in the valid range: expected " +
                                    range.describe(wantInteger));
            }
            value = (draw_ && draw_->draw) ? rng.normal(a, b) : a;
            if (wantInteger) value = std::floor(value + 0.5);
            // Draws outside the valid range are clamped to it (documented in the README).
            if (!range.contains(value)) {
                double lo = unboundedBelow(range) ? -kMaxSpecMagnitude : range.lo;
                double hi = unboundedAbove(range) ? kMaxSpecMagnitude : range.hi;
                if (range.loOpen) lo = lo + std::max(1e-9, std::abs(lo) * 1e-9);
                if (range.hiOpen) hi = hi - std::max(1e-9, std::abs(hi) * 1e-9);
                if (wantInteger) {
                    lo = std::ceil(lo);
                    hi = std::floor(hi);
                }
                value = std::clamp(value, lo, hi);
            }
        }
        if (draw_ && draw_->draw) draw_->sampled[path] = value;
        return value;
    }
    throw SpecError(where, path,
                    "expected " + range.describe(wantInteger) + ", got " + typeName(node));
}

double Params::number(std::string_view key, const Range& range) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) fail(key, "required key missing (expected " + range.describe(false) + ")");
    return readNumber(*n, w, path(key), range, false);
}

double Params::number(std::string_view key, double fallback, const Range& range) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) return fallback;
    return readNumber(*n, w, path(key), range, false);
}

double Params::numberOrDistribution(std::string_view key, const Range& range) {
    // Restores the table's own rule however number() leaves (a value or a SpecError).
    struct Restore {
        bool& flag;
        bool was;
        ~Restore() { flag = was; }
    } restore{allowDistribution_, allowDistribution_};
    allowDistribution_ = true;
    return number(key, range);
}

int64_t Params::readInteger(const toml::node& node, const SourcePos& where, const std::string& path,
                            const Range& range) {
    if (auto i = node.as_integer()) {
        // Exact: a 64-bit integer is not rounded through a double (seeds above 2⁵³).
        const int64_t v = i->get();
        if (!range.contains(static_cast<double>(v))) {
            throw SpecError(where, path,
                            outOfRange(range, true, static_cast<double>(v), std::to_string(v)));
        }
        return v;
    }
    if (auto f = node.as_floating_point()) {
        const double v = f->get();
        if (std::isfinite(v) && std::floor(v) == v && std::abs(v) < 1e15) {
            char whole[64];
            std::snprintf(whole, sizeof whole, "%.1f", v);
            throw SpecError(where, path,
                            std::string("expected an integer, got the float ") + whole +
                                " (write integers without a decimal point or exponent)");
        }
        throw SpecError(where, path, "expected an integer, got " + formatNumber(v));
    }
    return static_cast<int64_t>(readNumber(node, where, path, range, true));
}

int64_t Params::integer(std::string_view key, const Range& range) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) fail(key, "required key missing (expected " + range.describe(true) + ")");
    return readInteger(*n, w, path(key), range);
}

int64_t Params::integer(std::string_view key, int64_t fallback, const Range& range) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) return fallback;
    return readInteger(*n, w, path(key), range);
}

bool Params::boolean(std::string_view key, bool fallback) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) return fallback;
    if (auto b = n->as_boolean()) return b->get();
    throw SpecError(w, path(key), "expected true or false");
}

std::string Params::string(std::string_view key) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) fail(key, "required string missing");
    if (auto s = n->as_string()) return s->get();
    throw SpecError(w, path(key), "expected a string");
}

std::string Params::string(std::string_view key, std::string fallback) {
    if (!has(key)) {
        ask(key);
        return fallback;
    }
    return string(key);
}

std::string Params::choice(std::string_view key, std::string fallback,
                           const std::vector<std::string>& allowed) {
    std::string v = string(key, fallback);
    for (const auto& a : allowed) {
        if (a == v) return v;
    }
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "\"" : ", \"") + a + "\"";
    std::string hint;
    if (auto s = closestWord(v, std::set<std::string>(allowed.begin(), allowed.end()))) {
        hint = "; did you mean \"" + *s + "\"?";
    }
    fail(key, "expected one of " + list + ", got \"" + v + "\"" + hint);
}

double Params::degrees(std::string_view key, double fallbackRad, const Range& rangeDeg) {
    ask(key);
    if (!has(key)) return fallbackRad;
    return number(key, rangeDeg) * (kPi / 180.0);
}

std::pair<double, double> Params::degreeInterval(std::string_view key,
                                                 std::pair<double, double> fallbackRad,
                                                 const Range& rangeDeg) {
    ask(key);
    if (!has(key)) return fallbackRad;
    const auto [lo, hi] = interval(key, {0, 0}, rangeDeg);
    return {lo * (kPi / 180.0), hi * (kPi / 180.0)};
}

Vec3 Params::vec3(std::string_view key, const Vec3& fallback, const Range& range) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) return fallback;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3) throw SpecError(w, path(key), "expected an array [x, y, z]");
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
        v[i] = readNumber(*a->get(i), w, path(key) + "[" + std::to_string(i) + "]", range, false);
    }
    return v;
}

std::pair<double, double> Params::interval(std::string_view key, std::pair<double, double> fallback,
                                           const Range& range) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) return fallback;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 2) throw SpecError(w, path(key), "expected an array [lo, hi]");
    double lo = readNumber(*a->get(0), w, path(key) + "[0]", range, false);
    double hi = readNumber(*a->get(1), w, path(key) + "[1]", range, false);
    if (lo > hi) throw SpecError(w, path(key), "expected lo ≤ hi in [lo, hi]");
    return {lo, hi};
}

Params Params::table(std::string_view key) {
    auto t = optionalTable(key);
    if (!t) fail(key, "required table missing");
    return *t;
}

std::optional<Params> Params::optionalTable(std::string_view key) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) {
        // An absent optional table still exists for a sweep overriding a key inside it.
        static const toml::table kEmpty;
        const std::string inside = path(key) + ".";
        if (overrides_) {
            auto it = overrides_->lower_bound(inside);
            if (it != overrides_->end() && it->first.compare(0, inside.size(), inside) == 0) {
                return child(kEmpty, path(key), docPath(key));
            }
        }
        return std::nullopt;
    }
    const toml::table* t = n->as_table();
    if (!t) throw SpecError(w, path(key), "expected a table");
    return child(*t, path(key), docPath(key));
}

std::vector<Params> Params::tableArray(std::string_view key) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    std::vector<Params> out;
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a) throw SpecError(w, path(key), "expected an array of tables");
    for (size_t i = 0; i < a->size(); ++i) {
        const toml::table* t = a->get(i)->as_table();
        std::string p = path(key) + "[" + std::to_string(i) + "]";
        if (!t) throw SpecError(sourceOf(*a->get(i), file_), p, "expected a table");
        out.push_back(child(*t, p, docPath(key) + "[]"));
    }
    return out;
}

std::vector<std::string> Params::stringArray(std::string_view key) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    std::vector<std::string> out;
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a) throw SpecError(w, path(key), "expected an array of strings");
    for (size_t i = 0; i < a->size(); ++i) {
        auto s = a->get(i)->as_string();
        if (!s) throw SpecError(w, path(key), "expected an array of strings");
        out.push_back(s->get());
    }
    return out;
}

std::vector<Vec2> Params::pairArray(std::string_view key, size_t minCount) {
    ask(key);
    SourcePos w;
    const toml::node* n = lookup(key, &w);
    if (!n) fail(key, "missing: expected an array of [a, b] number pairs");
    const toml::array* a = n->as_array();
    auto bad = [&](const toml::node& at, const std::string& why) {
        throw SpecError(sourceOf(at, file_), path(key), why);
    };
    if (!a) bad(*n, "expected an array of [a, b] number pairs");
    std::vector<Vec2> out;
    for (size_t i = 0; i < a->size(); ++i) {
        const toml::array* pair = a->get(i)->as_array();
        if (!pair || pair->size() != 2 || !pair->get(0)->is_number() ||
            !pair->get(1)->is_number()) {
            bad(*a->get(i), "item " + std::to_string(i) + ": expected [a, b], two numbers");
        }
        const double x = pair->get(0)->value<double>().value_or(NAN);
        const double y = pair->get(1)->value<double>().value_or(NAN);
        if (!std::isfinite(x) || !std::isfinite(y) || std::abs(x) > kMaxSpecMagnitude ||
            std::abs(y) > kMaxSpecMagnitude) {
            bad(*a->get(i),
                "item " + std::to_string(i) + ": expected finite numbers of magnitude at most 1e9");
        }
        out.push_back({x, y});
    }
    if (out.size() < minCount) {
        bad(*n, "expected at least " + std::to_string(minCount) + " points, got " +
                    std::to_string(out.size()));
    }
    return out;
}

std::string Params::filePath(std::string_view key) {
    const std::string name = string(key);
    std::filesystem::path p(name);
    if (p.is_relative()) p = std::filesystem::path(file_).parent_path() / p;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) fail(key, "file not found: " + p.string());
    return p.string();
}

Rng Params::randomStream(std::string_view key) {
    if (draw_ && draw_->draw) draw_->perInstance = true;
    return Rng((draw_ && draw_->draw) ? draw_->seed : 0).derive(path(key) + "#stream");
}

void Params::finish() const {
    for (const auto& [k, v] : *table_) {
        std::string key(k.str());
        if (asked_.count(key)) continue;
        std::string hint;
        if (auto s = closestWord(key, asked_)) hint = "; did you mean \"" + *s + "\"?";
        throw SpecError(sourceOf(v, file_), path(key), "unknown key" + hint);
    }
}

}  // namespace sylva
