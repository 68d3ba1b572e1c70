#include "pipeline/render/colour_render.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <stdexcept>

#include "pipeline/render/embree_scene.h"
#include "pipeline/render/sky_grid.h"
#include "species/model/leaf_shape.h"

namespace sylva {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Colour {
    double r = 0, g = 0, b = 0;
    Colour operator+(const Colour& o) const { return {r + o.r, g + o.g, b + o.b}; }
    Colour operator*(double k) const { return {r * k, g * k, b * k}; }
    Colour operator*(const Colour& o) const { return {r * o.r, g * o.g, b * o.b}; }
    Colour& operator+=(const Colour& o) {
        r += o.r, g += o.g, b += o.b;
        return *this;
    }
};
Colour of(const LinearRgb& c) { return {c.r, c.g, c.b}; }
Colour mix(const Colour& a, const Colour& b, double t) { return a * (1 - t) + b * t; }

// The light of one view: a sun (direction, irradiance) and a sky of zenith and horizon colours.
struct Light {
    Vec3 sun;
    Colour sunIrradiance;  // W/m² in the renderer's units: a white surface facing it shows 1/π·…
    Colour zenith, horizon;
    Colour groundAlbedo{0.10, 0.11, 0.06};
    double exposure = 1.0;

    Colour sky(const Vec3& d) const {
        if (d.y < 0) {  // the ground below the horizon, lit by sun and sky
            return groundAlbedo * (1.0 / kPi) *
                   (sunIrradiance * std::max(0.0, sun.y) + (zenith + horizon) * (0.5 * kPi));
        }
        return mix(horizon, zenith, std::sqrt(d.y));
    }
};

Light makeLight(const ColourOptions& o, Rng& rng, ColourLight& out) {
    Light l;
    const double elev = rng.uniform(o.sunElevationDeg[0], o.sunElevationDeg[1]) * kPi / 180.0;
    const double azim = rng.uniform(0.0, 2.0 * kPi);
    l.sun = {std::cos(elev) * std::sin(azim), std::sin(elev), std::cos(elev) * std::cos(azim)};
    const double haze = rng.uniform();
    const double ev = rng.uniform(o.exposureEv[0], o.exposureEv[1]);
    // Clear-sky daylight: the sun ≈ 3.5× the sky's irradiance on a level surface, warmer.
    l.sunIrradiance = Colour{1.0, 0.96, 0.90} * kPi * 0.95;
    const Colour deepZenith{0.16, 0.32, 0.75}, paleHorizon{0.62, 0.72, 0.88};
    l.zenith = mix(deepZenith, paleHorizon, 0.6 * haze) * 0.45;
    l.horizon = paleHorizon * 0.5;
    l.exposure = std::pow(2.0, ev);
    out.sunDirection = l.sun;
    out.sunElevationDeg = elev * 180.0 / kPi;
    out.sunAzimuthDeg = azim * 180.0 / kPi;
    out.exposureEv = ev;
    out.haze = haze;
    return l;
}

// A direction about `n` with density cos θ / π.
Vec3 cosineSample(const Vec3& n, double u1, double u2) {
    const Frame f = Frame::fromAxis(n);
    const double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
    const double x = r * std::cos(phi), z = r * std::sin(phi);
    const double y = std::sqrt(std::max(0.0, 1.0 - u1));
    return normalize(f.u * x + f.v * y + f.w * z);
}

// The sky grid (sky_grid.h): cells along the scene's longest side; the clumping index Ω and the
// near rays' reach (in cells), chosen together so that the estimate's mean matches rays cast to
// infinity (skyIrradiance): leaves on shoots and in clusters leave more gaps than the same area
// spread at random, and the near rays already count the occluders closest to a point.
constexpr int kSkyGridCells = 48;
constexpr double kClumping = 0.5;
constexpr double kNearReachCells = 0.5;

// A leaf whose corners all lie within this of its centre (metres) is lit as one: one sun and one
// near-sky estimate for the whole leaf. Larger leaves (a palm's fronds) are lit point by point.
constexpr double kSharedLeaf = 0.15;

// The linear luminance the auto-exposure brings a tree's log-average to: below middle grey
// (0.18), as foliage, darker than the grey card, photographs.
constexpr double kMeterKey = 0.08;

// Vertex v's triple of a mesh's per-vertex floats (positions, normals).
Vec3 xyz(const std::vector<float>& a, uint32_t v) {
    return {a[3 * size_t(v)], a[3 * size_t(v) + 1], a[3 * size_t(v) + 2]};
}

uint8_t toByte(double linear) {
    return static_cast<uint8_t>(std::lround(linearToSrgb(linear) * 255.0));
}

}  // namespace

// What an Embree geometry of the scene is: a tree's wood or leaves, the terrain, ground cover.
enum class ObjectKind : uint8_t { kWood, kLeaves, kTerrain, kCover };

