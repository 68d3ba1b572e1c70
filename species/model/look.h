// How a species looks in colour: its bark (colour, pattern, roughness) and its leaves (a colour
// per leaf colour class, the underside, per-leaf variation, translucency, gloss). The species
// file's [look] table (species/spec/look_spec.h) fills it; the colour renderer
// (pipeline/render/colour_render.h) and the textured meshes (pipeline/formats/mesh_writers.h)
// read it. Colours are held linear (the renderer's space); the file gives them in sRGB.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace sylva {

// A linear-light RGB colour, each channel in [0, 1].
struct LinearRgb {
    float r = 0, g = 0, b = 0;
};

// sRGB ↔ linear transfer (IEC 61966-2-1) of one channel in [0, 1].
double srgbToLinear(double c);
double linearToSrgb(double c);
// "#rrggbb" (sRGB) → linear; false when `text` is not of that form.
bool parseHexColour(const std::string& text, LinearRgb& out);
// Linear → "#rrggbb" (sRGB, rounded).
std::string hexColour(const LinearRgb& c);

// The bark's pattern on a tube (texture space: u around the branch, 0 → 1 once round it; v
// along it in units of the circumference, tube_mesh.h, so texels are square on the bark and
// the pattern's features grow with the branch's girth, as bark's do).
enum class BarkPattern : uint8_t {
    kSmooth,    // faint mottling (beech, young bark, cherry)
    kFurrowed,  // long ridges and dark furrows running along the stem (oak, ash, lime, elm)
    kPlated,    // plates parted by dark cracks (pine, plane, mango, sal)
    kBanded,    // pale bark with dark horizontal lenticels and patches (birch, cherry)
    kRinged,    // rings round the stem (palms' leaf scars, bamboo's nodes)
};
// The words of `bark_pattern`, in enum order.
const std::vector<std::string>& barkPatternWords();

struct Look {
    LinearRgb bark;      // bark_colour: the bark's main colour
    LinearRgb barkDark;  // bark_dark_colour: furrows, cracks, lenticels, rings
    BarkPattern pattern = BarkPattern::kFurrowed;
    int barkRepeat = 8;             // bark_repeat: the pattern's periods once round a branch
    double barkContrast = 0.6;      // bark_contrast: how far the pattern reaches barkDark, [0, 1]
    double barkRoughness = 0.9;     // bark_roughness: PBR roughness, [0, 1]
    std::vector<LinearRgb> leaf;    // leaf_colours: per leaf colour class (class k: entry k,
                                    // classes past the end: the last entry)
    LinearRgb leafBack;             // leaf_back_colour: the underside of leaves of classes 0–3
    bool leafBackSet = false;       // … given; else each class's front, lighter and paler
    double leafVariation = 0.08;    // leaf_variation: per-leaf lightness spread (σ, relative)
    double leafTranslucency = 0.3;  // leaf_translucency: share of sunlight a leaf lets through
    double leafSpecular = 0.04;     // leaf_specular: specular reflectance at normal incidence
    double leafRoughness = 0.5;     // leaf_roughness: PBR roughness, [0, 1]

    Look();  // the defaults: grey-brown furrowed bark, the grammar palette's leaf colours

    // The front colour of a leaf of class `colourClass`, and its underside.
    LinearRgb leafFront(uint8_t colourClass) const;
    LinearRgb leafUnderside(uint8_t colourClass) const;
};

// The default leaf palette by class, the colour-class convention of the grammar method
// (docs/methods/grammar.md): 0–3 greens dark → light, 4 dark red, 5 red, 6 orange, 7 yellow,
// 8 fruit, 9 flower. sRGB hex.
const std::vector<std::string>& defaultLeafPalette();

// One leaf's lightness factor (≈ 1, spread `variation`): a hash of the leaf's index and the
// tree's seed, so every view and every output of a tree sees the same leaf alike.
double leafLightness(uint64_t treeSeed, uint32_t leafIndex, double variation);

// The bark texture tile: size × size sRGB pixels (RGB, row 0 at v = 0), periodic in both
// directions so it tiles around and along a tube without a seam. `size` a power of two ≥ 16.
// The renderer samples this tile, and the textured meshes carry it, so both show the same bark.
std::vector<uint8_t> barkTexture(const Look& look, int size);

// Bilinear lookup in a bark tile (wrapping), linear RGB.
struct BarkTile {
    int size = 0;
    std::vector<LinearRgb> texels;  // linear, size × size
    explicit BarkTile(const Look& look, int size = 256);
    LinearRgb sample(double u, double v) const;
    LinearRgb mean() const;
};

// barkTexture and BarkTile made once per bark (the fields the tile depends on: pattern,
// colours, repeat, contrast, size) and shared by every tree and thread of the process that asks
// for the same bark — a dataset's trees of one species share one. The same bytes as making them
// anew (a tile is a function of those fields alone); up to 64 barks are kept, then the memo
// starts over.
std::shared_ptr<const std::vector<uint8_t>> sharedBarkTexture(const Look& look, int size);
std::shared_ptr<const BarkTile> sharedBarkTile(const Look& look, int size = 256);

}  // namespace sylva
