#include "species/model/look.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>

#include "core/rng.h"

namespace sylva {

namespace {

double clamp01(double x) { return std::clamp(x, 0.0, 1.0); }

double smoothstep(double a, double b, double x) {
    const double t = clamp01((x - a) / (b - a));
    return t * t * (3 - 2 * t);
}

LinearRgb mix(const LinearRgb& a, const LinearRgb& b, double t) {
    return {static_cast<float>(a.r + (b.r - a.r) * t), static_cast<float>(a.g + (b.g - a.g) * t),
            static_cast<float>(a.b + (b.b - a.b) * t)};
}

LinearRgb scaled(const LinearRgb& a, double k) {
    return {static_cast<float>(clamp01(a.r * k)), static_cast<float>(clamp01(a.g * k)),
            static_cast<float>(clamp01(a.b * k))};
}

LinearRgb hex(const char* text) {
    LinearRgb c;
    parseHexColour(text, c);
    return c;
}

// A value in [0, 1) for an integer lattice point, keyed by the pattern's layer.
double lattice(int64_t x, int64_t y, uint64_t key) {
    const uint64_t h = hashCombine(hashCombine(key, static_cast<uint64_t>(x)),
                                   static_cast<uint64_t>(y) * 0x9e3779b97f4a7c15ull);
    return static_cast<double>(h >> 11) * 0x1.0p-53;
}

int64_t wrap(int64_t i, int64_t period) { return ((i % period) + period) % period; }

// Value noise periodic over (px, py) cells: x in [0, px) cells, y in [0, py).
double periodicNoise(double x, double y, int px, int py, uint64_t key) {
    const double fx = std::floor(x), fy = std::floor(y);
    const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
    const double tx = smoothstep(0, 1, x - fx), ty = smoothstep(0, 1, y - fy);
    auto at = [&](int64_t i, int64_t j) { return lattice(wrap(i, px), wrap(j, py), key); };
    const double a = at(ix, iy) + (at(ix + 1, iy) - at(ix, iy)) * tx;
    const double b = at(ix, iy + 1) + (at(ix + 1, iy + 1) - at(ix, iy + 1)) * tx;
    return a + (b - a) * ty;
}

// Fractal sum of periodic noise over the unit tile (u, v in [0, 1)), `cells` lattice cells
// across the tile at the first octave, 4 octaves, in [0, 1].
double fbm(double u, double v, int cellsU, int cellsV, uint64_t key) {
    double sum = 0, norm = 0, amp = 1;
    for (int o = 0; o < 4; ++o) {
        const int cu = cellsU << o, cv = cellsV << o;
        sum += amp * periodicNoise(u * cu, v * cv, cu, cv, hashCombine(key, o));
        norm += amp;
        amp *= 0.5;
    }
    return sum / norm;
}

// Distances to the nearest and second-nearest feature points of a periodic jittered grid
// (cellsU × cellsV cells over the tile, one point per cell), in tile units with v stretched
// by `stretch` (plates longer along the stem than across); and the nearest point's cell hash.
struct Cellular {
    double f1 = 1e9, f2 = 1e9;
    double id = 0;
};
Cellular cellular(double u, double v, int cellsU, int cellsV, double stretch, uint64_t key) {
    Cellular c;
    const double x = u * cellsU, y = v * cellsV;
    const int64_t ix = static_cast<int64_t>(std::floor(x)),
                  iy = static_cast<int64_t>(std::floor(y));
    for (int64_t j = iy - 1; j <= iy + 1; ++j) {
        for (int64_t i = ix - 1; i <= ix + 1; ++i) {
            const int64_t wi = wrap(i, cellsU), wj = wrap(j, cellsV);
            const double px = i + 0.1 + 0.8 * lattice(wi, wj, key);
            const double py = j + 0.1 + 0.8 * lattice(wi, wj, key + 1);
            const double dx = (px - x) / cellsU, dy = (py - y) / cellsV * stretch;
            const double d = std::sqrt(dx * dx + dy * dy);
            if (d < c.f1) {
                c.f2 = c.f1;
                c.f1 = d;
                c.id = lattice(wi, wj, key + 2);
            } else if (d < c.f2) {
                c.f2 = d;
            }
        }
    }
    return c;
}

// How dark the pattern is at (u, v) of the tile, 0 (bark colour) … 1 (dark colour), and a
// lightness factor of the bark colour there (plates and patches vary).
struct BarkShade {
    double dark = 0;
    double light = 1;
};

BarkShade barkShade(const Look& look, double u, double v) {
    const int n = std::max(1, look.barkRepeat);
    const uint64_t key = 0xba4c;
    BarkShade s;
    switch (look.pattern) {
        case BarkPattern::kSmooth: {
            const double m = fbm(u, v, 3, 3, key);
            s.dark = 0.45 * smoothstep(0.45, 0.8, m);
            s.light = 0.92 + 0.16 * fbm(u, v, 8, 8, key + 7);
            break;
        }
        case BarkPattern::kFurrowed: {
            // Ridges along the stem: the furrow's position across wanders with v.
            const double warp = 0.35 * (fbm(u, v, n, 2, key) - 0.5);
            const double x = u * n + warp * 2.0;
            const double across = std::abs(x - std::floor(x) - 0.5) * 2.0;  // 0 ridge … 1 furrow
            const double breaks = fbm(u, v, n, 4 * n, key + 3);  // ridges break into blocks
            s.dark = smoothstep(0.55, 0.9, across + 0.25 * (breaks - 0.5));
            s.light = 0.9 + 0.2 * fbm(u, v, 2 * n, 8 * n, key + 5);
            break;
        }
        case BarkPattern::kPlated: {
            const Cellular c = cellular(u, v, n, std::max(1, n * 2 / 3), 1.0, key);
            const double edge = (c.f2 - c.f1) * n;  // 0 on a crack
            s.dark = 1.0 - smoothstep(0.04, 0.18, edge);
            s.light = 0.82 + 0.36 * c.id;
            s.light *= 0.93 + 0.14 * fbm(u, v, 4 * n, 4 * n, key + 9);
            break;
        }
        case BarkPattern::kBanded: {
            // Lenticels: short dark dashes across the stem, scattered along it; dark patches.
            const int rows = 3 * n;
            const double y = v * rows;
            const int64_t row = static_cast<int64_t>(std::floor(y));
            const double inRow = y - std::floor(y);
            const double offset = lattice(wrap(row, rows), 0, key + 11);
            const double len = 0.25 + 0.45 * lattice(wrap(row, rows), 1, key + 11);
            double along = u + offset;
            along -= std::floor(along);
            const double dash =
                (along < len ? 1.0 : 0.0) * (1.0 - smoothstep(0.06, 0.16, std::abs(inRow - 0.5)));
            const double patch = smoothstep(0.62, 0.78, fbm(u, v, 2, 3, key + 13));
            s.dark = std::max(dash, patch);
            s.light = 0.95 + 0.08 * fbm(u, v, 6, 6, key + 15);
            break;
        }
        case BarkPattern::kRinged: {
            const double y = v * n;
            const double d = std::abs(y - std::floor(y) - 0.5) * 2.0;  // 1 on a ring
            s.dark = smoothstep(0.8, 0.95, d + 0.08 * (fbm(u, v, 4, n, key + 17) - 0.5));
            s.light = 0.9 + 0.2 * fbm(u, v, 3, 2 * n, key + 19);
            break;
        }
    }
    s.dark *= look.barkContrast;
    return s;
}

}  // namespace

double srgbToLinear(double c) {
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

double linearToSrgb(double c) {
    c = clamp01(c);
    return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}

bool parseHexColour(const std::string& text, LinearRgb& out) {
    if (text.size() != 7 || text[0] != '#') return false;
    int v[3];
    for (int k = 0; k < 3; ++k) {
        int x = 0;
        for (int d = 0; d < 2; ++d) {
            const char ch = text[1 + 2 * k + d];
            int h;
            if (ch >= '0' && ch <= '9')
                h = ch - '0';
            else if (ch >= 'a' && ch <= 'f')
                h = ch - 'a' + 10;
            else if (ch >= 'A' && ch <= 'F')
                h = ch - 'A' + 10;
            else
                return false;
            x = 16 * x + h;
        }
        v[k] = x;
    }
    out = {static_cast<float>(srgbToLinear(v[0] / 255.0)),
           static_cast<float>(srgbToLinear(v[1] / 255.0)),
           static_cast<float>(srgbToLinear(v[2] / 255.0))};
    return true;
}

std::string hexColour(const LinearRgb& c) {
    char buf[8];
    auto byte = [](double x) { return static_cast<int>(std::lround(linearToSrgb(x) * 255.0)); };
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", byte(c.r), byte(c.g), byte(c.b));
    return buf;
}

const std::vector<std::string>& barkPatternWords() {
    static const std::vector<std::string> words = {"smooth", "furrowed", "plated", "banded",
                                                   "ringed"};
    return words;
}

const std::vector<std::string>& defaultLeafPalette() {
    static const std::vector<std::string> palette = {
        "#2f4a1e", "#3e5f24", "#52752c", "#6c8c38",  // greens, dark → light
        "#5e1f18", "#a3301e", "#c96a1f", "#d8b43c",  // dark red, red, orange, yellow
        "#c29a2a", "#d9462a"};                       // fruit, flower
    return palette;
}

Look::Look() : bark(hex("#5d5045")), barkDark(hex("#2a231d")) {
    for (const std::string& c : defaultLeafPalette()) leaf.push_back(hex(c.c_str()));
}

LinearRgb Look::leafFront(uint8_t colourClass) const {
    if (leaf.empty()) return {};
    return leaf[std::min<size_t>(colourClass, leaf.size() - 1)];
}

LinearRgb Look::leafUnderside(uint8_t colourClass) const {
    const LinearRgb front = leafFront(colourClass);
    if (colourClass > 3) return front;  // autumn colours, fruit and flowers alike both sides
    if (leafBackSet) return leafBack;
    // Paler and lighter: the underside's looser mesophyll and hairs scatter more.
    const double grey = (front.r + front.g + front.b) / 3.0;
    return scaled(mix(front, {float(grey), float(grey), float(grey)}, 0.3), 1.45);
}

double leafLightness(uint64_t treeSeed, uint32_t leafIndex, double variation) {
    if (variation <= 0) return 1.0;
    Rng rng(hashCombine(hashCombine(treeSeed, 0x1eaf), leafIndex));
    return std::clamp(1.0 + variation * rng.normal(), 0.5, 1.5);
}

std::vector<uint8_t> barkTexture(const Look& look, int size) {
    std::vector<uint8_t> rgb(static_cast<size_t>(size) * size * 3);
    for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
            const double u = (x + 0.5) / size, v = (y + 0.5) / size;
            const BarkShade s = barkShade(look, u, v);
            const LinearRgb c = scaled(mix(look.bark, look.barkDark, s.dark), s.light);
            uint8_t* p = &rgb[(static_cast<size_t>(y) * size + x) * 3];
            p[0] = static_cast<uint8_t>(std::lround(linearToSrgb(c.r) * 255));
            p[1] = static_cast<uint8_t>(std::lround(linearToSrgb(c.g) * 255));
            p[2] = static_cast<uint8_t>(std::lround(linearToSrgb(c.b) * 255));
        }
    }
    return rgb;
}

