// type = "canopy-envelope" and the canopy method's [canopy] table (volume_spec_canopy_envelope.h).
#include "species/spec/volume_spec_canopy_envelope.h"

#include <map>
#include <stdexcept>

#include "species/spec/volume_spec.h"

namespace sylva {

namespace {

// Images named by several layers (packed channels) are read once per parse.
class ImageCache {
  public:
    const CanopyImage& get(Params& p, std::string_view key) {
        const std::string path = p.filePath(key);
        auto it = images_.find(path);
        if (it != images_.end()) return it->second;
        try {
            return images_.emplace(path, readCanopyImage(path)).first->second;
        } catch (const std::runtime_error& e) {
            p.fail(key, e.what());
        }
    }

  private:
    std::map<std::string, CanopyImage> images_;
};

CanopyGrid imageChannel(Params& p, std::string_view imageKey, std::string_view channelKey,
                        ImageCache& cache) {
    const CanopyImage& img = cache.get(p, imageKey);
    const int channel = static_cast<int>(p.integer(channelKey, 0, Range::closed(0, 3)));
    if (channel >= img.channels) {
        p.fail(channelKey, "the image has " + std::to_string(img.channels) + " channel" +
                               (img.channels == 1 ? "" : "s") + " (0–" +
                               std::to_string(img.channels - 1) + "), got " +
                               std::to_string(channel));
    }
    return img.channel(channel);
}

CanopyLayer parseLayer(Params& l, ImageCache& cache) {
    CanopyLayer layer;
    const std::string type = l.choice("type", "", {"blobs", "noise", "image"});
    if (type == "blobs") {
        layer.kind = CanopyLayer::Kind::kBlobs;
        if (l.has("centres")) {
            if (l.has("count")) {
                l.raw("count");
                l.fail("count", "give either count (random centres) or centres, not both");
            }
            layer.centres = l.pairArray("centres", 1);
            for (const Vec2& c : layer.centres) {
                if (!(c.x >= 0 && c.x <= 1 && c.y >= 0 && c.y <= 1)) {
                    l.fail("centres", "expected [u, v] pairs in [0, 1]");
                }
            }
            layer.count = static_cast<int>(layer.centres.size());
        } else {
            layer.count =
                static_cast<int>(l.integer("count", layer.count, Range::closed(1, 10000)));
        }
        layer.sigma = l.number("sigma", layer.sigma, Range::leftOpen(0, 0.5));
        layer.amplitude = l.number("amplitude", layer.amplitude, Range::any());
    } else if (type == "noise") {
        layer.kind = CanopyLayer::Kind::kNoise;
        layer.resolution =
            static_cast<int>(l.integer("resolution", layer.resolution, Range::closed(1, 4096)));
        layer.nearest = l.choice("interpolation", layer.nearest ? "nearest" : "bilinear",
                                 {"bilinear", "nearest"}) == "nearest";
        layer.amplitude = l.number("amplitude", layer.amplitude, Range::any());
    } else {
        layer.kind = CanopyLayer::Kind::kGrid;
        layer.grid = imageChannel(l, "image", "channel", cache);
        const double amplitude = l.number("amplitude", layer.amplitude, Range::any());
        if (amplitude != 1.0) {
            for (float& v : layer.grid.values) v = static_cast<float>(v * amplitude);
        }
    }
    l.finish();
    return layer;
}

}  // namespace

std::shared_ptr<const CanopyEnvelope> parseCanopyEnvelope(Params& p) {
    DocumentAs keys(p, "volume.canopy-envelope");  // also the canopy method's [canopy]
    CanopyEnvelopeOptions o;
    o.domain = p.choice("domain", o.domain,
                        {{"ellipsoid", CanopyDomain::kEllipsoid}, {"cone", CanopyDomain::kCone}});
    if (!p.has("radii")) {
        p.raw("radii");
        p.fail("radii", "required key missing (expected [kx, ky, kz], metres)");
    }
    o.radii = p.vec3("radii", o.radii, Range::positive());
    o.persistence = p.number("persistence", o.persistence, Range::closed(0, 1));
    o.jitter = p.degrees("jitter_deg", o.jitter, Range::closed(0, 30));

    ImageCache cache;
    if (p.has("base_image")) {
        o.hasBase = true;
        o.base = imageChannel(p, "base_image", "base_channel", cache);
    } else if (p.has("base_channel")) {
        p.raw("base_channel");
        p.fail("base_channel", "only meaningful with base_image");
    }
    std::vector<Params> ls = p.tableArray("layers");
    if (ls.size() > 10) p.fail("layers", "at most 10 layers (layer 10 already tiles 1024 times)");
    bool random = o.jitter > 0.0;
    for (Params& l : ls) {
        o.layers.push_back(parseLayer(l, cache));
        const CanopyLayer& layer = o.layers.back();
        if (layer.kind == CanopyLayer::Kind::kNoise ||
            (layer.kind == CanopyLayer::Kind::kBlobs && layer.centres.empty())) {
            random = true;
        }
    }

    // A fixed seed gives every tree the same envelope; otherwise each tree draws its own
    // (which marks the species as drawn per instance). Nothing random: no stream at all.
    Rng rng(0);
    if (p.has("seed")) {
        rng = Rng(static_cast<uint64_t>(p.integer("seed", Range::closed(0, 9.0e15))));
    } else if (random) {
        rng = p.randomStream("seed");
    }
    try {
        return makeCanopyEnvelope(o, rng);
    } catch (const std::invalid_argument& e) {
        p.failHere(e.what());  // the readers above check every value; this is a safety net
    }
}

VolumePtr parseCanopyEnvelopeVolume(Params& p) { return parseCanopyEnvelope(p); }

}  // namespace sylva
