#include "species/spec/look_spec.h"

namespace sylva {

namespace {

// An sRGB colour "#rrggbb" at `key`, `fallback` when absent.
LinearRgb colourKey(Params& p, std::string_view key, const LinearRgb& fallback) {
    if (!p.has(key)) {
        p.raw(key);  // recorded as read
        return fallback;
    }
    const std::string text = p.string(key);
    LinearRgb c;
    if (!parseHexColour(text, c)) {
        p.fail(key, "expected an sRGB colour \"#rrggbb\" (six hex digits), got \"" + text + "\"");
    }
    return c;
}

}  // namespace

Look readLook(Params& p) {
    p.plainNumbersOnly();
    Look o;
    o.bark = colourKey(p, "bark_colour", o.bark);
    o.barkDark = colourKey(p, "bark_dark_colour", o.barkDark);
    o.pattern = p.choice("bark_pattern", o.pattern,
                         {{"smooth", BarkPattern::kSmooth},
                          {"furrowed", BarkPattern::kFurrowed},
                          {"plated", BarkPattern::kPlated},
                          {"banded", BarkPattern::kBanded},
                          {"ringed", BarkPattern::kRinged}});
    o.barkRepeat = static_cast<int>(p.integer("bark_repeat", o.barkRepeat, Range::closed(1, 64)));
    o.barkContrast = p.number("bark_contrast", o.barkContrast, Range::closed(0, 1));
    o.barkRoughness = p.number("bark_roughness", o.barkRoughness, Range::closed(0, 1));
    if (p.has("leaf_colours")) {
        const std::vector<std::string> words = p.stringArray("leaf_colours");
        if (words.empty() || words.size() > 255) {
            p.fail("leaf_colours",
                   "expected 1–255 sRGB colours \"#rrggbb\", one per leaf colour "
                   "class from class 0");
        }
        o.leaf.clear();
        for (const std::string& w : words) {
            LinearRgb c;
            if (!parseHexColour(w, c)) {
                p.fail("leaf_colours",
                       "expected sRGB colours \"#rrggbb\" (six hex digits), got \"" + w + "\"");
            }
            o.leaf.push_back(c);
        }
    } else {
        p.raw("leaf_colours");
    }
    o.leafBackSet = p.has("leaf_back_colour");
    o.leafBack = colourKey(p, "leaf_back_colour", o.leafBack);
    o.leafVariation = p.number("leaf_variation", o.leafVariation, Range::closed(0, 0.5));
    o.leafTranslucency = p.number("leaf_translucency", o.leafTranslucency, Range::closed(0, 1));
    o.leafSpecular = p.number("leaf_specular", o.leafSpecular, Range::closed(0, 1));
    o.leafRoughness = p.number("leaf_roughness", o.leafRoughness, Range::closed(0, 1));
    p.finish();
    return o;
}

}  // namespace sylva