BarkTile::BarkTile(const Look& look, int s) : size(s) {
    const std::shared_ptr<const std::vector<uint8_t>> shared = sharedBarkTexture(look, s);
    const std::vector<uint8_t>& rgb = *shared;
    texels.resize(static_cast<size_t>(s) * s);
    for (size_t i = 0; i < texels.size(); ++i) {
        texels[i] = {static_cast<float>(srgbToLinear(rgb[3 * i] / 255.0)),
                     static_cast<float>(srgbToLinear(rgb[3 * i + 1] / 255.0)),
                     static_cast<float>(srgbToLinear(rgb[3 * i + 2] / 255.0))};
    }
}

LinearRgb BarkTile::sample(double u, double v) const {
    // Texel centres at (i + 0.5) / size, wrapping (glTF's REPEAT with LINEAR filtering).
    const double x = u * size - 0.5, y = v * size - 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const double tx = x - fx, ty = y - fy;
    const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
    auto at = [&](int64_t i, int64_t j) {
        return texels[static_cast<size_t>(wrap(j, size)) * size + wrap(i, size)];
    };
    return mix(mix(at(ix, iy), at(ix + 1, iy), tx), mix(at(ix, iy + 1), at(ix + 1, iy + 1), tx),
               ty);
}

LinearRgb BarkTile::mean() const {
    double r = 0, g = 0, b = 0;
    for (const LinearRgb& t : texels) {
        r += t.r;
        g += t.g;
        b += t.b;
    }
    const double n = static_cast<double>(std::max<size_t>(1, texels.size()));
    return {static_cast<float>(r / n), static_cast<float>(g / n), static_cast<float>(b / n)};
}

