#include "pipeline/analysis/dataset_stats.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <regex>
#include <set>
#include <sstream>
#include <unordered_set>

#include "core/atomic_file.h"
#include "core/input_file.h"
#include "pipeline/analysis/dataset_reader.h"
#include "pipeline/analysis/quantile_sketch.h"
#include "pipeline/batch/output_lock.h"
#include "pipeline/batch/pack.h"
#include "pipeline/formats/skeleton_reader.h"
#include "pipeline/formats/skeleton_writers.h"
#include "species/model/reference_metrics.h"

namespace fs = std::filesystem;

namespace sylva {

double quantileType7(const std::vector<double>& sorted, double q) {
    const size_t n = sorted.size();
    if (n == 1) return sorted[0];
    double h = static_cast<double>(n - 1) * q;
    size_t lo = static_cast<size_t>(std::floor(h));
    if (lo >= n - 1) return sorted[n - 1];
    return sorted[lo] + (h - static_cast<double>(lo)) * (sorted[lo + 1] - sorted[lo]);
}

namespace {

// P(D < d) for sample sizes m, n without ties: Hodges' lattice-path count, normalised as it goes
// (the recursion of R's psmirnov / Marsaglia, Tsang & Wang style). A path is excluded as soon as
// |i/m − j/n| ≥ d.
double ksExactBelow(double d, int m, int n) {
    if (m > n) std::swap(m, n);
    const double md = m, nd = n;
    // m·n·D is an integer; q sits half-way below it so rounding cannot flip the comparison.
    const double q = (0.5 + std::floor(d * md * nd - 1e-7)) / (md * nd);
    std::vector<double> u(static_cast<size_t>(n) + 1);
    for (int j = 0; j <= n; ++j) u[j] = (j / nd > q) ? 0.0 : 1.0;
    for (int i = 1; i <= m; ++i) {
        const double w = static_cast<double>(i) / static_cast<double>(i + n);
        u[0] = (i / md > q) ? 0.0 : w * u[0];
        for (int j = 1; j <= n; ++j) {
            u[j] = (std::fabs(i / md - j / nd) > q) ? 0.0 : w * u[j] + u[j - 1];
        }
    }
    return u[n];
}

// Kolmogorov's survival function Q(λ) = 2 Σ_{j≥1} (−1)^(j−1) e^(−2 j² λ²).
double kolmogorovQ(double lambda) {
    if (lambda < 1e-3) return 1.0;
    double sum = 0, sign = 1;
    for (int j = 1; j <= 100; ++j) {
        double term = sign * std::exp(-2.0 * j * j * lambda * lambda);
        sum += term;
        if (std::fabs(term) < 1e-12 * std::fabs(sum)) break;
        sign = -sign;
    }
    return std::clamp(2.0 * sum, 0.0, 1.0);
}

}  // namespace

KsResult ksTwoSample(const std::vector<double>& a, const std::vector<double>& b) {
    const size_t na = a.size(), nb = b.size();
    size_t i = 0, j = 0;
    double d = 0;
    // Walk the merged order statistics; evaluate after all copies of a value are consumed.
    while (i < na && j < nb) {
        double x = std::min(a[i], b[j]);
        while (i < na && a[i] == x) ++i;
        while (j < nb && b[j] == x) ++j;
        d = std::max(d, std::fabs(static_cast<double>(i) / static_cast<double>(na) -
                                  static_cast<double>(j) / static_cast<double>(nb)));
    }
    KsResult r;
    r.d = d;
    if (d <= 0) {
        r.p = 1.0;
    } else if (static_cast<double>(na) * static_cast<double>(nb) <= 10000.0) {
        r.p =
            std::clamp(1.0 - ksExactBelow(d, static_cast<int>(na), static_cast<int>(nb)), 0.0, 1.0);
    } else {
        double ne =
            static_cast<double>(na) * static_cast<double>(nb) / static_cast<double>(na + nb);
        double s = std::sqrt(ne);
        r.p = kolmogorovQ((s + 0.12 + 0.11 / s) * d);
    }
    return r;
}

double ksAsymptoticP(double d, double na, double nb) {
    if (d <= 0) return 1.0;
    const double s = std::sqrt(na * nb / (na + nb));
    return kolmogorovQ((s + 0.12 + 0.11 / s) * d);
}

double wasserstein1(const std::vector<double>& a, const std::vector<double>& b) {
    const size_t na = a.size(), nb = b.size();
    size_t i = 0, j = 0;
    double w = 0, prev = std::min(a[0], b[0]);
    // Between consecutive merged values x_k < x_{k+1}, both CDFs are constant.
    while (i < na || j < nb) {
        double x = (j >= nb || (i < na && a[i] <= b[j])) ? a[i] : b[j];
        w += std::fabs(static_cast<double>(i) / static_cast<double>(na) -
                       static_cast<double>(j) / static_cast<double>(nb)) *
             (x - prev);
        prev = x;
        while (i < na && a[i] == x) ++i;
        while (j < nb && b[j] == x) ++j;
    }
    return w;
}

MetricSummary summarize(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    MetricSummary s;
    s.count = v.size();
    if (v.empty()) return s;
    s.mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    if (v.size() >= 2) {
        double ss = 0;
        for (double x : v) ss += (x - s.mean) * (x - s.mean);
        s.sd = std::sqrt(ss / static_cast<double>(v.size() - 1));
        if (s.mean != 0) s.cv = *s.sd / std::fabs(s.mean);
    }
    s.q05 = quantileType7(v, 0.05);
    s.q25 = quantileType7(v, 0.25);
    s.q50 = quantileType7(v, 0.50);
    s.q75 = quantileType7(v, 0.75);
    s.q95 = quantileType7(v, 0.95);
    return s;
}

double quantileTableCdf(const QuantileTable& t, double x, bool left) {
    const std::vector<double>& q = t.q;
    size_t k;  // the segment [q[k], q[k+1]] holding x, with q[k] < q[k+1]
    if (left) {
        if (x <= q.front()) return 0.0;
        if (x > q.back()) return 1.0;
        k = static_cast<size_t>(std::lower_bound(q.begin(), q.end(), x) - q.begin()) - 1;
    } else {
        if (x < q.front()) return 0.0;
        if (x >= q.back()) return 1.0;
        k = static_cast<size_t>(std::upper_bound(q.begin(), q.end(), x) - q.begin()) - 1;
    }
    return t.p[k] + (t.p[k + 1] - t.p[k]) * (x - q[k]) / (q[k + 1] - q[k]);
}

double quantileTableQuantile(const QuantileTable& t, double p) {
    const std::vector<double>& ps = t.p;
    if (p <= ps.front()) return t.q.front();
    if (p >= ps.back()) return t.q.back();
    size_t k = static_cast<size_t>(std::upper_bound(ps.begin(), ps.end(), p) - ps.begin()) - 1;
    return t.q[k] + (t.q[k + 1] - t.q[k]) * (p - ps[k]) / (ps[k + 1] - ps[k]);
}

QuantileTable sampleTable(const std::vector<double>& sorted) {
    QuantileTable t;
    const size_t n = sorted.size();
    if (n == 1) {
        t.p = {0.0, 1.0};
        t.q = {sorted[0], sorted[0]};
        return t;
    }
    t.q = sorted;
    t.p.resize(n);
    for (size_t i = 0; i < n; ++i) t.p[i] = static_cast<double>(i) / static_cast<double>(n - 1);
    return t;
}

double ksDistance(const QuantileTable& a, const QuantileTable& b) {
    double d = 0;
    for (const QuantileTable* t : {&a, &b}) {
        for (double x : t->q) {
            d = std::max(d, std::fabs(quantileTableCdf(a, x) - quantileTableCdf(b, x)));
            d = std::max(d, std::fabs(quantileTableCdf(a, x, true) - quantileTableCdf(b, x, true)));
        }
    }
    return d;
}

Reference readReference(const fs::path& file) {
    const std::string name = file.string();
    auto fail = [&](const std::string& what) { throw DatasetStatsInputError(name + ": " + what); };
    std::string text;
    try {
        text = readInputFile(file, kMaxReferenceBytes, "a reference file");
    } catch (const InputError& e) {
        throw DatasetStatsInputError(e.what());
    }
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded()) fail("not JSON");
    if (!j.is_object() || !j.contains("distributions") || !j["distributions"].is_object()) {
        fail("expected a JSON object with an object \"distributions\"");
    }
    Reference ref;
    ref.name = j.contains("name") && j["name"].is_string() ? j["name"].get<std::string>()
                                                           : file.filename().string();
    std::string known;
    for (const char* k : kReferenceDistributionNames)
        known += (known.empty() ? "" : ", ") + std::string(k);
    for (const auto& [key, v] : j["distributions"].items()) {
        const std::string& name = key;  // C++17 lambdas cannot capture a structured binding
        const std::string where = "distributions." + name;
        if (std::find_if(kReferenceDistributionNames.begin(), kReferenceDistributionNames.end(),
                         [&](const char* k) { return name == k; }) ==
            kReferenceDistributionNames.end()) {
            fail(where + ": unknown distribution; expected one of " + known);
        }
        if (!v.is_object()) fail(where + ": expected an object with arrays \"p\" and \"q\"");
        Reference::Distribution dist;
        for (const char* arr : {"p", "q"}) {
            if (!v.contains(arr) || !v[arr].is_array()) {
                fail(where + ": expected an array \"" + arr + "\"");
            }
            std::vector<double>& out = arr[0] == 'p' ? dist.table.p : dist.table.q;
            for (const auto& x : v[arr]) {
                if (!x.is_number() || !std::isfinite(x.get<double>())) {
                    fail(where + "." + arr + ": expected finite numbers");
                }
                out.push_back(x.get<double>());
            }
        }
        const auto &p = dist.table.p, &q = dist.table.q;
        if (p.size() != q.size() || p.size() < 2) {
            fail(where + ": expected as many p as q, at least two");
        }
        if (p.front() != 0.0 || p.back() != 1.0) fail(where + ".p: expected 0 first and 1 last");
        for (size_t i = 1; i < p.size(); ++i) {
            if (!(p[i] > p[i - 1])) fail(where + ".p: expected strictly increasing probabilities");
            if (!(q[i] >= q[i - 1])) fail(where + ".q: expected non-decreasing quantiles");
        }
        for (const char* count : {"n", "trees"}) {
            if (!v.contains(count)) continue;
            if (!v[count].is_number_unsigned()) {
                fail(where + "." + count + ": expected a count (an integer >= 0)");
            }
            (count[0] == 'n' ? dist.n : dist.trees) = v[count].get<size_t>();
        }
        ref.distributions[key] = dist;
    }
    if (ref.distributions.empty()) fail("\"distributions\" is empty");
    if (j.contains("trees")) {
        if (!j["trees"].is_number_unsigned()) fail("trees: expected a count (an integer >= 0)");
        ref.trees = j["trees"].get<size_t>();
    }
    return ref;
}

