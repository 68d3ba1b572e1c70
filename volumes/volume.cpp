// Defaults shared by every Volume: rejection sampling from bounds() and a deterministic
// Monte-Carlo volume estimate, for volumes that have no closed form.
#include "volumes/volume.h"

namespace sylva {

std::optional<Vec3> Volume::sample(Rng& rng, int maxTries) const {
    const Aabb b = bounds();
    if (b.empty()) return std::nullopt;
    for (int i = 0; i < maxTries; ++i) {
        Vec3 p = rng.inBox(b);
        if (inside(p)) return p;
    }
    return std::nullopt;
}

double Volume::measure() const {
    const Aabb b = bounds();
    if (b.empty()) return 0.0;
    // Jittered stratified sampling (40³ strata) converges much faster than plain Monte
    // Carlo; the fixed seed makes the estimate a pure function of the volume.
    constexpr int kStrata = 40;
    Rng rng(0x5e1f'0a11'ab1e'0001ull);
    const Vec3 cell = b.size() / kStrata;
    long hits = 0;
    for (int k = 0; k < kStrata; ++k)
        for (int j = 0; j < kStrata; ++j)
            for (int i = 0; i < kStrata; ++i) {
                Vec3 p{b.lo.x + (i + rng.uniform()) * cell.x, b.lo.y + (j + rng.uniform()) * cell.y,
                       b.lo.z + (k + rng.uniform()) * cell.z};
                if (inside(p)) ++hits;
            }
    return b.volume() * static_cast<double>(hits) / (double(kStrata) * kStrata * kStrata);
}

}  // namespace sylva