struct ColourObject {
    ObjectKind kind = ObjectKind::kWood;
    const Mesh* mesh = nullptr;
    int look = 0;                      // index into the scene's looks (wood, leaves)
    uint64_t seed = 0;                 // the tree's: keys its near sky rays
    std::vector<uint32_t> leafFront;   // leaves: front-face triangles of `mesh`, 3 per triangle
    std::vector<uint32_t> leafOf;      // per front triangle, its leaf's index
    std::vector<uint32_t> leafFirst;   // per leaf, its first front triangle; one more at the end
    std::vector<Vec3> leafCentre;      // per leaf: the mean of its front triangles' corners
    std::vector<uint8_t> leafShared;   // per leaf: small enough to be lit as one (kSharedLeaf)
    std::vector<uint8_t> leafClass;    // per leaf
    std::vector<float> leafLightness;  // per leaf
};

// The near sky rays' open share (NearSky), computed the first time a view needs it and kept for
// the scene's other views: per leaf and side, and per wood vertex. Each value is a function of
// its leaf or vertex alone (its rays keyed by it), so it does not matter which pixel or thread
// computes it first: the images stay the same bytes on any thread count.
class OpenCache {
  public:
    explicit OpenCache(size_t n) : open_(new std::atomic<float>[n]) {
        for (size_t i = 0; i < n; ++i) open_[i].store(kUnknown, std::memory_order_relaxed);
    }
    template <class F>
    float get(size_t i, F&& compute) const {
        float v = open_[i].load(std::memory_order_relaxed);
        if (v == kUnknown) {
            v = static_cast<float>(compute());
            open_[i].store(v, std::memory_order_relaxed);
        }
        return v;
    }

  private:
    static constexpr float kUnknown = -1.0f;
    std::unique_ptr<std::atomic<float>[]> open_;
};

// Low vegetation and bare ground: a grass-green and an earth brown (sRGB #4f6b2c, #6b5a44).
const Look& groundLook() {
    static const Look look = [] {
        Look l;
        LinearRgb grass, earth;
        parseHexColour("#4f6b2c", grass);
        parseHexColour("#6b5a44", earth);
        l.leaf.assign(1, grass);
        l.bark = earth;
        l.leafTranslucency = 0.2;
        l.leafSpecular = 0.02;
        return l;
    }();
    return look;
}