ReferenceValues readSkeletonReferenceValues(const fs::path& path) {
    std::string bytes;
    try {
        bytes = readInputFile(path, kMaxSkeletonBytes, "a skeleton");
    } catch (const InputError& e) {
        throw DatasetStatsInputError(std::string(e.what()) +
                                     "; the manifest lists it as skeleton_ply");
    }
    return skeletonReferenceValuesOf(bytes, path.string());
}

ReferenceValues skeletonReferenceValuesOf(const std::string& bytes, const std::string& name) {
    const fs::path path = name;
    try {
        return referenceValues(readSkeletonPly(bytes, name));
    } catch (const DatasetStatsInputError&) {
        throw;
    } catch (const InputError& e) {  // readSkeletonPly's message names the file
        throw DatasetStatsInputError(e.what());
    } catch (const std::invalid_argument& e) {
        throw DatasetStatsInputError(path.string() + ": " + e.what());
    }
}

ReferenceValues skeletonReferenceValues(const Tree& tree) {
    return referenceValues(readSkeletonPly(skeletonPly(tree), "skeleton.ply"));
}

void poolReferenceValues(ReferenceValues& pool, const ReferenceValues& tree) {
    for (int k = 0; k < kReferenceDistributions; ++k) {
        pool[k].insert(pool[k].end(), tree[k].begin(), tree[k].end());
    }
}

