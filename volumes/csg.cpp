// Constructive solid geometry on signed distances: union = min, intersection = max,
// difference = max(a, −b). Signs are exact; magnitudes are conservative bounds.
// Sampling is exactly uniform and deterministic (a pure function of the rng draws).
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>

#include "volumes/volume.h"

namespace sylva {
namespace {

// Monte-Carlo estimates below use this many draws and a fixed seed, so measure() is a pure
// function of the volume (about ±0.5 % error).
constexpr int kMeasureSamples = 20000;
constexpr uint64_t kMeasureSeed = 0xc59'0000'0000'0001ull;

std::string joinDescriptions(const char* op, const std::vector<VolumePtr>& parts,
                             const VolumePtr& first = nullptr) {
    std::string s = op;
    s += '(';
    bool comma = false;
    auto add = [&](const VolumePtr& v) {
        if (comma) s += ", ";
        s += v->describe();
        comma = true;
    };
    if (first) add(first);
    for (const auto& p : parts) add(p);
    s += ')';
    // Error messages quote this; keep it to one readable line.
    constexpr size_t kMax = 200;
    if (s.size() > kMax) s = s.substr(0, kMax - 4) + "...)";
    return s;
}

void requireParts(const std::vector<VolumePtr>& parts, const char* who) {
    for (const auto& p : parts)
        if (!p) throw std::invalid_argument(std::string(who) + ": a part is null");
}

class Union final : public Volume {
  public:
    explicit Union(std::vector<VolumePtr> parts) : parts_(std::move(parts)) {
        double acc = 0.0;
        cumulative_.reserve(parts_.size());
        for (const auto& p : parts_) {
            acc += std::max(0.0, p->measure());
            cumulative_.push_back(acc);
            bounds_.extend(p->bounds());
        }
    }

    double signedDistance(const Vec3& p) const override {
        double d = std::numeric_limits<double>::infinity();
        for (const auto& v : parts_) d = std::min(d, v->signedDistance(p));
        return d;
    }

    Aabb bounds() const override { return bounds_; }

    // Mixture sampling: part i with probability m_i / Σm, a uniform point x of that part,
    // kept with probability 1/n(x) where n(x) counts the parts containing x. The accepted
    // density is Σ_{i∋x} (m_i/Σm)(1/m_i)(1/n(x)) = 1/Σm, uniform over the union.
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        if (parts_.empty()) return std::nullopt;
        if (parts_.size() == 1) return parts_[0]->sample(rng, maxTries);
        for (int tries = 0; tries < maxTries; ++tries) {
            auto x = parts_[pick(rng)]->sample(rng, maxTries);
            if (!x) continue;
            const int n = containing(*x);
            if (n <= 1 || rng.uniform() * n < 1.0) return x;
        }
        return std::nullopt;
    }

    // Same mixture: E[1/n(x)] = V / Σm, exact for disjoint parts.
    double measure() const override {
        std::call_once(measureOnce_, [this] {
            if (parts_.size() <= 1) {
                measure_ = parts_.empty() ? 0.0 : parts_[0]->measure();
                return;
            }
            Rng rng(kMeasureSeed);
            double sum = 0.0;
            int drawn = 0;
            for (int i = 0; i < kMeasureSamples; ++i) {
                auto x = parts_[pick(rng)]->sample(rng, 1000);
                if (!x) continue;
                sum += 1.0 / std::max(1, containing(*x));
                ++drawn;
            }
            measure_ = drawn > 0 ? cumulative_.back() * sum / drawn : 0.0;
        });
        return measure_;
    }

    std::string describe() const override { return joinDescriptions("union", parts_); }

  private:
    size_t pick(Rng& rng) const {
        const double total = cumulative_.back();
        if (!(total > 0.0)) return rng.below(parts_.size());  // all parts measure-less
        const double u = rng.uniform() * total;
        size_t i =
            std::upper_bound(cumulative_.begin(), cumulative_.end(), u) - cumulative_.begin();
        return std::min(i, parts_.size() - 1);
    }
    int containing(const Vec3& x) const {
        int n = 0;
        for (const auto& v : parts_) n += v->inside(x) ? 1 : 0;
        return n;
    }

    std::vector<VolumePtr> parts_;
    std::vector<double> cumulative_;  // running sum of part measures, for pick()
    Aabb bounds_;                     // parts are immutable, so computed once
    mutable std::once_flag measureOnce_;
    mutable double measure_ = 0.0;
};

class Intersection final : public Volume {
  public:
    explicit Intersection(std::vector<VolumePtr> parts) : parts_(std::move(parts)) {
        bounds_ = parts_[0]->bounds();
        for (size_t i = 1; i < parts_.size(); ++i)
            bounds_ = Aabb::intersect(bounds_, parts_[i]->bounds());
    }

