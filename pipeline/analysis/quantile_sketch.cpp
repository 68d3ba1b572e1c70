#include "pipeline/analysis/quantile_sketch.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace sylva {

namespace {

// Capacity of compactor `h` of `levels`: k·(2/3)^(levels − 1 − h), at least 2 (KLL §3).
size_t capacityAt(size_t below) {
    const double c = std::pow(2.0 / 3.0, static_cast<double>(below));
    return std::max<size_t>(2, static_cast<size_t>(std::ceil(QuantileSketch::kK * c)));
}

// The same from a table of the first 64 (a sketch of n values has about log₂ n levels): every
// value added asks for each level's, and std::pow was a fifth of `sylva stats`.
size_t capacity(size_t h, size_t levels) {
    static const std::array<size_t, 64> table = [] {
        std::array<size_t, 64> t{};
        for (size_t e = 0; e < t.size(); ++e) t[e] = capacityAt(e);
        return t;
    }();
    const size_t below = levels - 1 - h;
    return below < table.size() ? table[below] : capacityAt(below);
}

}  // namespace

uint64_t QuantileSketch::nextBit() {
    // SplitMix64: a well-mixed bit per compaction from the caller's seed.
    uint64_t z = (rng_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return (z ^ (z >> 31)) & 1u;
}

void QuantileSketch::add(double x) {
    ++n_;
    const double d = x - mean_;
    mean_ += d / static_cast<double>(n_);
    m2_ += d * (x - mean_);
    if (exact()) {
        values_.push_back(x);
        if (values_.size() <= kExact) return;
        levels_.emplace_back(std::move(values_));  // every value at weight 1
        values_.clear();
        values_.shrink_to_fit();
    } else {
        levels_[0].push_back(x);
    }
    compress();
}

void QuantileSketch::compress() {
    for (;;) {
        size_t total = 0, room = 0;
        for (size_t h = 0; h < levels_.size(); ++h) {
            total += levels_[h].size();
            room += capacity(h, levels_.size());
        }
        if (total <= room) return;
        // The lowest compactor over its capacity keeps every other sorted item, from a random
        // offset, at twice the weight one level up; an odd one out stays.
        for (size_t h = 0; h < levels_.size(); ++h) {
            if (levels_[h].size() < capacity(h, levels_.size())) continue;
            if (h + 1 == levels_.size()) levels_.emplace_back();
            std::vector<double>& items = levels_[h];
            std::sort(items.begin(), items.end());
            double keep = 0;
            const bool odd = items.size() % 2 == 1;
            if (odd) {
                keep = items.back();
                items.pop_back();
            }
            const size_t offset = nextBit();
            std::vector<double>& up = levels_[h + 1];
            for (size_t i = offset; i < items.size(); i += 2) up.push_back(items[i]);
            items.clear();
            if (odd) items.push_back(keep);
            break;
        }
    }
}

std::vector<double> QuantileSketch::sortedValues() const {
    std::vector<double> v = values_;
    std::sort(v.begin(), v.end());
    return v;
}

std::vector<std::pair<double, uint64_t>> QuantileSketch::weighted() const {
    std::vector<std::pair<double, uint64_t>> w;
    if (exact()) {
        for (double x : sortedValues()) w.emplace_back(x, 1);
        return w;
    }
    for (size_t h = 0; h < levels_.size(); ++h) {
        for (double x : levels_[h]) w.emplace_back(x, uint64_t{1} << h);
    }
    std::sort(w.begin(), w.end());  // a compaction halves the items and doubles their weight:
    return w;                       // the weights sum to count()
}

double QuantileSketch::quantile(double q) const {
    if (n_ == 0) return std::nan("");
    if (exact()) {
        const std::vector<double> v = sortedValues();
        if (v.size() == 1) return v[0];
        const double h = static_cast<double>(v.size() - 1) * q;
        const auto lo = static_cast<size_t>(std::floor(h));
        if (lo >= v.size() - 1) return v.back();
        return v[lo] + (h - static_cast<double>(lo)) * (v[lo + 1] - v[lo]);
    }
    const auto w = weighted();
    double total = 0;
    for (const auto& [x, wt] : w) total += static_cast<double>(wt);
    // Item i stands for the ranks [c_i − w_i, c_i) of `total`; its midpoint rank is its place.
    const double target = q * total;
    double cum = 0, prevMid = 0, prevX = w.front().first;
    for (size_t i = 0; i < w.size(); ++i) {
        const double mid = cum + 0.5 * static_cast<double>(w[i].second);
        if (mid >= target) {
            if (i == 0) return w[0].first;
            return prevX + (target - prevMid) / (mid - prevMid) * (w[i].first - prevX);
        }
        cum += static_cast<double>(w[i].second);
        prevMid = mid;
        prevX = w[i].first;
    }
    return w.back().first;
}

double QuantileSketch::mean() const {
    if (exact()) {
        const std::vector<double> v = sortedValues();
        return v.empty() ? std::nan("")
                         : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    }
    return mean_;
}

std::optional<double> QuantileSketch::sd() const {
    if (n_ < 2) return std::nullopt;
    if (exact()) {
        const std::vector<double> v = sortedValues();
        const double m = mean();
        double ss = 0;
        for (double x : v) ss += (x - m) * (x - m);
        return std::sqrt(ss / static_cast<double>(v.size() - 1));
    }
    return std::sqrt(m2_ / static_cast<double>(n_ - 1));
}

size_t QuantileSketch::retained() const {
    size_t r = values_.size();
    for (const auto& l : levels_) r += l.size();
    return r;
}

namespace {

// Walks the merged values of two weighted samples, calling f(x, F_a(x), F_b(x)) after all
// copies of each value x (CDFs normalised by each sample's total weight).
template <class F>
void walkCdfs(const std::vector<std::pair<double, uint64_t>>& a,
              const std::vector<std::pair<double, uint64_t>>& b, F f) {
    double ta = 0, tb = 0;
    for (const auto& p : a) ta += static_cast<double>(p.second);
    for (const auto& p : b) tb += static_cast<double>(p.second);
    size_t i = 0, j = 0;
    double ca = 0, cb = 0;
    while (i < a.size() || j < b.size()) {
        const double x =
            (j >= b.size() || (i < a.size() && a[i].first <= b[j].first)) ? a[i].first : b[j].first;
        while (i < a.size() && a[i].first == x) ca += static_cast<double>(a[i++].second);
        while (j < b.size() && b[j].first == x) cb += static_cast<double>(b[j++].second);
        f(x, ca / ta, cb / tb);
    }
}

}  // namespace

double weightedKsDistance(const std::vector<std::pair<double, uint64_t>>& a,
                          const std::vector<std::pair<double, uint64_t>>& b) {
    if (a.empty() || b.empty()) return 0;
    double d = 0;
    walkCdfs(a, b, [&](double, double fa, double fb) { d = std::max(d, std::fabs(fa - fb)); });
    return d;
}

double weightedWasserstein(const std::vector<std::pair<double, uint64_t>>& a,
                           const std::vector<std::pair<double, uint64_t>>& b) {
    if (a.empty() || b.empty()) return 0;
    double w = 0, prevX = std::min(a.front().first, b.front().first), prevA = 0, prevB = 0;
    walkCdfs(a, b, [&](double x, double fa, double fb) {
        w += std::fabs(prevA - prevB) * (x - prevX);
        prevX = x;
        prevA = fa;
        prevB = fb;
    });
    return w;
}

}  // namespace sylva