std::optional<double> referenceDistance(std::vector<double> values, const QuantileTable& table) {
    if (values.empty()) return std::nullopt;
    std::sort(values.begin(), values.end());
    return ksDistance(sampleTable(values), table);
}

namespace {

using MetricValues = std::map<std::string, std::vector<double>>;

struct Record {
    int64_t index = 0;
    std::string id, species, habit;
    std::string skeleton;  // files.skeleton_ply, relative to the dataset directory ("" if none)
    std::string pack;      // packed: the tar holding it (skeleton is a member's name)
    std::map<std::string, double> metrics;
    std::vector<std::pair<std::string, std::string>> sweep;  // path → value (as text)
};

// Flattens a stats object: numbers as themselves; arrays element-wise as key[i] plus, when every
// element is a number, their mean as key_mean; nested objects as key.sub.
void flatten(const nlohmann::json& j, const std::string& key, std::map<std::string, double>& out) {
    if (j.is_number()) {
        double x = j.get<double>();
        if (std::isfinite(x)) out[key] = x;
    } else if (j.is_array()) {
        double sum = 0;
        bool allNumbers = !j.empty();
        for (size_t i = 0; i < j.size(); ++i) {
            flatten(j[i], key + "[" + std::to_string(i) + "]", out);
            if (j[i].is_number() && std::isfinite(j[i].get<double>())) {
                sum += j[i].get<double>();
            } else {
                allNumbers = false;
            }
        }
        if (allNumbers) out[key + "_mean"] = sum / static_cast<double>(j.size());
    } else if (j.is_object()) {
        for (const auto& [k, v] : j.items()) flatten(v, key.empty() ? k : key + "." + k, out);
    }
}

std::string sweepText(const nlohmann::json& v) {
    return v.is_string() ? v.get<std::string>() : v.dump();
}

// A checked manifest record (dataset_reader.h) as stats uses it. A plot's record names its plot
// instead of a species: its statistics are grouped under the plot's name, as a species' are.
Record statsRecord(const ManifestRecord& m, const DatasetStatsOptions& options) {
    const nlohmann::json& j = m.json;
    Record r;
    r.id = m.id;
    r.index = m.index;
    r.species = m.group;
    r.habit = m.plot ? "plot" : j.value("habit", std::string());
    r.pack = m.pack;
    if (j.contains("files") && j["files"].contains("skeleton_ply")) {
        r.skeleton = j["files"]["skeleton_ply"].get<std::string>();
    }
    if (j.contains("stats")) flatten(j["stats"], "", r.metrics);
    if (options.timing && j.contains("timing")) flatten(j["timing"], "timing", r.metrics);
    if (j.contains("sweep")) {
        for (const auto& [k, v] : j["sweep"].items()) r.sweep.emplace_back(k, sweepText(v));
    }
    return r;
}

// Numeric order when every value parses as a number, else text order.
bool parseNumber(const std::string& s, double& x) {
    if (s.empty()) return false;
    char* end = nullptr;
    x = std::strtod(s.c_str(), &end);
    return end == s.c_str() + s.size();
}
std::vector<std::string> orderedValues(const std::set<std::string>& values) {
    std::vector<std::string> v(values.begin(), values.end());
    bool numeric = true;
    double x;
    for (const auto& s : v) numeric = numeric && parseNumber(s, x);
    if (numeric) {
        std::stable_sort(v.begin(), v.end(), [](const std::string& a, const std::string& b) {
            return std::strtod(a.c_str(), nullptr) < std::strtod(b.c_str(), nullptr);
        });
    }
    return v;
}

std::string num(double x) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.10g", x);
    return buf;
}
std::string num(const std::optional<double>& x) { return x ? num(*x) : std::string(); }