struct ColourScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<ColourObject> objects;  // by Embree geometry id
    std::vector<Look> looks;
    std::vector<std::shared_ptr<const BarkTile>> barks;  // per look
    double radius = 1.0;  // the scene's bounding sphere: ray offsets scale with it
    double groundY = 0.0;
    bool hasGroundPlane = false;       // a tree alone: the sky background's ground plane
    std::unique_ptr<SkyGrid> skyGrid;  // the occluders' transmittance: sky light
    // Per object and near-ray count: the open shares (OpenCache) of its leaves' sides or its
    // wood's vertices, made on first use.
    mutable std::mutex openMutex;
    mutable std::map<std::pair<size_t, int>, std::unique_ptr<OpenCache>> openCaches_;

    int addLook(const Look& look) {
        looks.push_back(look);
        barks.push_back(sharedBarkTile(look));
        return static_cast<int>(looks.size() - 1);
    }

    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }

    void addGeometry(const float* positions, size_t nv, const uint32_t* indices, size_t nt) {
        attachTriangles(device, scene, positions, nv, indices, nt);
    }

    // A ray from `o` along `d`, from `tnear` to infinity.
    static void setRay(RTCRay& ray, const Vec3& o, const Vec3& d, double tnear) {
        ray.org_x = float(o.x), ray.org_y = float(o.y), ray.org_z = float(o.z);
        ray.dir_x = float(d.x), ray.dir_y = float(d.y), ray.dir_z = float(d.z);
        ray.tnear = float(tnear);
        ray.tfar = kInf;
        ray.time = 0;
        ray.mask = 0xffffffffu;
        ray.id = 0;
        ray.flags = 0;
    }

    bool occluded(const Vec3& o, const Vec3& d, double tnear, double tfar = kInf) const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRay ray;
        setRay(ray, o, d, tnear);
        ray.tfar = float(tfar);
        rtcOccluded1(scene, &ctx, &ray);
        return ray.tfar < 0;
    }

    bool intersect(const Vec3& o, const Vec3& d, RTCRayHit& rh) const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        setRay(rh.ray, o, d, 0);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &ctx, &rh);
        return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }

    // Sky light reaching `p` over the hemisphere about `n`: the sky's radiance towards the
    // grid's directions, each through the crown's transmittance from half a grid cell out along
    // `n` (cosine-weighted over the hemisphere), times the share of `nearRays` cosine-distributed
    // rays half a cell long that escape (the occluders nearer than the grid resolves: a leaf's
    // neighbours, the fork it sits in). `skyRadiance[k]`: the view's sky towards
    // directions()[k]. Against 256 rays cast to infinity from points on a hawthorn's and an oak's
    // leaves and wood, this with 4 near rays has a mean 2–7 % below and a correlation of
    // 0.86–0.90; 4 rays to infinity (the renderer before the grid), 0.72–0.80; the grid alone
    // 0.63–0.66 (ColourViews.TheSkyGridAgreesWithTracedSkyLight).
    Colour skyIrradiance(const Vec3& p, const Vec3& n, const Colour* skyRadiance, int nearRays,
                         Rng& rng) const {
        const double open = nearRays > 0 ? openShare(p, n, nearRays, nearReach(), rng) : 1.0;
        return gridSky(p, n, skyRadiance) * open;
    }

    // The near rays' length: half a sky-grid cell.
    double nearReach() const { return kNearReachCells * skyGrid->cellSize(); }

    // skyIrradiance before the near rays: the sky through the grid's transmittance from
    // nearReach() out along `n`.
    Colour gridSky(const Vec3& p, const Vec3& n, const Colour* skyRadiance) const {
        float t[SkyGrid::kDirections];
        skyGrid->transmittance(p + n * nearReach(), t);
        Colour sum;
        double weights = 0.0;
        for (int k = 0; k < SkyGrid::kDirections; ++k) {
            const double w = dot(n, skyGrid->directions()[k]);
            if (w <= 0) continue;
            sum += skyRadiance[k] * (w * t[k]);
            weights += w;
        }
        if (weights <= 0) return {};
        return sum * (kPi / weights);
    }

    // A leaf's front's normal (its first front corner's).
    static Vec3 leafNormal(const ColourObject& obj, uint32_t leaf) {
        return xyz(obj.mesh->normals, obj.leafFront[3 * size_t(obj.leafFirst[leaf])]);
    }

    // What the pixels of one view share beyond their own: per object, the near sky's cache
    // (openCaches) and, for leaves, whether the sun reaches each leaf — one shadow ray per leaf
    // and view, cast from the leaf's centre on the sun's side (a leaf is a few centimetres
    // across; within it, a shadow's edge is finer than the pixels that show it). Each leaf's
    // answer is a function of the leaf and the sun alone, so whichever pixel asks first, on
    // whichever thread, the images are the same bytes.
    struct ViewShare {
        std::vector<const OpenCache*> open;
        std::vector<std::unique_ptr<std::atomic<uint8_t>[]>> leafSun;  // 0 unknown, 1 no, 2 yes
    };

    ViewShare viewShare(int rays) const {
        ViewShare v;
        v.open = openCaches(rays);
        v.leafSun.resize(objects.size());
        for (size_t g = 0; g < objects.size(); ++g) {
            if (objects[g].kind != ObjectKind::kLeaves) continue;
            const size_t n = objects[g].leafClass.size();
            v.leafSun[g].reset(new std::atomic<uint8_t>[n]);
            for (size_t k = 0; k < n; ++k) v.leafSun[g][k].store(0, std::memory_order_relaxed);
        }
        return v;
    }

    bool leafSunLit(const ViewShare& vs, unsigned geom, uint32_t leaf, const Vec3& sun) const {
        std::atomic<uint8_t>& slot = vs.leafSun[geom][leaf];
        uint8_t state = slot.load(std::memory_order_relaxed);
        if (state == 0) {
            const ColourObject& obj = objects[geom];
            const Vec3 front = leafNormal(obj, leaf);
            const Vec3 sunSide = dot(front, sun) >= 0 ? front : -front;
            state = occluded(obj.leafCentre[leaf] + sunSide * (1e-4 * radius), sun, 0) ? 1 : 2;
            slot.store(state, std::memory_order_relaxed);
        }
        return state == 2;
    }

    // Per object, the open shares of `rays` near rays (OpenCache): one per leaf side, or one
    // per wood vertex where the wood has normals; none for the ground.
    std::vector<const OpenCache*> openCaches(int rays) const {
        std::vector<const OpenCache*> out(objects.size(), nullptr);
        if (rays <= 0) return out;
        const std::lock_guard<std::mutex> lock(openMutex);
        for (size_t g = 0; g < objects.size(); ++g) {
            const ColourObject& obj = objects[g];
            size_t n = 0;
            if (obj.kind == ObjectKind::kLeaves) {
                n = 2 * obj.leafClass.size();
            } else if (obj.kind == ObjectKind::kWood &&
                       obj.mesh->normals.size() == 3 * obj.mesh->vertexCount()) {
                n = obj.mesh->vertexCount();
            }
            if (n == 0) continue;
            std::unique_ptr<OpenCache>& cache = openCaches_[{g, rays}];
            if (!cache) cache = std::make_unique<OpenCache>(n);
            out[g] = cache.get();
        }
        return out;
    }

    // The share of the near sky rays that escape, for a hit on `obj` seen from the side `n`
    // faces: a small leaf's (its centre, one value per side) and the wood's (its triangle's
    // vertices', interpolated) from the cache, each cast once for all the scene's views — such a
    // leaf is a few centimetres across, and the open share varies little over it or between a
    // tube's vertices; a large leaf's and the ground's from the point itself with the pixel's
    // stream.
    double nearOpen(const OpenCache* cache, const ColourObject& obj, const RTCRayHit& rh,
                    uint32_t leaf, bool seenFront, const Vec3& above, const Vec3& n, int rays,
                    Rng& rng) const {
        const double reach = nearReach(), eps = 1e-4 * radius;
        const Mesh& mesh = *obj.mesh;
        if (!cache || (obj.kind == ObjectKind::kLeaves && !obj.leafShared[leaf])) {
            return openShare(above, n, rays, reach, rng);
        }
        if (obj.kind == ObjectKind::kLeaves) {
            const int side = seenFront ? 0 : 1;
            return cache->get(2 * size_t(leaf) + side, [&] {
                const Vec3& centre = obj.leafCentre[leaf];
                const Vec3 front = leafNormal(obj, leaf);
                const Vec3 sideNormal = seenFront ? front : -front;
                Rng leafRng =
                    Rng(obj.seed).derive("near-sky-leaf").derive(2 * uint64_t(leaf) + side);
                return openShare(centre + sideNormal * eps, sideNormal, rays, reach, leafRng);
            });
        }
        const uint32_t* tri = &mesh.indices[3 * size_t(rh.hit.primID)];
        const double w[3] = {1.0 - rh.hit.u - rh.hit.v, rh.hit.u, rh.hit.v};
        double open = 0.0;
        for (int c = 0; c < 3; ++c) {
            const uint32_t v = tri[c];
            open += w[c] * cache->get(v, [&] {
                const Vec3 nv = normalize(xyz(mesh.normals, v));
                Rng vertexRng = Rng(obj.seed).derive("near-sky-wood").derive(uint64_t(v));
                return openShare(xyz(mesh.positions, v) + nv * eps, nv, rays, reach, vertexRng);
            });
        }
        return open;
    }

    // The share of `rays` cosine-distributed rays about `n` from `p` that meet nothing within
    // `reach` metres.
    double openShare(const Vec3& p, const Vec3& n, int rays, double reach, Rng& rng) const {
        int escaped = 0;
        for (int k = 0; k < rays; ++k) {
            const double u1 = rng.uniform(), u2 = rng.uniform();
            escaped += occluded(p, cosineSample(n, u1, u2), 0, reach) ? 0 : 1;
        }
        return double(escaped) / std::max(1, rays);
    }

    // What a pixel's samples share: its sky irradiance, estimated at its first shaded sample,
    // and the sun's visibility, cast from the first sample that meets a surface and reused by the
    // later samples on the same surface — the same leaf, or the same wood or ground object at a
    // depth within 2 % (within a pixel, one surface is in or out of the sun but at a shadow's
    // edge). Small leaves share theirs over the whole view (ViewShare).
    struct PixelShare {
        Colour sky;
        bool haveSky = false;
        bool haveSun = false;
        unsigned sunGeom = RTC_INVALID_GEOMETRY_ID;
        uint32_t sunLeaf = 0;
        double sunDepth = 0;
        bool sunLit = false;
    };

    // Whether the sun reaches `from` (a point on the sun's side of a surface), shared with the
    // pixel's earlier samples on the same surface.
    bool sunLit(const Vec3& from, const Vec3& sun, unsigned geom, uint32_t leaf, bool isLeaf,
                double depth, PixelShare& share) const {
        if (share.haveSun && share.sunGeom == geom &&
            (isLeaf ? share.sunLeaf == leaf
                    : std::abs(depth - share.sunDepth) <= 0.02 * share.sunDepth)) {
            return share.sunLit;
        }
        share.haveSun = true;
        share.sunGeom = geom;
        share.sunLeaf = leaf;
        share.sunDepth = depth;
        share.sunLit = !occluded(from, sun, 0);
        return share.sunLit;
    }

    // The radiance leaving a tree hit towards the camera (`share`: see PixelShare).
    Colour shade(const RTCRayHit& rh, const Vec3& dir, const Light& light,
                 const Colour* skyRadiance, const ViewShare& vs, const ColourOptions& o, Rng& rng,
                 PixelShare& share) const {
        const Vec3 view = -dir;
        const double eps = 1e-4 * radius;
        const Vec3 p = Vec3{rh.ray.org_x, rh.ray.org_y, rh.ray.org_z} + dir * double(rh.ray.tfar);
        const double bu = rh.hit.u, bv = rh.hit.v, bw = 1.0 - bu - bv;
        const ColourObject& obj = objects[rh.hit.geomID];
        const Look& look = looks[obj.look];
        const Mesh& mesh = *obj.mesh;
        Colour albedo;
        Vec3 n;
        uint32_t leafIndex = 0;
        bool seenFront = true;
        double translucency = 0.0, specular = 0.04, roughness = 0.9;
        const Vec3 ng = normalize(Vec3{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z});
        const Vec3 facing = dot(ng, view) > 0 ? ng : -ng;
        if (obj.kind == ObjectKind::kLeaves) {
            const uint32_t leaf = leafIndex = obj.leafOf[rh.hit.primID];
            const uint32_t v0 = obj.leafFront[3 * size_t(rh.hit.primID)];
            const Vec3 front = xyz(mesh.normals, v0);
            seenFront = dot(front, view) >= 0;
            const uint8_t cls = obj.leafClass[leaf];
            albedo = of(seenFront ? look.leafFront(cls) : look.leafUnderside(cls)) *
                     double(obj.leafLightness[leaf]);
            n = seenFront ? front : -front;
            translucency = look.leafTranslucency;
            specular = look.leafSpecular;
            roughness = look.leafRoughness;
        } else {
            const uint32_t* tri = &mesh.indices[3 * size_t(rh.hit.primID)];
            auto attr = [&](const std::vector<float>& a, int k, int c) {
                return bw * a[k * tri[0] + c] + bu * a[k * tri[1] + c] + bv * a[k * tri[2] + c];
            };
            n = facing;
            if (mesh.normals.size() == 3 * mesh.vertexCount()) {
                n = normalize(Vec3{attr(mesh.normals, 3, 0), attr(mesh.normals, 3, 1),
                                   attr(mesh.normals, 3, 2)});
                if (dot(n, view) <= 0) n = facing;
            }
            if (obj.kind == ObjectKind::kWood) {
                albedo = of(barks[obj.look]->sample(attr(mesh.uvs, 2, 0), attr(mesh.uvs, 2, 1)));
                roughness = look.barkRoughness;
            } else if (obj.kind == ObjectKind::kTerrain) {
                // Bare earth under a patchy sward: a value-noise mix on a 1.5 m scale.
                const double mixGrass = 0.55 + 0.35 *
                                                   std::sin(0.9 * p.x + 2.1 * std::sin(0.7 * p.z)) *
                                                   std::cos(0.8 * p.z + 1.3 * std::sin(0.6 * p.x));
                albedo = mix(of(look.bark), of(look.leafFront(0)), std::clamp(mixGrass, 0.0, 1.0));
                roughness = 1.0;
                specular = 0.0;
            } else {  // ground cover: grass-green both sides
                albedo = of(look.leafFront(0));
                translucency = look.leafTranslucency;
                specular = look.leafSpecular;
            }
        }
        if (o.unlit) return albedo;  // the surface's own colour: an albedo picture
        Colour out;
        const Vec3 above = p + n * eps;
        const double cosL = dot(n, light.sun);
        const bool isLeaf = obj.kind == ObjectKind::kLeaves;
        const double depth = rh.ray.tfar;
        const bool sharedLeaf = isLeaf && obj.leafShared[leafIndex];
        auto lit = [&](const Vec3& from) {
            return sharedLeaf
                       ? leafSunLit(vs, rh.hit.geomID, leafIndex, light.sun)
                       : sunLit(from, light.sun, rh.hit.geomID, leafIndex, isLeaf, depth, share);
        };
        if (cosL > 0) {
            if (lit(above)) {
                out += albedo * light.sunIrradiance * (cosL / kPi);
                // Blinn–Phong lobe, normalised, its exponent from the roughness.
                const double a = std::max(0.05, roughness);
                const double shininess = std::clamp(2.0 / (a * a * a * a) - 2.0, 1.0, 4000.0);
                const Vec3 h = normalize(light.sun + view);
                const double nh = std::max(0.0, dot(n, h));
                out += light.sunIrradiance *
                       (specular * (shininess + 2) / (2 * kPi) * std::pow(nh, shininess) * cosL);
            }
        } else if (translucency > 0) {  // sunlight through the leaf from behind
            if (lit(p - n * eps)) {
                out += albedo * light.sunIrradiance * (-cosL * translucency / kPi);
            }
        }
        if (!share.haveSky && o.aoRays > 0) {
            share.sky = gridSky(above, n, skyRadiance) * nearOpen(vs.open[rh.hit.geomID], obj, rh,
                                                                  leafIndex, seenFront, above, n,
                                                                  o.aoRays, rng);
            share.haveSky = true;
        }
        out += albedo * share.sky * (1.0 / kPi);
        return out;
    }

    // The sky grid over the scene's bounds: the leaves (front faces; G = ½), the wood and the
    // ground cover (closed surfaces and grass; G = ¼ and ½); the terrain is the sky model's
    // ground below the horizon.
    void buildSkyGrid(const RTCBounds& b) {
        Vec3 lo{b.lower_x, b.lower_y, b.lower_z}, hi{b.upper_x, b.upper_y, b.upper_z};
        if (!(std::isfinite(lo.x) && std::isfinite(hi.x)) || lo.x > hi.x) lo = hi = Vec3{};
        skyGrid = std::make_unique<SkyGrid>(lo, hi, kSkyGridCells, kClumping);
        for (const ColourObject& obj : objects) {
            if (obj.kind == ObjectKind::kTerrain) continue;
            const Mesh& mesh = *obj.mesh;
            const std::vector<uint32_t>& idx =
                obj.kind == ObjectKind::kLeaves ? obj.leafFront : mesh.indices;
            const double g = obj.kind == ObjectKind::kWood ? 0.25 : 0.5;
            for (size_t t = 0; t + 2 < idx.size(); t += 3) {
                const Vec3 a = xyz(mesh.positions, idx[t]), bb = xyz(mesh.positions, idx[t + 1]),
                           c = xyz(mesh.positions, idx[t + 2]);
                const double area = 0.5 * length(cross(bb - a, c - a));
                skyGrid->addArea((a + bb + c) / 3.0, g * area);
            }
        }
        skyGrid->finish();
    }

    // What a ray that meets no tree shows: the background.
    Colour background(const Vec3& o, const Vec3& d, const Light& light,
                      const ColourOptions& opt) const {
        if (opt.background == ColourBackground::kColour) return of(opt.backgroundColour);
        if (hasGroundPlane && d.y < 0 &&
            o.y > groundY) {  // the ground plane under the tree, its shadow on it
            const double t = (groundY - o.y) / d.y;
            const Vec3 g = o + d * t;
            const double lit = occluded(g + Vec3{0, 1e-4 * radius, 0}, light.sun, 0) ? 0.0 : 1.0;
            const Colour e = light.sunIrradiance * (lit * std::max(0.0, light.sun.y)) +
                             (light.zenith + light.horizon) * (0.5 * kPi);
            return light.groundAlbedo * e * (1.0 / kPi);
        }
        return light.sky(d);
    }
};