namespace {

// The bytes a bark tile is a function of.
std::string barkKey(const Look& look, int size) {
    std::string key;
    auto put = [&](const void* p, size_t n) { key.append(static_cast<const char*>(p), n); };
    put(&look.bark, sizeof look.bark);
    put(&look.barkDark, sizeof look.barkDark);
    put(&look.pattern, sizeof look.pattern);
    put(&look.barkRepeat, sizeof look.barkRepeat);
    put(&look.barkContrast, sizeof look.barkContrast);
    put(&size, sizeof size);
    return key;
}

// A bounded memo, one per type: made outside the lock (two threads asking at once may both make
// it; either result is the same), kept under it.
template <class T, class Make>
std::shared_ptr<const T> memoised(const std::string& key, Make make) {
    static std::mutex mutex;
    static std::map<std::string, std::shared_ptr<const void>> kept;
    constexpr size_t kKeep = 64;
    {
        const std::lock_guard<std::mutex> lock(mutex);
        const auto it = kept.find(key);
        if (it != kept.end()) return std::static_pointer_cast<const T>(it->second);
    }
    std::shared_ptr<const T> made = make();
    const std::lock_guard<std::mutex> lock(mutex);
    if (kept.size() >= kKeep) kept.clear();
    kept.emplace(key, made);
    return made;
}

}  // namespace

std::shared_ptr<const std::vector<uint8_t>> sharedBarkTexture(const Look& look, int size) {
    return memoised<std::vector<uint8_t>>(barkKey(look, size), [&] {
        return std::make_shared<const std::vector<uint8_t>>(barkTexture(look, size));
    });
}

std::shared_ptr<const BarkTile> sharedBarkTile(const Look& look, int size) {
    return memoised<BarkTile>(barkKey(look, size),
                              [&] { return std::make_shared<const BarkTile>(look, size); });
}

}  // namespace sylva