    double signedDistance(const Vec3& p) const override {
        double d = -std::numeric_limits<double>::infinity();
        for (const auto& v : parts_) d = std::max(d, v->signedDistance(p));
        return d;
    }

    Aabb bounds() const override { return bounds_; }

    // Rejection from the first part: uniform there, so uniform on any subset of it.
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        if (bounds_.empty()) return std::nullopt;  // provably disjoint parts
        for (int tries = 0; tries < maxTries; ++tries) {
            auto x = parts_[0]->sample(rng, maxTries);
            if (x && insideOthers(*x)) return x;
        }
        return std::nullopt;
    }

    double measure() const override {
        std::call_once(measureOnce_, [this] {
            const double m0 = parts_[0]->measure();
            if (!(m0 > 0.0) || bounds_.empty()) return;
            Rng rng(kMeasureSeed);
            int drawn = 0, hits = 0;
            for (int i = 0; i < kMeasureSamples; ++i) {
                auto x = parts_[0]->sample(rng, 1000);
                if (!x) continue;
                ++drawn;
                hits += insideOthers(*x) ? 1 : 0;
            }
            if (drawn > 0) measure_ = m0 * hits / drawn;
        });
        return measure_;
    }

    std::string describe() const override { return joinDescriptions("intersection", parts_); }

  private:
    bool insideOthers(const Vec3& x) const {
        for (size_t i = 1; i < parts_.size(); ++i)
            if (!parts_[i]->inside(x)) return false;
        return true;
    }

    std::vector<VolumePtr> parts_;
    Aabb bounds_;
    mutable std::once_flag measureOnce_;
    mutable double measure_ = 0.0;
};

class Difference final : public Volume {
  public:
    Difference(VolumePtr base, std::vector<VolumePtr> cut)
        : base_(std::move(base)), cut_(std::move(cut)) {}

    double signedDistance(const Vec3& p) const override {
        double d = base_->signedDistance(p);
        for (const auto& v : cut_) d = std::max(d, -v->signedDistance(p));
        return d;
    }

    Aabb bounds() const override { return base_->bounds(); }

    // Rejection from the base's own uniform sampler.
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        for (int tries = 0; tries < maxTries; ++tries) {
            auto x = base_->sample(rng, maxTries);
            if (x && outsideCuts(*x)) return x;
        }
        return std::nullopt;
    }

    double measure() const override {
        std::call_once(measureOnce_, [this] {
            const double m0 = base_->measure();
            if (!(m0 > 0.0)) return;
            if (cut_.empty()) {
                measure_ = m0;
                return;
            }
            Rng rng(kMeasureSeed);
            int drawn = 0, hits = 0;
            for (int i = 0; i < kMeasureSamples; ++i) {
                auto x = base_->sample(rng, 1000);
                if (!x) continue;
                ++drawn;
                hits += outsideCuts(*x) ? 1 : 0;
            }
            if (drawn > 0) measure_ = m0 * hits / drawn;
        });
        return measure_;
    }

    std::string describe() const override { return joinDescriptions("difference", cut_, base_); }

  private:
    // Matches signedDistance(): a point on a cut's surface (distance 0) is still inside.
    bool outsideCuts(const Vec3& x) const {
        for (const auto& v : cut_)
            if (v->signedDistance(x) < 0.0) return false;
        return true;
    }

    VolumePtr base_;
    std::vector<VolumePtr> cut_;
    mutable std::once_flag measureOnce_;
    mutable double measure_ = 0.0;
};

}  // namespace

VolumePtr makeUnion(std::vector<VolumePtr> parts) {
    requireParts(parts, "makeUnion");
    return std::make_shared<Union>(std::move(parts));
}

VolumePtr makeIntersection(std::vector<VolumePtr> parts) {
    requireParts(parts, "makeIntersection");
    if (parts.empty()) throw std::invalid_argument("makeIntersection: needs at least one part");
    return std::make_shared<Intersection>(std::move(parts));
}

VolumePtr makeDifference(VolumePtr base, std::vector<VolumePtr> cut) {
    if (!base) throw std::invalid_argument("makeDifference: base is null");
    requireParts(cut, "makeDifference");
    return std::make_shared<Difference>(std::move(base), std::move(cut));
}

}  // namespace sylva