ColourScene::ColourScene() : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.device = newEmbreeDevice();
    m.scene = newRobustScene(m.device);
}

ColourScene::ColourScene(const Tree& tree, const Mesh& wood, const Mesh& leaves, const Look& look,
                         uint64_t treeSeed)
    : ColourScene() {
    addTree(tree, wood, leaves, look, treeSeed);
    impl_->groundY = tree.nodes.empty() ? 0.0 : tree.nodes[0].position.y;
    impl_->hasGroundPlane = true;
    commit();
}

void ColourScene::addTree(const Tree& tree, const Mesh& wood, const Mesh& leaves, const Look& look,
                          uint64_t treeSeed, bool leavesAsCards) {
    Impl& m = *impl_;
    const int lookIndex = m.addLook(look);
    ColourObject w;
    w.kind = ObjectKind::kWood;
    w.mesh = &wood;
    w.look = lookIndex;
    w.seed = treeSeed;
    m.objects.push_back(std::move(w));
    m.addGeometry(wood.positions.data(), wood.vertexCount(), wood.indices.data(),
                  wood.triangleCount());
    // Front faces of the leaves (leafMesh's layout: per leaf, 2n vertices and 2t triangles,
    // the first t the front face).
    ColourObject l;
    l.kind = ObjectKind::kLeaves;
    l.mesh = &leaves;
    l.look = lookIndex;
    size_t tri = 0;
    l.leafClass.reserve(tree.leaves.size());
    l.leafLightness.reserve(tree.leaves.size());
    for (size_t i = 0; i < tree.leaves.size(); ++i) {
        const Leaf& leaf = tree.leaves[i];
        const size_t t = leafOutline(leavesAsCards ? LeafShape::kCard : leaf.shape).triangleCount();
        if (3 * (tri + 2 * t) > leaves.indices.size()) {
            throw std::invalid_argument("ColourScene: the leaf mesh is not leafMesh(tree)'s");
        }
        l.leafFront.insert(l.leafFront.end(), leaves.indices.begin() + 3 * tri,
                           leaves.indices.begin() + 3 * (tri + t));
        l.leafFirst.push_back(static_cast<uint32_t>(l.leafOf.size()));
        l.leafOf.insert(l.leafOf.end(), t, static_cast<uint32_t>(i));
        l.leafClass.push_back(leaf.colour);
        l.leafLightness.push_back(static_cast<float>(
            leafLightness(treeSeed, static_cast<uint32_t>(i), look.leafVariation)));
        tri += 2 * t;
    }
    l.leafFirst.push_back(static_cast<uint32_t>(l.leafOf.size()));
    l.seed = treeSeed;
    // Each leaf's centre, and whether all its corners lie within kSharedLeaf of it.
    l.leafCentre.resize(tree.leaves.size());
    l.leafShared.resize(tree.leaves.size());
    for (size_t i = 0; i < tree.leaves.size(); ++i) {
        const uint32_t* first = l.leafFront.data() + 3 * size_t(l.leafFirst[i]);
        const uint32_t* end = l.leafFront.data() + 3 * size_t(l.leafFirst[i + 1]);
        Vec3 centre{0, 0, 0};
        for (const uint32_t* v = first; v != end; ++v) centre += xyz(leaves.positions, *v);
        centre = centre / double(std::max<ptrdiff_t>(1, end - first));
        double reach = 0.0;
        for (const uint32_t* v = first; v != end; ++v) {
            reach = std::max(reach, distance(centre, xyz(leaves.positions, *v)));
        }
        l.leafCentre[i] = centre;
        l.leafShared[i] = reach <= kSharedLeaf ? 1 : 0;
    }
    m.objects.push_back(std::move(l));
    const ColourObject& added = m.objects.back();
    m.addGeometry(leaves.positions.data(), leaves.vertexCount(), added.leafFront.data(),
                  added.leafFront.size() / 3);
}

