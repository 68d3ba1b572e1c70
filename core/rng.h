// Deterministic random numbers. Randomness is always passed in (an Rng&), never global:
// every stream is derived from an instance seed and a stable sub-key, so results do not
// depend on thread count or scheduling. The distributions are written out here rather
// than taken from <random>, whose distributions differ between standard libraries.
#pragma once

#include <cmath>
#include <cstdint>
#include <string_view>

#include "core/math.h"

namespace sylva {

// SplitMix64 finaliser: a good 64-bit mixing function.
inline constexpr uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

// Combines a seed with a sub-key into a new seed.
inline constexpr uint64_t hashCombine(uint64_t seed, uint64_t key) {
    return mix64(seed ^ mix64(key + 0x632be59bd9b4e019ull));
}

// FNV-1a over bytes, then mixed; stable across platforms.
inline constexpr uint64_t hashString(std::string_view s) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (char c : s) {
        h ^= static_cast<unsigned char>(c);
        h *= 0x100000001b3ull;
    }
    return mix64(h);
}

// xoshiro256** (Blackman & Vigna), seeded through SplitMix64.
class Rng {
  public:
    explicit Rng(uint64_t seed = 0) : seed_(seed) {
        uint64_t z = seed;
        for (auto& s : s_) {
            z += 0x9e3779b97f4a7c15ull;
            s = mix64(z);
        }
    }

    // An independent stream for a sub-task, identified by a stable key.
    Rng derive(uint64_t key) const { return Rng(hashCombine(seed_, key)); }
    Rng derive(std::string_view key) const { return Rng(hashCombine(seed_, hashString(key))); }
    uint64_t seed() const { return seed_; }

    uint64_t next() {
        uint64_t result = rotl(s_[1] * 5, 7) * 9;
        uint64_t t = s_[1] << 17;
        s_[2] ^= s_[0];
        s_[3] ^= s_[1];
        s_[1] ^= s_[2];
        s_[0] ^= s_[3];
        s_[2] ^= t;
        s_[3] = rotl(s_[3], 45);
        return result;
    }

    // Uniform in [0, 1).
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
    // Uniform in [a, b).
    double uniform(double a, double b) { return a + (b - a) * uniform(); }
    // Uniform integer in [0, n), n > 0 (Lemire's multiply-shift, unbiased enough for n << 2^64).
    uint64_t below(uint64_t n) {
        return static_cast<uint64_t>((static_cast<unsigned __int128>(next()) * n) >> 64);
    }
    // Standard normal by Box–Muller (one value per call, deterministic).
    double normal() {
        double u1 = uniform();
        double u2 = uniform();
        if (u1 < 1e-300) u1 = 1e-300;
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
    }
    double normal(double mu, double sigma) { return mu + sigma * normal(); }
    // Uniform direction on the unit sphere.
    Vec3 unitVector() {
        double z = uniform(-1.0, 1.0);
        double phi = uniform(0.0, 2.0 * kPi);
        double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        return {r * std::cos(phi), z, r * std::sin(phi)};
    }
    // Uniform point in the axis-aligned box.
    Vec3 inBox(const Aabb& b) {
        return {uniform(b.lo.x, b.hi.x), uniform(b.lo.y, b.hi.y), uniform(b.lo.z, b.hi.z)};
    }

  private:
    static constexpr uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
    uint64_t seed_;
    uint64_t s_[4];
};

}  // namespace sylva