std::string csvField(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) {
        if (c == '"') q += '"';
        q += c;
    }
    return q + "\"";
}

nlohmann::json optJson(const std::optional<double>& x) {
    return x ? nlohmann::json(*x) : nlohmann::json(nullptr);
}

// Per species, the reference distributions pooled over its instances' skeletons, streamed.
struct ReferencePool {
    std::array<QuantileSketch, kReferenceDistributions> values;
    size_t instances = 0;
};

struct ReferenceFiles {
    std::string csv, json, summary;
};
ReferenceFiles compareWithReference(const fs::path& file, const Reference& ref,
                                    std::map<std::string, ReferencePool>& pooled,
                                    const std::map<std::string, std::string>& habit,
                                    DatasetStatsResult& res) {
    ReferenceFiles f;
    f.csv = "species,habit,distribution,instances,n,d,median,reference_n,reference_median\n";
    nlohmann::json j;
    j["reference"] = {{"file", file.string()}, {"name", ref.name}};
    j["d"] =
        "sup |F_species - F_reference|: F_species linear between the pooled values' order "
        "statistics (type 7; from a KLL sketch's 1001 quantiles above 2048 values), "
        "F_reference linear between the reference's quantiles";
    j["species"] = nlohmann::json::object();
    f.summary = "reference " + ref.name + ": KS distance D per species and distribution\n";
    for (const std::string& sp : res.species) {
        nlohmann::json dj = nlohmann::json::object();
        std::string line = "  " + sp + ":";
        ReferencePool& pool = pooled[sp];
        for (int k = 0; k < kReferenceDistributions; ++k) {
            const std::string name = kReferenceDistributionNames[k];
            auto it = ref.distributions.find(name);
            if (it == ref.distributions.end()) continue;
            const QuantileSketch& sk = pool.values[k];
            DatasetStatsResult::ReferenceComparison c;
            c.instances = pool.instances;
            c.n = sk.count();
            if (sk.count() > 0 && sk.exact()) {
                const std::vector<double> v = sk.sortedValues();
                c.d = referenceDistance(v, it->second.table);
                c.median = quantileType7(v, 0.5);
            } else if (sk.count() > 0) {
                QuantileTable t;
                for (int i = 0; i <= 1000; ++i) {
                    t.p.push_back(i / 1000.0);
                    t.q.push_back(sk.quantile(i / 1000.0));
                }
                c.d = ksDistance(t, it->second.table);
                c.median = sk.quantile(0.5);
            }
            res.reference[sp][name] = c;
            const double refMedian = quantileTableQuantile(it->second.table, 0.5);
            const std::string h = habit.count(sp) ? habit.at(sp) : std::string();
            f.csv += csvField(sp) + "," + csvField(h) + "," + name + "," +
                     std::to_string(c.instances) + "," + std::to_string(c.n) + "," + num(c.d) +
                     "," + num(c.median) + "," + std::to_string(it->second.n) + "," +
                     num(refMedian) + "\n";
            dj[name] = {{"n", c.n},
                        {"d", optJson(c.d)},
                        {"median", optJson(c.median)},
                        {"reference_n", it->second.n},
                        {"reference_median", refMedian}};
            char buf[96];
            std::snprintf(buf, sizeof buf, " %s %s", name.c_str(),
                          c.d ? num(std::round(*c.d * 100) / 100).c_str() : "-");
            line += buf;
        }
        j["species"][sp] = {{"habit", habit.count(sp) ? habit.at(sp) : std::string()},
                            {"instances", pool.instances},
                            {"distributions", dj}};
        f.summary += line + "\n";
    }
    f.json = j.dump(2) + "\n";
    return f;
}