void ColourScene::addGround(const Mesh& terrain, const Mesh& groundCover) {
    Impl& m = *impl_;
    const int lookIndex = m.addLook(groundLook());
    for (const Mesh* mesh : {&terrain, &groundCover}) {
        ColourObject o;
        o.kind = mesh == &terrain ? ObjectKind::kTerrain : ObjectKind::kCover;
        o.mesh = mesh;
        o.look = lookIndex;
        m.objects.push_back(std::move(o));
        m.addGeometry(mesh->positions.data(), mesh->vertexCount(), mesh->indices.data(),
                      mesh->triangleCount());
    }
}

void ColourScene::commit() {
    Impl& m = *impl_;
    rtcCommitScene(m.scene);
    RTCBounds b;
    rtcGetSceneBounds(m.scene, &b);
    const double dx = b.upper_x - b.lower_x, dy = b.upper_y - b.lower_y, dz = b.upper_z - b.lower_z;
    const double r = 0.5 * std::sqrt(dx * dx + dy * dy + dz * dz);
    m.radius = std::isfinite(r) && r > 0 ? r : 1.0;
    m.buildSkyGrid(b);
}

ColourScene::~ColourScene() = default;

double ColourScene::skyView(const Vec3& p, const Vec3& n, int nearRays, Rng& rng) const {
    Colour uniform[SkyGrid::kDirections];
    for (Colour& c : uniform) c = {1, 1, 1};
    return impl_->skyIrradiance(p, normalize(n), uniform, nearRays, rng).r / kPi;
}

