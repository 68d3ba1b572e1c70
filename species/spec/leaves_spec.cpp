#include "species/spec/leaves_spec.h"

#include <algorithm>
#include <tuple>

#include "species/model/leaf_shape.h"

namespace sylva {

void readLeafCards(Params& l, LeafCardOptions& o) {
    std::tie(o.sizeMin, o.sizeMax) = l.interval("size", {o.sizeMin, o.sizeMax}, Range::positive());
    o.aspect = l.number("aspect", o.aspect, Range::leftOpen(0, 10));
    o.shape = readLeafShape(l, o.shape);
    o.orientation = l.choice("orientation", o.orientation,
                             {{"random", LeafOrientation::kRandom},
                              {"sun", LeafOrientation::kSun},
                              {"planophile", LeafOrientation::kPlanophile},
                              {"erectophile", LeafOrientation::kErectophile},
                              {"plagiophile", LeafOrientation::kPlagiophile},
                              {"extremophile", LeafOrientation::kExtremophile},
                              {"uniform", LeafOrientation::kUniform},
                              {"spherical", LeafOrientation::kSpherical}});
    o.sun = l.vec3("sun_direction", o.sun);
    if (length(o.sun) < 1e-12) l.fail("sun_direction", "expected a non-zero direction");
    o.sunWeight = l.number("sun_weight", o.sunWeight, Range::closed(0, 1));
}

LeafShape readLeafShape(Params& l, LeafShape fallback) {
    return l.choice("shape", fallback, leafShapeWords());
}

LeafOptions readLeaves(Params& species) {
    LeafOptions o;
    auto l = species.optionalTable("leaves");
    if (!l) return o;
    o.enabled = true;
    o.perTip = static_cast<int>(l->integer("per_tip", o.perTip, Range::closed(0, 1000)));
    o.alongTwig = l->number("along_twig", o.alongTwig, Range::nonNegative());
    readLeafCards(*l, o);
    o.colourClasses =
        static_cast<int>(l->integer("colour_classes", o.colourClasses, Range::closed(1, 254)));
    o.colourJitter = l->number("colour_jitter", o.colourJitter, Range::closed(0, 1));
    l->finish();
    return o;
}

std::vector<uint8_t> readColourClasses(Params& p, std::string_view key) {
    std::vector<uint8_t> out;
    const toml::node* n = p.raw(key);
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a) p.fail(key, "expected an array of colour classes (integers 0–255)");
    for (const toml::node& e : *a) {
        auto i = e.as_integer();
        if (!i || i->get() < 0 || i->get() > 255) {
            p.fail(key, "expected an array of colour classes (integers 0–255)");
        }
        out.push_back(static_cast<uint8_t>(i->get()));
    }
    return out;
}

Season readSeason(Params& p, std::string_view key, Season fallback) {
    return p.choice(key, fallback,
                    {{"spring", Season::kSpring},
                     {"summer", Season::kSummer},
                     {"autumn", Season::kAutumn},
                     {"winter", Season::kWinter}});
}

void readSeasonPalettes(Params& sp, std::array<SeasonPalette, 4>& palettes, bool asGrownAllowed) {
    const toml::node* raw = sp.raw("seasons");
    if (!raw) return;
    const toml::table* table = raw->as_table();
    if (!table) sp.fail("seasons", "expected a table of seasons ([seasons.<season>])");
    std::vector<std::string> names;
    for (const auto& [k, v] : *table) names.emplace_back(k.str());
    Params seasons = sp.table("seasons");
    seasons.keysAreUserNames();  // season names
    for (const std::string& name : names) {
        const int index = seasonIndex(name);
        if (index < 0) {
            seasons.fail(name, "unknown season (expected spring, summer, autumn, winter)");
        }
        Params p = seasons.table(name);
        SeasonPalette& s = palettes[index];
        if (const toml::node* c = p.raw("classes"); c && c->is_string()) {
            if (!asGrownAllowed || p.string("classes") != "as-grown") {
                p.fail("classes", asGrownAllowed
                                      ? "expected an array of colour classes or \"as-grown\""
                                      : "expected an array of colour classes (integers 0–255)");
            }
            s.classes.clear();
            s.asGrown = true;
        } else if (c) {
            s.classes = readColourClasses(p, "classes");
            s.asGrown = false;
        }
        s.density = p.number("density", s.density, Range::closed(0, 1));
        p.finish();
    }
    seasons.finish();
}

}  // namespace sylva