// A stream's summary as the tables print it: exact from the sorted values (as before sketches),
// from the sketch above QuantileSketch::kExact values.
MetricSummary summarize(const QuantileSketch& s) {
    if (s.exact()) return sylva::summarize(s.sortedValues());
    MetricSummary m;
    m.count = s.count();
    m.mean = s.mean();
    m.sd = s.sd();
    if (m.sd && m.mean != 0) m.cv = *m.sd / std::fabs(m.mean);
    m.q05 = s.quantile(0.05);
    m.q25 = s.quantile(0.25);
    m.q50 = s.quantile(0.50);
    m.q75 = s.quantile(0.75);
    m.q95 = s.quantile(0.95);
    return m;
}

// A sketch per stream, seeded by its name so that one manifest always gives the same files.
QuantileSketch& stream(std::map<std::string, QuantileSketch>& m, const std::string& name,
                       const std::string& owner) {
    auto it = m.find(name);
    if (it == m.end()) {
        it = m.emplace(name, QuantileSketch(std::hash<std::string>{}(owner + "/" + name))).first;
    }
    return it->second;
}

}  // namespace

DatasetStatsResult computeDatasetStats(const fs::path& dir, const DatasetStatsOptions& options) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
        throw DatasetStatsInputError(dir.string() + ": not a directory");
    }
    // DIR/stats/ is written into the dataset: not while a build (or another stats) runs there.
    OutputLock lock(dir, "sylva stats");
    std::optional<Reference> reference;
    if (!options.reference.empty()) reference = readReference(options.reference);

    // The manifests (manifest.jsonl, then the shards' in index order) streamed a record at a
    // time into bounded summaries (QuantileSketch), so memory does not grow with the records;
    // the description the build wrote first, checked (dataset_reader.h).
    using Streams = std::map<std::string, QuantileSketch>;
    std::map<std::string, Streams> bySpecies;
    // species → path → value → metric
    std::map<std::string, std::map<std::string, std::map<std::string, Streams>>> bySweep;
    std::set<std::string> allMetrics;
    // Species in the order of their first instance by (index, id), and its habit: the order the
    // tables list them, whichever manifest held which record.
    std::map<std::string, std::pair<int64_t, std::string>> firstOf;
    std::map<std::string, std::string> habit;
    std::map<std::string, ReferencePool> pooled;
    size_t skeletonsRead = 0;
    DatasetFiles packed(dir);
    DatasetStatsResult res;
    ManifestStream read;
    try {
        read = forEachManifestRecord(dir, [&](ManifestRecord& m) {
            const Record r = statsRecord(m, options);
            const std::pair<int64_t, std::string> key{r.index, r.id};
            auto first = firstOf.find(r.species);
            if (first == firstOf.end() || key < first->second) {
                firstOf[r.species] = key;
                habit[r.species] = r.habit;
            }
            ++res.counts[r.species];
            Streams& mv = bySpecies[r.species];
            for (const auto& [k, x] : r.metrics) {
                stream(mv, k, r.species).add(x);
                allMetrics.insert(k);
            }
            for (const auto& [path, value] : r.sweep) {
                Streams& sv = bySweep[r.species][path][value];
                for (const auto& [k, x] : r.metrics) {
                    stream(sv, k, r.species + "/" + path + "=" + value).add(x);
                }
            }
            if (reference && !r.skeleton.empty()) {
                ReferenceValues v;
                if (r.pack.empty()) {
                    v = readSkeletonReferenceValues(dir / r.skeleton);
                } else {
                    const std::string where = (dir / r.pack).string() + ": " + r.skeleton;
                    const std::optional<std::string> bytes = packed.read(r.pack, r.skeleton);
                    if (!bytes) {
                        throw DatasetStatsInputError(where +
                                                     ": no such member; the manifest lists it "
                                                     "as skeleton_ply");
                    }
                    v = skeletonReferenceValuesOf(*bytes, where);
                }
                ReferencePool& pool = pooled[r.species];
                for (int k = 0; k < kReferenceDistributions; ++k) {
                    for (double x : v[k]) pool.values[k].add(x);
                }
                ++pool.instances;
                ++skeletonsRead;
            }
        });
        (void)readDatasetDescription(dir);
    } catch (const DatasetStatsInputError&) {
        throw;
    } catch (const InputError& e) {
        throw DatasetStatsInputError(e.what());
    }
    res.outDir = dir / "stats";
    res.manifests = read.files;
    res.ignoredPartialLines = read.tornLines;
    if (read.records == 0) {
        throw DatasetStatsInputError(dir.string() + ": the manifest has no complete record yet");
    }
    if (reference && skeletonsRead == 0) {
        throw DatasetStatsInputError(dir.string() +
                                     ": --reference needs the instances' skeleton.ply, and the "
                                     "manifest lists none (outputs.skeleton = [\"ply\"])");
    }
    {
        std::vector<std::pair<std::pair<int64_t, std::string>, std::string>> order;
        for (const auto& [sp, key] : firstOf) order.emplace_back(key, sp);
        std::sort(order.begin(), order.end());
        for (const auto& o : order) res.species.push_back(o.second);
    }
    res.instances = read.records;
    res.metrics = allMetrics.size();

    std::map<std::string, std::map<std::string, MetricSummary>> summaries;
    for (auto& [sp, mv] : bySpecies) {
        for (auto& [k, v] : mv) summaries[sp][k] = summarize(v);
    }

    std::string speciesCsv = "species,metric,count,mean,sd,cv,q05,q25,q50,q75,q95\n";
    nlohmann::json sj;
    sj["instances"] = res.instances;
    sj["quantiles"] =
        "type 7: linear interpolation between order statistics, h = (n-1)p; above 2048 values "
        "from a KLL sketch (k = 200, rank error about 1%)";
    sj["sd"] = "sample standard deviation (n-1); null when count < 2";
    sj["cv"] = "sd / |mean|; null when sd is null or mean is 0";
    sj["species"] = nlohmann::json::object();
    for (const std::string& sp : res.species) {
        nlohmann::json mj = nlohmann::json::object();
        for (const auto& [k, s] : summaries[sp]) {
            speciesCsv += csvField(sp) + "," + csvField(k) + "," + std::to_string(s.count) + "," +
                          num(s.mean) + "," + num(s.sd) + "," + num(s.cv) + "," + num(s.q05) + "," +
                          num(s.q25) + "," + num(s.q50) + "," + num(s.q75) + "," + num(s.q95) +
                          "\n";
            mj[k] = {{"count", s.count},    {"mean", s.mean}, {"sd", optJson(s.sd)},
                     {"cv", optJson(s.cv)}, {"q05", s.q05},   {"q25", s.q25},
                     {"q50", s.q50},        {"q75", s.q75},   {"q95", s.q95}};
        }
        sj["species"][sp] = {{"instances", res.counts[sp]}, {"metrics", mj}};
    }

    // Pairs in species order; within a pair, metrics ranked by D, then by W1 / pooled sd.
    std::string compareCsv = "species_a,species_b,metric,n_a,n_b,ks_d,ks_p,wasserstein,rank\n";
    std::ostringstream summary;
    summary << res.species.size() << " species, " << res.instances << " instances, " << res.metrics
            << " metrics";
    if (res.ignoredPartialLines) {
        summary << " (" << res.ignoredPartialLines << " torn manifest line(s) ignored)";
    }
    summary << "\n";
    for (const std::string& sp : res.species) {
        summary << "  " << sp << ": " << res.counts[sp] << " instances\n";
    }
    size_t pairs = 0;
    for (size_t ia = 0; ia < res.species.size(); ++ia) {
        for (size_t ib = ia + 1; ib < res.species.size(); ++ib) {
            const std::string &sa = res.species[ia], &sb = res.species[ib];
            struct Row {
                std::string metric;
                size_t na, nb;
                KsResult ks;
                double w, wNorm;
            };
            std::vector<Row> rows;
            for (const auto& [k, qa] : bySpecies[sa]) {
                auto it = bySpecies[sb].find(k);
                if (it == bySpecies[sb].end()) continue;
                const QuantileSketch& qb = it->second;
                Row r{k, qa.count(), qb.count(), {}, 0, 0};
                if (qa.exact() && qb.exact()) {
                    const std::vector<double> va = qa.sortedValues(), vb = qb.sortedValues();
                    r.ks = ksTwoSample(va, vb);
                    r.w = wasserstein1(va, vb);
                } else {  // D from the sketches; p from the asymptotic distribution
                    const auto wa = qa.weighted(), wb = qb.weighted();
                    r.ks.d = weightedKsDistance(wa, wb);
                    r.ks.p =
                        ksAsymptoticP(r.ks.d, static_cast<double>(r.na), static_cast<double>(r.nb));
                    r.w = weightedWasserstein(wa, wb);
                }
                double pooledSd = 0;
                if (r.na + r.nb > 2) {
                    const auto &a = summaries[sa][k], &b = summaries[sb][k];
                    double sa2 = a.sd ? *a.sd * *a.sd : 0, sb2 = b.sd ? *b.sd * *b.sd : 0;
                    pooledSd = std::sqrt(((r.na - 1) * sa2 + (r.nb - 1) * sb2) /
                                         static_cast<double>(r.na + r.nb - 2));
                }
                r.wNorm = pooledSd > 0 ? r.w / pooledSd
                                       : (r.w > 0 ? std::numeric_limits<double>::infinity() : 0.0);
                rows.push_back(r);
            }
            std::stable_sort(rows.begin(), rows.end(), [](const Row& x, const Row& y) {
                if (x.ks.d != y.ks.d) return x.ks.d > y.ks.d;
                if (x.wNorm != y.wNorm) return x.wNorm > y.wNorm;
                return x.metric < y.metric;
            });
            const bool listed = pairs++ < options.maxPairsListed;
            std::ostringstream line;
            line << "  " << sa << " vs " << sb << ":";
            for (size_t r = 0; r < rows.size(); ++r) {
                const Row& x = rows[r];
                compareCsv += csvField(sa) + "," + csvField(sb) + "," + csvField(x.metric) + "," +
                              std::to_string(x.na) + "," + std::to_string(x.nb) + "," +
                              num(x.ks.d) + "," + num(x.ks.p) + "," + num(x.w) + "," +
                              std::to_string(r + 1) + "\n";
                if (static_cast<int>(r) < options.topMetrics) {
                    char buf[160];
                    std::snprintf(buf, sizeof buf, "%s %s (D %.2f, p %.2g)", r ? "," : "",
                                  x.metric.c_str(), x.ks.d, x.ks.p);
                    line << buf;
                }
            }
            if (rows.empty()) line << " no metric in common";
            if (listed) summary << line.str() << "\n";
        }
    }
    if (pairs > options.maxPairsListed) {
        summary << "  … and " << pairs - options.maxPairsListed << " more pairs in compare.csv\n";
    }

    std::string sweepCsv = "species,path,value,metric,count,mean,sd,q25,q75\n";
    for (const std::string& sp : res.species) {
        auto its = bySweep.find(sp);
        if (its == bySweep.end()) continue;
        for (const auto& [path, byValue] : its->second) {
            std::set<std::string> values;
            for (const auto& kv : byValue) values.insert(kv.first);
            for (const std::string& value : orderedValues(values)) {
                for (const auto& [k, v] : byValue.at(value)) {
                    MetricSummary s = summarize(v);
                    sweepCsv += csvField(sp) + "," + csvField(path) + "," + csvField(value) + "," +
                                csvField(k) + "," + std::to_string(s.count) + "," + num(s.mean) +
                                "," + num(s.sd) + "," + num(s.q25) + "," + num(s.q75) + "\n";
                }
            }
        }
    }

    std::optional<ReferenceFiles> referenceFiles;
    if (reference) {
        referenceFiles = compareWithReference(options.reference, *reference, pooled, habit, res);
    }

    writeFileAtomic(res.outDir / "species.csv", speciesCsv);
    writeFileAtomic(res.outDir / "species.json", sj.dump(2) + "\n");
    writeFileAtomic(res.outDir / "compare.csv", compareCsv);
    writeFileAtomic(res.outDir / "sweep.csv", sweepCsv);
    if (referenceFiles) {
        writeFileAtomic(res.outDir / "reference.csv", referenceFiles->csv);
        writeFileAtomic(res.outDir / "reference.json", referenceFiles->json);
        summary << referenceFiles->summary;
    }
    summary << "-> " << res.outDir.string() << "/{species.csv,species.json,compare.csv,sweep.csv"
            << (referenceFiles ? ",reference.csv,reference.json" : "") << "}\n";
    res.summary = summary.str();
    return res;
}

}  // namespace sylva