double ColourScene::skyViewTraced(const Vec3& p, const Vec3& n, int rays, Rng& rng) const {
    return impl_->openShare(p, normalize(n), rays, kInf, rng);
}

ColourImage ColourScene::render(const Camera& camera, const ViewImage& view,
                                const ColourOptions& options, Rng rng,
                                const std::vector<uint8_t>* coverage) const {
    const Impl& m = *impl_;
    const int w = camera.width, h = camera.height;
    const std::vector<uint8_t>& centres = coverage ? *coverage : view.silhouette;
    if (view.width != w || view.height != h || centres.size() != size_t(w) * h) {
        throw std::invalid_argument("ColourScene::render: the view is not the camera's");
    }
    ColourImage img;
    img.width = w;
    img.height = h;
    img.rgba.assign(size_t(w) * h * 4, 0);
    Rng lightRng = rng.derive("light");
    const Light light = makeLight(options, lightRng, img.light);
    Colour skyRadiance[SkyGrid::kDirections];
    for (int k = 0; k < SkyGrid::kDirections; ++k) {
        skyRadiance[k] = light.sky(m.skyGrid->directions()[k]);
    }
    const int samples = std::max(1, options.samples);
    const Impl::ViewShare viewShare = m.viewShare(options.aoRays);
    const bool opaque = options.background != ColourBackground::kTransparent;
    const Vec3 eye{camera.cameraToWorld[0][3], camera.cameraToWorld[1][3],
                   camera.cameraToWorld[2][3]};
    const Vec3 forward{-camera.cameraToWorld[0][2], -camera.cameraToWorld[1][2],
                       -camera.cameraToWorld[2][2]};
    const double focal = camera.fx();
    auto ray = [&](double px, double py, Vec3& o, Vec3& d) {
        if (camera.orthographic) {
            o = camera.unproject(px, py, 0.0, focal);
            d = forward;
        } else {
            o = eye;
            d = normalize(camera.unproject(px, py, 1.0, focal) - eye);
        }
    };
    auto inMask = [&](int x, int y) {
        return x >= 0 && y >= 0 && x < w && y < h && centres[size_t(y) * w + x] != 0;
    };
    std::atomic<int64_t> misses{0};
    // Per pixel, before exposure: the sum of the covered samples' radiance, the background's
    // (already final for a flat colour), and the counts.
    const size_t npx = size_t(w) * h;
    std::vector<float> treeSum(3 * npx, 0.0f), backSum(3 * npx, 0.0f);
    std::vector<uint16_t> coveredOf(npx, 0), samplesOf(npx, 0);
    const bool flatBack = options.background == ColourBackground::kColour;
    Rng pixelRoot = rng.derive("pixels");
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y < rows.end(); ++y) {
            for (int x = 0; x < w; ++x) {
                const size_t i = size_t(y) * w + x;
                const bool centreCovered = inMask(x, y);
                bool near = false;
                for (int dy = -1; dy <= 1 && !near; ++dy) {
                    for (int dx = -1; dx <= 1 && !near; ++dx) near = inMask(x + dx, y + dy);
                }
                if (!near && !opaque) continue;  // transparent, nothing near
                Rng prng = pixelRoot.derive(static_cast<uint64_t>(i));
                const int n = near ? samples : 1;
                const double jx = prng.uniform(), jy = prng.uniform();
                Colour tree, back;
                Impl::PixelShare share;
                int covered = 0;
                bool missedCentre = false;
                for (int s = 0; s < n; ++s) {
                    double sx = 0.5, sy = 0.5;
                    if (s > 0) {  // R2 low-discrepancy points, rotated per pixel
                        sx = std::fmod(jx + 0.7548776662466927 * s, 1.0);
                        sy = std::fmod(jy + 0.5698402909980532 * s, 1.0);
                    }
                    Vec3 o, d;
                    ray(x + sx, y + sy, o, d);
                    RTCRayHit rh;
                    bool hit = m.intersect(o, d, rh);
                    if (s == 0) {
                        if (centreCovered && !hit) {  // retry a hair off the centre
                            for (const auto& [ox, oy] :
                                 {std::pair{1e-3, 0.0}, {-1e-3, 0.0}, {0.0, 1e-3}, {0.0, -1e-3}}) {
                                ray(x + 0.5 + ox, y + 0.5 + oy, o, d);
                                if ((hit = m.intersect(o, d, rh))) break;
                            }
                            if (!hit) missedCentre = true;
                        }
                        if (!centreCovered) hit = false;  // the mask decides the centre
                    }
                    if (missedCentre && s == 0) {
                        ++covered;  // coloured below from the other samples
                        continue;
                    }
                    if (hit) {
                        tree += m.shade(rh, d, light, skyRadiance, viewShare, options, prng, share);
                        ++covered;
                    } else if (opaque) {
                        back += m.background(o, d, light, options);
                    }
                }
                if (missedCentre) {
                    misses.fetch_add(1, std::memory_order_relaxed);
                    const int others = covered - 1;
                    // No other sample found it either: the bark's mean colour in half light.
                    tree += others > 0 ? tree * (1.0 / others) : of(m.barks[0]->mean()) * 0.5;
                }
                treeSum[3 * i] = float(tree.r), treeSum[3 * i + 1] = float(tree.g);
                treeSum[3 * i + 2] = float(tree.b);
                backSum[3 * i] = float(back.r), backSum[3 * i + 1] = float(back.g);
                backSum[3 * i + 2] = float(back.b);
                coveredOf[i] = static_cast<uint16_t>(covered);
                samplesOf[i] = static_cast<uint16_t>(n);
            }
        }
    });
    // Exposure: a camera metering the tree — its pixels' log-average luminance (the whole
    // frame's over the sky) brought to `kMeterKey`, summed in pixel order (the same on any
    // thread count) — times 2^EV.
    double factor = 1.0;
    if (options.unlit) {
        factor = 1.0 / light.exposure;  // albedo as it is: no exposure
    } else if (options.autoExposure) {
        double logSum = 0.0;
        int64_t count = 0;
        // Over the sky, the whole frame (as a camera's matrix metering); else the tree.
        const bool wholeFrame = options.background == ColourBackground::kSky;
        for (size_t i = 0; i < npx; ++i) {
            const double lum3[3] = {0.2126, 0.7152, 0.0722};
            double lum = 0.0;
            if (wholeFrame && samplesOf[i] > 0) {
                for (int c = 0; c < 3; ++c) {
                    lum += lum3[c] * (treeSum[3 * i + c] + backSum[3 * i + c]) / samplesOf[i];
                }
            } else if (!wholeFrame && coveredOf[i] > 0) {
                for (int c = 0; c < 3; ++c) lum += lum3[c] * treeSum[3 * i + c] / coveredOf[i];
            } else {
                continue;
            }
            logSum += std::log(std::max(lum, 1e-4));
            ++count;
        }
        if (count > 0) {
            factor = std::clamp(kMeterKey / std::exp(logSum / double(count)), 0.25, 4.0);
        }
    }
    const double exposure = factor * light.exposure;
    img.light.exposureScale = exposure;
    for (size_t i = 0; i < npx; ++i) {
        const int n = samplesOf[i], covered = coveredOf[i];
        uint8_t* out = &img.rgba[4 * i];
        if (n == 0) continue;
        const Colour tree =
            Colour{treeSum[3 * i], treeSum[3 * i + 1], treeSum[3 * i + 2]} * exposure;
        const Colour back = Colour{backSum[3 * i], backSum[3 * i + 1], backSum[3 * i + 2]} *
                            (flatBack ? 1.0 : exposure);
        Colour c;
        double alpha = 1.0;
        if (opaque) {
            c = (tree + back) * (1.0 / n);
        } else {
            alpha = double(covered) / n;
            c = covered > 0 ? tree * (1.0 / covered) : Colour{};
        }
        out[0] = toByte(c.r);
        out[1] = toByte(c.g);
        out[2] = toByte(c.b);
        out[3] = static_cast<uint8_t>(std::lround(alpha * 255.0));
        // Alpha 255 only for full coverage, above 0 for any.
        if (!opaque && covered < n && out[3] == 255) out[3] = 254;
        if (!opaque && covered > 0 && out[3] == 0) out[3] = 1;
    }
    img.centreMisses = misses.load();
    return img;
}

}  // namespace sylva
