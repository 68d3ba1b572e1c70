// CPU renderer of one view: the tree's mesh as sylva writes it — the branch tubes of
// species/geometry/tube_mesh.h and the leaves' outline triangles — z-buffered into a
// silhouette, a depth map and labels; optionally the skeleton's segments as lines of a minimum
// width on top; plus silhouette statistics.
//
// Triangles. A pixel is covered iff its centre lies inside a triangle, edges inclusive (the
// barycentric weights all ≥ 0): a binary mask with no coverage fraction, the same test any
// plain rasteriser of the mesh file makes. No back faces are culled (a closed tube swept around
// a sharp bend can fold). Tube triangles use the mesh's float positions; leaf triangles are each
// leaf's outline points (leafPoints) rounded to float, as leafMesh writes them, one face only
// (the back face has the same positions). Depth is perspective-correct: 1/z is linear in screen
// space (z itself for orthographic). Triangles cut by the near plane (depth 1e-4 m) are
// clipped (Sutherland–Hodgman) and fanned.
//
// Lines (RenderOptions::minWidthPx > 0, off by default). Each skeleton segment, clipped to the
// near plane, covers the pixels whose centres lie within minWidthPx / 2 of its projected axis,
// at the depth of the nearest axis point within that distance (so a pixel's depth is never
// behind a skeleton point inside it). A width just over √2 px draws every pixel the axis passes
// through: sub-pixel twigs become unbroken 1–2 px lines, as in the papers' black-on-white
// figures. Wider tubes hide their own lines, since their surface is in front of their axis.
//
// Visibility: nearest depth (compared as float) wins; equal depths go to the lower label. A
// full tie leaves the same depth and label whichever primitive drew first, so the image does
// not depend on drawing order.
//
// Parallelism: vertices are projected in parallel; triangles are binned by the bands of
// kBandRows rows their clipped screen box overlaps (in parallel over fixed chunks, merged in
// chunk order); each band is owned by one task. The result does not depend on thread count.
#include "pipeline/render/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "species/model/leaf_shape.h"

namespace sylva {

namespace {

constexpr double kNear = 1e-4;      // metres; geometry closer than this is clipped
constexpr float kMinDepth = 1e-6f;  // drawn depths stay > 0 (0 means background)
constexpr int kBandRows = 16;
constexpr double kSpanMargin = 1e-6;  // pixels: a triangle's row span is widened by this
constexpr size_t kBinChunk = 8192;    // triangles per binning task

// World → camera space, camera space → pixels.
struct View {
    Vec3 right, up, back, eye;
    double f, cx, cy;
    bool ortho;
    int width, height;

    explicit View(const Camera& c)
        : right{c.cameraToWorld[0][0], c.cameraToWorld[1][0], c.cameraToWorld[2][0]},
          up{c.cameraToWorld[0][1], c.cameraToWorld[1][1], c.cameraToWorld[2][1]},
          back{c.cameraToWorld[0][2], c.cameraToWorld[1][2], c.cameraToWorld[2][2]},
          eye{c.cameraToWorld[0][3], c.cameraToWorld[1][3], c.cameraToWorld[2][3]},
          f(c.fx()),
          cx(c.cx()),
          cy(c.cy()),
          ortho(c.orthographic),
          width(c.width),
          height(c.height) {}

    Vec3 toCamera(const Vec3& p) const {
        const Vec3 d = p - eye;
        return {dot(d, right), dot(d, up), dot(d, back)};
    }
    // Camera-space point (depth −z > 0) → pixel coordinates.
    void toPixel(const Vec3& c, double& px, double& py) const {
        const double s = ortho ? f : f / -c.z;
        px = cx + s * c.x;
        py = cy - s * c.y;
    }
};

struct Box {
    int x0, x1, y0, y1;  // inclusive pixel ranges; empty when x0 > x1 or y0 > y1
};

// Index of the first / last pixel whose centre i + 0.5 is ≥ v / ≤ v, clamped to [−1, n]
// (n pixels) before converting, so far-off coordinates cannot overflow an int.
// Clamping before rounding gives the same integer (the bounds are integers) and lets the
// rounding be a truncation plus a step: std::ceil / std::floor are library calls on baseline
// x86-64 and were 3% of a build's time.
int firstCentreAtOrAfter(double v, int n) {
    const double c = std::clamp(v - 0.5, -1.0, static_cast<double>(n));
    const int i = static_cast<int>(c);  // rounds toward zero
    return i < c ? i + 1 : i;
}
int lastCentreAtOrBefore(double v, int n) {
    const double c = std::clamp(v - 0.5, -1.0, static_cast<double>(n));
    const int i = static_cast<int>(c);
    return i > c ? i - 1 : i;
}

// The pixel centres of one axis of the image (n pixels) that lie in [lo, hi]: first … last;
// false when there are none (also for NaN).
inline bool centreSpan(double lo, double hi, int n, int& first, int& last) {
    if (!(lo <= hi) || hi < 0.0 || lo > n) return false;
    first = std::max(0, firstCentreAtOrAfter(lo, n));
    last = std::min(n - 1, lastCentreAtOrBefore(hi, n));
    return first <= last;
}

// Pixels whose centres fall in the continuous box, clipped to the image.
bool pixelBox(double lox, double hix, double loy, double hiy, int w, int h, Box& box) {
    return centreSpan(lox, hix, w, box.x0, box.x1) && centreSpan(loy, hiy, h, box.y0, box.y1);
}

// A projected vertex: screen position, depth (metres along the view axis) and the term
// interpolated linearly in screen space (depth for orthographic, 1/depth for perspective).
struct Corner {
    double x, y, depth, z;
};

Corner project(const View& view, const Vec3& c) {
    Corner k;
    view.toPixel(c, k.x, k.y);
    k.depth = -c.z;
    k.z = view.ortho ? k.depth : 1.0 / k.depth;
    return k;
}

struct Triangle {
    double x[3], y[3];  // screen vertices
    double z[3];        // depth (orthographic) or 1/depth (perspective) per vertex
    double area;        // signed, twice the screen area
    float zmin;
    uint8_t label;
    uint16_t id;  // instance id (scene renders; 0 otherwise)
    Box box;
};

// The screen triangle of three corners; false when it has no area or no pixel centre in its
// box, or, with `frontOnly`, when it faces away from the camera (counter-clockwise seen from
// outside is clockwise on screen, whose rows run down: a negative area).
bool setupTriangle(const Corner& a, const Corner& b, const Corner& c, uint8_t label, int w, int h,
                   bool frontOnly, Triangle& t) {
    t.area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (!(frontOnly ? t.area < 0.0 : t.area != 0.0)) return false;  // (NaN area: false)
    const Corner* v[3] = {&a, &b, &c};
    double lox = 1e300, hix = -1e300, loy = 1e300, hiy = -1e300, zmin = 1e300;
    for (int j = 0; j < 3; ++j) {
        t.x[j] = v[j]->x;
        t.y[j] = v[j]->y;
        t.z[j] = v[j]->z;
        zmin = std::min(zmin, v[j]->depth);
        lox = std::min(lox, t.x[j]);
        hix = std::max(hix, t.x[j]);
        loy = std::min(loy, t.y[j]);
        hiy = std::max(hiy, t.y[j]);
    }
    t.zmin = static_cast<float>(zmin);
    t.label = label;
    t.id = 0;
    return pixelBox(lox, hix, loy, hiy, w, h, t.box);
}

// setupTriangle for a triangle whose pixel box the caller has found already (the same box:
// pixelBox of its extent), so only the area's test and the copies remain.
inline bool setupTriangleInBox(const Corner& a, const Corner& b, const Corner& c, bool frontOnly,
                               const Box& box, Triangle& t) {
    t.area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (!(frontOnly ? t.area < 0.0 : t.area != 0.0)) return false;  // (NaN area: false)
    t.x[0] = a.x, t.x[1] = b.x, t.x[2] = c.x;
    t.y[0] = a.y, t.y[1] = b.y, t.y[2] = c.y;
    t.z[0] = a.z, t.z[1] = b.z, t.z[2] = c.z;
    t.zmin = static_cast<float>(std::min(std::min(a.depth, b.depth), c.depth));
    t.box = box;
    return true;
}

// True when the triangle's box holds at most four pixel centres and each is clearly outside
// it (a barycentric weight below −1e-9), so drawing it would change no pixel: most triangles of
// twigs and shaped leaves are smaller than a pixel, and skipping them keeps the bins small.
// Centres within the margin are left to drawTriangle's exact test.
bool missesEveryCentre(const Triangle& t) {
    if ((t.box.x1 - t.box.x0 + 1) * (t.box.y1 - t.box.y0 + 1) > 4) return false;
    const double inv = 1.0 / t.area;
    for (int y = t.box.y0; y <= t.box.y1; ++y) {
        for (int x = t.box.x0; x <= t.box.x1; ++x) {
            const double pxc = x + 0.5, pyc = y + 0.5;
            bool outside = false;
            for (int j = 0; j < 3 && !outside; ++j) {
                const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
                outside = ((t.x[j2] - t.x[j1]) * (pyc - t.y[j1]) -
                           (t.y[j2] - t.y[j1]) * (pxc - t.x[j1])) *
                              inv <
                          -1e-9;
            }
            if (!outside) return false;
        }
    }
    return true;
}

// Camera-space polygon clipped to depth ≥ kNear (Sutherland–Hodgman against one plane).
int clipNear(const Vec3* in, int n, Vec3* out) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
        const Vec3& p = in[i];
        const Vec3& q = in[(i + 1) % n];
        const double dp = -p.z - kNear, dq = -q.z - kNear;
        if (dp >= 0) out[m++] = p;
        if ((dp >= 0) != (dq >= 0)) out[m++] = p + (q - p) * (dp / (dp - dq));
    }
    return m;
}

// A skeleton segment drawn as a line of a minimum width (RenderOptions::minWidthPx).
struct Line {
    double ax, ay, bx, by;  // screen endpoints
    double da, db;          // axis depths at the ends (≥ kNear)
    double invDa, invDb;    // their reciprocals
    double invLen2;         // 1 / squared screen length, 0 for a point
    bool aNearer;           // da ≤ db
    bool ortho;
    double radius;  // pixels: half the width
    float zmin;
    uint8_t label;
    uint16_t id;
    Box box;
};

// A pixel a small triangle covers, found while binning: its index, label and the interpolated
// depth term (depth for orthographic views, 1/depth for perspective ones; inverted only for
// the fragments kept).
struct Fragment {
    uint32_t pixel;
    uint8_t label;
    uint16_t id;
    double zi;
};

// A growable array of fragments whose new slots are not zeroed first (appendFragments writes
// every slot it keeps).
class Fragments {
  public:
    size_t size() const { return size_; }
    Fragment* data() { return data_.get(); }
    const Fragment* data() const { return data_.get(); }
    // Room for `more` fragments past size(), returned as the first free slot.
    Fragment* grow(size_t more) {
        if (size_ + more > capacity_) {
            const size_t capacity = std::max(size_ + more, 2 * capacity_ + 1024);
            std::unique_ptr<Fragment[]> bigger(new Fragment[capacity]);
            std::copy(data_.get(), data_.get() + size_, bigger.get());
            data_ = std::move(bigger);
            capacity_ = capacity;
        }
        return data_.get() + size_;
    }
    void setSize(size_t size) { size_ = size; }

  private:
    std::unique_ptr<Fragment[]> data_;
    size_t size_ = 0, capacity_ = 0;
};

// The z-buffer's depth for a depth in metres.
inline float storedDepth(double depth) { return std::max(kMinDepth, static_cast<float>(depth)); }

// Barycentric weight of vertex j at (px, py): the signed sub-triangle opposite it over the
// triangle's signed area (1 / area = inv).
inline double weight(const Triangle& t, int j, double px, double py, double inv) {
    const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
    return ((t.x[j2] - t.x[j1]) * (py - t.y[j1]) - (t.y[j2] - t.y[j1]) * (px - t.x[j1])) * inv;
}

// Appends the pixels of a triangle whose box holds few centres: each centre inside it (every
// weight ≥ 0, edges inclusive) at its perspective-correct depth. The same arithmetic as
// weight(), with the per-row and per-triangle terms hoisted; every centre of the box is
// written and kept only if inside (no branch to mispredict: most centres are outside). Two
// centres of a row at a time in SSE2's two double lanes (x86-64's baseline): each lane does the
// scalar code's operations in its order, so the weights and depths are the same bits, and the
// compiler left the scalar loop unvectorised (≈ 70 instructions a centre).
void appendFragments(const Triangle& t, int w, Fragments& out) {
    const double inv = 1.0 / t.area;
    double dx[3], dy[3];
    for (int j = 0; j < 3; ++j) {
        const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        dx[j] = t.x[j2] - t.x[j1];
        dy[j] = t.y[j2] - t.y[j1];
    }
    Fragment* f =
        out.grow(static_cast<size_t>(t.box.x1 - t.box.x0 + 1) * (t.box.y1 - t.box.y0 + 1));
    size_t n = 0;
#if defined(__SSE2__)
    const __m128d vInv = _mm_set1_pd(inv), zero = _mm_setzero_pd();
    const __m128d dy0 = _mm_set1_pd(dy[0]), dy1 = _mm_set1_pd(dy[1]), dy2 = _mm_set1_pd(dy[2]);
    const __m128d x0 = _mm_set1_pd(t.x[0]), x1 = _mm_set1_pd(t.x[1]), x2 = _mm_set1_pd(t.x[2]);
    const __m128d z0 = _mm_set1_pd(t.z[0]), z1 = _mm_set1_pd(t.z[1]), z2 = _mm_set1_pd(t.z[2]);
#endif
    for (int y = t.box.y0; y <= t.box.y1; ++y) {
        const double pyc = y + 0.5;
        const double r0 = dx[0] * (pyc - t.y[1]), r1 = dx[1] * (pyc - t.y[2]),
                     r2 = dx[2] * (pyc - t.y[0]);
        const size_t rowOff = static_cast<size_t>(y) * w;
        int x = t.box.x0;
#if defined(__SSE2__)
        const __m128d vr0 = _mm_set1_pd(r0), vr1 = _mm_set1_pd(r1), vr2 = _mm_set1_pd(r2);
        for (; x < t.box.x1; x += 2) {
            const __m128d pxc = _mm_set_pd(x + 1.5, x + 0.5);  // (x + 1) + 0.5 exactly
            const __m128d b0 =
                _mm_mul_pd(_mm_sub_pd(vr0, _mm_mul_pd(dy0, _mm_sub_pd(pxc, x1))), vInv);
            const __m128d b1 =
                _mm_mul_pd(_mm_sub_pd(vr1, _mm_mul_pd(dy1, _mm_sub_pd(pxc, x2))), vInv);
            const __m128d b2 =
                _mm_mul_pd(_mm_sub_pd(vr2, _mm_mul_pd(dy2, _mm_sub_pd(pxc, x0))), vInv);
            const __m128d zi =
                _mm_add_pd(_mm_add_pd(_mm_mul_pd(b0, z0), _mm_mul_pd(b1, z1)), _mm_mul_pd(b2, z2));
            const int inside = _mm_movemask_pd(
                _mm_and_pd(_mm_and_pd(_mm_cmpge_pd(b0, zero), _mm_cmpge_pd(b1, zero)),
                           _mm_cmpge_pd(b2, zero)));
            double z[2];
            _mm_storeu_pd(z, zi);
            f[n] = {static_cast<uint32_t>(rowOff + x), t.label, t.id, z[0]};
            n += inside & 1;
            f[n] = {static_cast<uint32_t>(rowOff + x + 1), t.label, t.id, z[1]};
            n += inside >> 1;
        }
#endif
        for (; x <= t.box.x1; ++x) {
            const double pxc = x + 0.5;
            const double b0 = (r0 - dy[0] * (pxc - t.x[1])) * inv;
            const double b1 = (r1 - dy[1] * (pxc - t.x[2])) * inv;
            const double b2 = (r2 - dy[2] * (pxc - t.x[0])) * inv;
            const double zi = b0 * t.z[0] + b1 * t.z[1] + b2 * t.z[2];
            f[n] = {static_cast<uint32_t>(rowOff + x), t.label, t.id, zi};
            n += (b0 >= 0.0) & (b1 >= 0.0) & (b2 >= 0.0);
        }
    }
    out.setSize(out.size() + n);
}

// What every view of one tree shares: the labels per node, and the leaves' outline points in
// the world (rounded to float, as leafMesh writes them) with their triangles — computed once
// for all the views rather than once per view.
struct TreePrep {
    const Tree* tree = nullptr;
    const Mesh* wood = nullptr;
    const std::vector<int32_t>* woodNodes = nullptr;
    const SceneLabels* labels = nullptr;
    std::vector<uint8_t> ownNodeLabels;  // segmentLabel per node, when no labels are given
    const uint8_t* nodeLabels = nullptr;
    // Outline points of every leaf, leaf by leaf: x, y, z as float, the mesh's values. (Stored
    // as floats: GCC 12 at -O2 drops the rounding from push_back({static_cast<float>(x), …})
    // into a vector of double Vec3s.)
    std::vector<float> leafWorld;
    std::vector<uint32_t> leafIndices;   // into the corners (after the tube vertices)
    std::vector<uint8_t> leafTriLabels;  // with labels: per leaf triangle
    std::vector<uint16_t> leafTriIds;
};

TreePrep prepareTree(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                     const SceneLabels* labels) {
    if (woodNodes.size() != wood.triangleCount()) {
        throw std::invalid_argument("renderView: woodNodes needs one node per wood triangle");
    }
    for (int32_t node : woodNodes) {
        if (node < 0 || static_cast<size_t>(node) >= tree.nodes.size()) {
            throw std::invalid_argument("renderView: woodNodes holds a node the tree lacks");
        }
    }
    if (labels && (labels->nodeLabels.size() != tree.nodes.size() ||
                   labels->nodeIds.size() != tree.nodes.size() ||
                   labels->leafLabels.size() != tree.leaves.size() ||
                   labels->leafIds.size() != tree.leaves.size())) {
        throw std::invalid_argument("renderScene: one label and id per node and per leaf");
    }
    TreePrep prep;
    prep.tree = &tree;
    prep.wood = &wood;
    prep.woodNodes = &woodNodes;
    prep.labels = labels;
    if (labels) {
        prep.nodeLabels = labels->nodeLabels.data();
    } else {
        prep.ownNodeLabels.resize(tree.nodes.size());
        for (size_t i = 0; i < tree.nodes.size(); ++i)
            prep.ownNodeLabels[i] = segmentLabel(tree.nodes[i]);
        prep.nodeLabels = prep.ownNodeLabels.data();
    }
    const size_t nWood = wood.vertexCount();
    size_t nLeafPoints = 0, nLeafIndices = 0;
    for (const Leaf& leaf : tree.leaves) {
        const LeafOutline& outline = leafOutline(leaf.shape);
        nLeafPoints += outline.points.size();
        nLeafIndices += outline.triangles.size();
    }
    prep.leafWorld.reserve(3 * nLeafPoints);
    prep.leafIndices.reserve(nLeafIndices);
    if (labels) {
        prep.leafTriLabels.reserve(nLeafIndices / 3);
        prep.leafTriIds.reserve(nLeafIndices / 3);
    }
    std::vector<Vec3> points;
    for (size_t li = 0; li < tree.leaves.size(); ++li) {
        const Leaf& leaf = tree.leaves[li];
        const LeafOutline& outline = leafOutline(leaf.shape);
        if (labels) {
            prep.leafTriLabels.insert(prep.leafTriLabels.end(), outline.triangleCount(),
                                      labels->leafLabels[li]);
            prep.leafTriIds.insert(prep.leafTriIds.end(), outline.triangleCount(),
                                   labels->leafIds[li]);
        }
        sylva::leafPoints(leaf, leafFrame(leaf), outline, points);
        const uint32_t first = static_cast<uint32_t>(nWood + prep.leafWorld.size() / 3);
        for (const Vec3& p : points) {
            prep.leafWorld.push_back(static_cast<float>(p.x));
            prep.leafWorld.push_back(static_cast<float>(p.y));
            prep.leafWorld.push_back(static_cast<float>(p.z));
        }
        for (uint32_t v : outline.triangles) prep.leafIndices.push_back(first + v);
    }
    return prep;
}

// What one view draws. Triangle ids: [0, woodTriangles) the tube triangles, then the leaf
// triangles (leafIndices), then `clipped` (triangles cut by the near plane, made explicit);
// line ids follow the triangles'. Triangles whose box holds at most kSmallBox pixel centres
// (almost all of a tree's: twigs are thinner than a pixel) are resolved into fragments while
// binning; the others, clipped triangles and lines are binned by id and drawn per band.
struct Scene {
    Corner* corners = nullptr;  // tube vertices, then leaf outline points (Scratch's)
    const Mesh* wood = nullptr;
    const int32_t* woodNodes = nullptr;
    const uint8_t* nodeLabels = nullptr;  // segmentLabel per skeleton node (or the caller's)
    const uint16_t* nodeIds = nullptr;    // instance id per node (scene renders)
    // Per leaf triangle, its label and instance id (scene renders; null: kLabelLeaf, id 0).
    const uint8_t* leafTriLabels = nullptr;
    const uint16_t* leafTriIds = nullptr;
    size_t woodTriangles = 0;
    const float* leafWorld = nullptr;       // leaf outline points in the world (TreePrep's)
    const uint32_t* leafIndices = nullptr;  // into corners
    size_t indexedTriangles = 0;            // woodTriangles + leaf triangles
    std::vector<Triangle> clipped;
    std::vector<Line> lines;
    std::vector<std::vector<uint32_t>> bins;  // per band: ids in ascending order
    // Per binning chunk: its fragments sorted by band, band b at [bandStart[b], [b + 1]).
    struct Chunk {
        std::vector<Fragment> fragments;
        std::vector<uint32_t> bandStart;
        std::vector<uint32_t> big, cut;  // ids: binned whole; cut by the near plane
    };
    std::vector<Chunk> chunks;
};

constexpr int kSmallBox = 16;

// Corner indices of indexed triangle `id`.
inline void cornersOf(const Scene& s, size_t id, uint32_t v[3]) {
    const uint32_t* p = id < s.woodTriangles ? s.wood->indices.data() + 3 * id
                                             : s.leafIndices + 3 * (id - s.woodTriangles);
    v[0] = p[0];
    v[1] = p[1];
    v[2] = p[2];
}

inline uint8_t labelOf(const Scene& s, const Tree& tree, size_t id) {
    if (id < s.woodTriangles) return s.nodeLabels[s.woodNodes[id]];
    return s.leafTriLabels ? s.leafTriLabels[id - s.woodTriangles] : kLabelLeaf;
}

inline uint16_t idOf(const Scene& s, size_t id) {
    if (id < s.woodTriangles) return s.nodeIds ? s.nodeIds[s.woodNodes[id]] : 0;
    return s.leafTriIds ? s.leafTriIds[id - s.woodTriangles] : 0;
}

// Camera-space position of corner v (wood vertices recomputed from the mesh).
inline Vec3 cameraPoint(const Scene& s, const View& view, uint32_t v) {
    const size_t nWood = s.wood->vertexCount();
    const float* p = v >= nWood ? &s.leafWorld[3 * static_cast<size_t>(v - nWood)]
                                : &s.wood->positions[3 * static_cast<size_t>(v)];
    return view.toCamera({p[0], p[1], p[2]});
}

void addToBins(Scene& scene, const Box& box, uint32_t id) {
    for (int band = box.y0 / kBandRows; band <= box.y1 / kBandRows; ++band) {
        scene.bins[band].push_back(id);
    }
}

void addLines(const Tree& tree, const View& view, double radius, Scene& scene) {
    const auto& nodes = tree.nodes;
    std::vector<Vec3> cam(nodes.size());
    for (size_t i = 0; i < nodes.size(); ++i) cam[i] = view.toCamera(nodes[i].position);
    const uint32_t firstId = static_cast<uint32_t>(scene.indexedTriangles + scene.clipped.size());
    for (size_t i = 1; i < nodes.size(); ++i) {
        const int32_t p = nodes[i].parent;
        if (p < 0 || static_cast<size_t>(p) >= nodes.size()) continue;
        Vec3 a = cam[p], b = cam[i];
        double da = -a.z, db = -b.z;
        if (!(da >= kNear || db >= kNear)) continue;  // wholly behind (or NaN)
        if (da < kNear) {
            a = a + (b - a) * ((kNear - da) / (db - da));
            da = kNear;
        } else if (db < kNear) {
            b = b + (a - b) * ((kNear - db) / (da - db));
            db = kNear;
        }
        Line s;
        s.da = da;
        s.db = db;
        s.invDa = 1.0 / da;
        s.invDb = 1.0 / db;
        s.aNearer = da <= db;
        s.ortho = view.ortho;
        view.toPixel(a, s.ax, s.ay);
        view.toPixel(b, s.bx, s.by);
        const double dx = s.bx - s.ax, dy = s.by - s.ay, len2 = dx * dx + dy * dy;
        s.invLen2 = len2 > 1e-18 ? 1.0 / len2 : 0.0;
        s.radius = radius;
        s.zmin = static_cast<float>(std::min(da, db));
        s.label = scene.nodeLabels[i];
        s.id = scene.nodeIds ? scene.nodeIds[i] : 0;
        if (!pixelBox(std::min(s.ax, s.bx) - radius, std::max(s.ax, s.bx) + radius,
                      std::min(s.ay, s.by) - radius, std::max(s.ay, s.by) + radius, view.width,
                      view.height, s.box)) {
            continue;
        }
        addToBins(scene, s.box, firstId + static_cast<uint32_t>(scene.lines.size()));
        scene.lines.push_back(s);
    }
}

// Memory the views of one tree reuse: the projected corners (tens of megabytes for a tree of
// compound leaves, which a fresh allocation per view would page in anew each time).
struct Scratch {
    std::unique_ptr<Corner[]> corners;
    size_t capacity = 0;
    Corner* cornersFor(size_t n) {
        if (n > capacity) {
            corners.reset(new Corner[n]);  // (uninitialised: every one used is written first)
            capacity = n;
        }
        return corners.get();
    }
};

Scene buildScene(const TreePrep& prep, const View& view, const RenderOptions& options,
                 Scratch& scratch) {
    const Tree& tree = *prep.tree;
    const Mesh& wood = *prep.wood;
    Scene scene;
    const int w = view.width, h = view.height;
    const int bands = (h + kBandRows - 1) / kBandRows;
    scene.bins.resize(bands);
    scene.wood = &wood;
    scene.woodNodes = prep.woodNodes->data();
    scene.woodTriangles = wood.triangleCount();
    scene.nodeLabels = prep.nodeLabels;
    scene.nodeIds = prep.labels ? prep.labels->nodeIds.data() : nullptr;
    scene.leafIndices = prep.leafIndices.data();
    if (prep.labels) {
        scene.leafTriLabels = prep.leafTriLabels.data();
        scene.leafTriIds = prep.leafTriIds.data();
    }

    // Vertices, in parallel: the tubes', then every leaf's outline points.
    const size_t nWood = wood.vertexCount();
    const size_t nLeafPoints = prep.leafWorld.size() / 3;
    scene.leafWorld = prep.leafWorld.data();
    scene.corners = scratch.cornersFor(nWood + nLeafPoints);  // (all written below)
    Corner* corners = scene.corners;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nWood + nLeafPoints, 4096),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                              corners[i] =
                                  project(view, cameraPoint(scene, view, static_cast<uint32_t>(i)));
                          }
                      });
    scene.indexedTriangles = scene.woodTriangles + prep.leafIndices.size() / 3;

    // Triangles, chunk by chunk in parallel: small ones straight to fragments, the others set
    // aside to be binned whole, those cut by the near plane set aside to be clipped.
    const size_t n = scene.indexedTriangles;
    scene.chunks.resize((n + kBinChunk - 1) / kBinChunk);
    const size_t bandPixels = static_cast<size_t>(w) * kBandRows;
    tbb::parallel_for(size_t(0), scene.chunks.size(), [&](size_t c) {
        Scene::Chunk& chunk = scene.chunks[c];
        Fragments found;
        const size_t end = std::min(n, (c + 1) * kBinChunk);
        for (size_t id = c * kBinChunk; id < end; ++id) {
            uint32_t v[3];
            cornersOf(scene, id, v);
            const Corner &a = corners[v[0]], &b = corners[v[1]], &d = corners[v[2]];
            if (!(a.depth >= kNear && b.depth >= kNear && d.depth >= kNear)) {
                chunk.cut.push_back(static_cast<uint32_t>(id));
                continue;
            }
            // About a third of them are tubes' back faces: settled by the sign of their area,
            // the set-up's first test, before anything else.
            const bool wood = id < scene.woodTriangles;
            if (wood && !((b.x - a.x) * (d.y - a.y) - (b.y - a.y) * (d.x - a.x) < 0.0)) continue;
            // Most of a tree's triangles are smaller than a pixel and hold no pixel centre:
            // those are settled by their extent alone, and the pixel box found on the way is
            // the set-up's (pixelBox is these two tests).
            Box box;
            if (!centreSpan(std::min({a.x, b.x, d.x}), std::max({a.x, b.x, d.x}), w, box.x0,
                            box.x1) ||
                !centreSpan(std::min({a.y, b.y, d.y}), std::max({a.y, b.y, d.y}), h, box.y0,
                            box.y1)) {
                continue;
            }
            Triangle t;
            if (!setupTriangleInBox(a, b, d, wood, box, t)) continue;
            if ((t.box.x1 - t.box.x0 + 1) * (t.box.y1 - t.box.y0 + 1) > kSmallBox) {
                chunk.big.push_back(static_cast<uint32_t>(id));
                continue;
            }
            t.label = labelOf(scene, tree, id);
            t.id = idOf(scene, id);
            appendFragments(t, w, found);
        }
        // Counting sort by band.
        const Fragment* all = found.data();
        const size_t count = found.size();
        chunk.bandStart.assign(bands + 1, 0);
        for (size_t k = 0; k < count; ++k) ++chunk.bandStart[all[k].pixel / bandPixels + 1];
        for (int b = 0; b < bands; ++b) chunk.bandStart[b + 1] += chunk.bandStart[b];
        chunk.fragments.resize(count);
        std::vector<uint32_t> next(chunk.bandStart.begin(), chunk.bandStart.end() - 1);
        for (size_t k = 0; k < count; ++k) {
            chunk.fragments[next[all[k].pixel / bandPixels]++] = all[k];
        }
    });
    for (const Scene::Chunk& chunk : scene.chunks) {
        for (uint32_t id : chunk.big) {
            uint32_t v[3];
            cornersOf(scene, id, v);
            Triangle t;
            setupTriangle(corners[v[0]], corners[v[1]], corners[v[2]], 0, w, h, false, t);
            addToBins(scene, t.box, id);
        }
    }
    for (const Scene::Chunk& chunk : scene.chunks) {
        for (uint32_t id : chunk.cut) {
            uint32_t v[3];
            cornersOf(scene, id, v);
            const Vec3 tri[3] = {cameraPoint(scene, view, v[0]), cameraPoint(scene, view, v[1]),
                                 cameraPoint(scene, view, v[2])};
            Vec3 poly[4];
            const int m = clipNear(tri, 3, poly);
            const uint8_t label = labelOf(scene, tree, id);
            for (int j = 1; j + 1 < m; ++j) {  // fan
                Triangle t;
                if (!setupTriangle(project(view, poly[0]), project(view, poly[j]),
                                   project(view, poly[j + 1]), label, w, h,
                                   id < scene.woodTriangles, t) ||
                    missesEveryCentre(t)) {
                    continue;
                }
                t.id = idOf(scene, id);
                addToBins(scene, t.box, static_cast<uint32_t>(n + scene.clipped.size()));
                scene.clipped.push_back(t);
            }
        }
    }
    if (options.minWidthPx > 0) addLines(tree, view, 0.5 * options.minWidthPx, scene);
    return scene;
}

// The z-buffer test and write. Equal depths go to the lower label, then (with an id buffer)
// to the lower id.
inline void plot(float* zbuf, uint8_t* lbuf, uint16_t* ibuf, size_t k, double depth, uint8_t label,
                 uint16_t id) {
    const float z = storedDepth(depth);
    if (!ibuf) {
        if (z < zbuf[k] || (z == zbuf[k] && label < lbuf[k])) {
            zbuf[k] = z;
            lbuf[k] = label;
        }
        return;
    }
    if (z < zbuf[k] || (z == zbuf[k] && (label < lbuf[k] || (label == lbuf[k] && id < ibuf[k])))) {
        zbuf[k] = z;
        lbuf[k] = label;
        ibuf[k] = id;
    }
}

// Depth of the axis at the nearest point of the stretch of the screen-space axis within
// `radius` pixels of a pixel centre p inside it; tRaw: the unclamped screen parameter of the
// point of the axis line closest to p, pa2 = |p − screen a|².
double nearestAxisDepth(const Line& s, double tRaw, double pa2, double radius) {
    double u = s.aNearer ? 0.0 : 1.0;  // depth is monotonic along the axis: the nearer end …
    if (s.invLen2 > 0) {               // … of the stretch
        const double half =
            std::sqrt(std::max(0.0, tRaw * tRaw - (pa2 - radius * radius) * s.invLen2));
        u = s.aNearer ? std::max(0.0, tRaw - half) : std::min(1.0, tRaw + half);
    }
    // Perspective: 1/depth is linear in screen space; orthographic: depth is.
    return s.ortho ? s.da + u * (s.db - s.da) : 1.0 / (s.invDa + u * (s.invDb - s.invDa));
}

void drawLine(const Line& s, int w, int row0, int row1, float* zbuf, uint8_t* lbuf,
              uint16_t* ibuf) {
    const double dx = s.bx - s.ax, dy = s.by - s.ay;
    const double reach = s.radius;
    for (int y = std::max(s.box.y0, row0); y <= std::min(s.box.y1, row1 - 1); ++y) {
        const double pyc = y + 0.5;
        // Only the part of the axis within `reach` rows of this one can cover it.
        int xa = s.box.x0, xb = s.box.x1;
        if (std::abs(dy) > 1e-12) {
            const double ta = std::clamp((pyc - reach - s.ay) / dy, 0.0, 1.0);
            const double tb = std::clamp((pyc + reach - s.ay) / dy, 0.0, 1.0);
            const double xta = s.ax + ta * dx, xtb = s.ax + tb * dx;
            xa = std::max(xa, firstCentreAtOrAfter(std::min(xta, xtb) - reach, w));
            xb = std::min(xb, lastCentreAtOrBefore(std::max(xta, xtb) + reach, w));
        }
        const size_t rowOff = static_cast<size_t>(y) * w;
        for (int x = xa; x <= xb; ++x) {
            const size_t k = rowOff + x;
            if (zbuf[k] < s.zmin) continue;  // something strictly nearer already
            const double pxc = x + 0.5;
            const double pax = pxc - s.ax, pay = pyc - s.ay;
            const double tRaw = (pax * dx + pay * dy) * s.invLen2;
            const double t = std::clamp(tRaw, 0.0, 1.0);
            const double ex = pxc - (s.ax + t * dx), ey = pyc - (s.ay + t * dy);
            if (ex * ex + ey * ey > reach * reach) continue;
            plot(zbuf, lbuf, ibuf, k, nearestAxisDepth(s, tRaw, pax * pax + pay * pay, reach),
                 s.label, s.id);
        }
    }
}

void drawTriangle(const Triangle& t, bool ortho, int w, int row0, int row1, float* zbuf,
                  uint8_t* lbuf, uint16_t* ibuf) {
    const double inv = 1.0 / t.area;
    // Each weight is linear along a row, so the inside of a row is an interval: per edge, the
    // x where the weight opposite it crosses 0, linear in the row's y.
    double slope[3], sign[3];
    for (int j = 0; j < 3; ++j) {
        const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        const double dy = t.y[j2] - t.y[j1];
        slope[j] = dy != 0.0 ? (t.x[j2] - t.x[j1]) / dy : 0.0;
        sign[j] = dy * inv;  // > 0: the weight falls as x grows (inside left of the crossing)
    }
    for (int y = std::max(t.box.y0, row0); y <= std::min(t.box.y1, row1 - 1); ++y) {
        const double pyc = y + 0.5;
        const size_t rowOff = static_cast<size_t>(y) * w;
        // The row's span, widened by a hair so the exact test below still decides every pixel
        // (slivers do not scan their whole box).
        double lo = t.box.x0 + 0.5, hi = t.box.x1 + 0.5;
        for (int j = 0; j < 3; ++j) {
            const int j1 = (j + 1) % 3;
            if (sign[j] > 0) {
                hi = std::min(hi, t.x[j1] + slope[j] * (pyc - t.y[j1]) + kSpanMargin);
            } else if (sign[j] < 0) {
                lo = std::max(lo, t.x[j1] + slope[j] * (pyc - t.y[j1]) - kSpanMargin);
            } else if (weight(t, j, lo, pyc, inv) < -kSpanMargin) {
                lo = hi + 1;  // parallel to the row and outside: no pixel
            }
        }
        if (!(lo <= hi)) continue;
        const int xa = std::max(t.box.x0, firstCentreAtOrAfter(lo, w));
        const int xb = std::min(t.box.x1, lastCentreAtOrBefore(hi, w));
        for (int x = xa; x <= xb; ++x) {
            const size_t k = rowOff + x;
            if (zbuf[k] < t.zmin) continue;
            const double pxc = x + 0.5;
            const double b0 = weight(t, 0, pxc, pyc, inv);
            if (b0 < 0.0) continue;
            const double b1 = weight(t, 1, pxc, pyc, inv);
            if (b1 < 0.0) continue;
            const double b2 = weight(t, 2, pxc, pyc, inv);
            if (b2 < 0.0) continue;
            const double zi = b0 * t.z[0] + b1 * t.z[1] + b2 * t.z[2];
            plot(zbuf, lbuf, ibuf, k, ortho ? zi : 1.0 / zi, t.label, t.id);
        }
    }
}

void checkImageSize(const Camera& camera) {
    if (camera.width <= 0 || camera.height <= 0) {
        throw std::invalid_argument("renderView: image size must be positive");
    }
    if (static_cast<double>(camera.width) * camera.height > 4.0e9) {
        throw std::invalid_argument("renderView: image too large");
    }
}

// One object's pass into the z-buffer (ids: the id buffer, or null for a tree's own views).
void drawInto(const TreePrep& prep, const View& view, const RenderOptions& options, float* zbuf,
              uint8_t* lbuf, uint16_t* ids, Scratch& scratch) {
    const Tree& tree = *prep.tree;
    if (!(view.f > 0 && std::isfinite(view.f))) return;
    const int w = view.width, h = view.height;
    const Scene scene = buildScene(prep, view, options, scratch);
    const size_t firstClipped = scene.indexedTriangles;
    const size_t firstLine = firstClipped + scene.clipped.size();
    const int bands = static_cast<int>(scene.bins.size());
    tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& r) {
        float* z = zbuf;
        uint8_t* l = lbuf;
        for (int band = r.begin(); band != r.end(); ++band) {
            const int row0 = band * kBandRows, row1 = std::min(h, row0 + kBandRows);
            for (const Scene::Chunk& chunk : scene.chunks) {
                for (uint32_t i = chunk.bandStart[band]; i < chunk.bandStart[band + 1]; ++i) {
                    const Fragment& f = chunk.fragments[i];
                    plot(z, l, ids, f.pixel, view.ortho ? f.zi : 1.0 / f.zi, f.label, f.id);
                }
            }
            for (uint32_t id : scene.bins[band]) {
                if (id < firstClipped) {
                    uint32_t v[3];
                    cornersOf(scene, id, v);
                    Triangle t;
                    setupTriangle(scene.corners[v[0]], scene.corners[v[1]], scene.corners[v[2]],
                                  labelOf(scene, tree, id), w, h, false, t);
                    t.id = idOf(scene, id);
                    drawTriangle(t, view.ortho, w, row0, row1, z, l, ids);
                } else if (id < firstLine) {
                    drawTriangle(scene.clipped[id - firstClipped], view.ortho, w, row0, row1, z, l,
                                 ids);
                } else {
                    drawLine(scene.lines[id - firstLine], w, row0, row1, z, l, ids);
                }
            }
        }
    });
}

// The image of a filled z-buffer: the silhouette from the drawn pixels, background depth ∞ → 0.
ViewImage finishImage(int w, int h, std::vector<float>& zbuf, std::vector<uint8_t>& lbuf,
                      std::vector<uint16_t>& ibuf, bool wantDepth, bool wantLabels, bool wantIds) {
    const size_t n = static_cast<size_t>(w) * h;
    ViewImage out;
    out.width = w;
    out.height = h;
    out.silhouette.resize(n);
    constexpr float kInf = std::numeric_limits<float>::infinity();
    uint8_t* sil = out.silhouette.data();
    float* z = zbuf.data();
    size_t k = 0;
#if defined(__SSE2__)
    // Sixteen pixels at a time: a drawn pixel's mask is all ones (z ≠ ∞, also for NaN, as
    // below), which keeps its depth and, packed to bytes with signed saturation, is 255. The
    // compiler left the loop scalar at 3.5 instructions a pixel (its two element widths).
    const __m128 inf = _mm_set1_ps(kInf);
    for (; k + 16 <= n; k += 16) {
        __m128i drawn[4];
        for (int q = 0; q < 4; ++q) {
            const __m128 d = _mm_loadu_ps(z + k + 4 * q);
            const __m128 m = _mm_cmpneq_ps(d, inf);
            _mm_storeu_ps(z + k + 4 * q, _mm_and_ps(d, m));
            drawn[q] = _mm_castps_si128(m);
        }
        _mm_storeu_si128(reinterpret_cast<__m128i*>(sil + k),
                         _mm_packs_epi16(_mm_packs_epi32(drawn[0], drawn[1]),
                                         _mm_packs_epi32(drawn[2], drawn[3])));
    }
#endif
    for (; k < n; ++k) {
        const bool drawn = z[k] != kInf;
        sil[k] = drawn ? 255 : 0;
        z[k] = drawn ? z[k] : 0.0f;
    }
    if (wantDepth) out.depth = std::move(zbuf);
    if (wantLabels) out.labels = std::move(lbuf);
    if (wantIds) out.ids = std::move(ibuf);
    return out;
}

ViewImage renderImpl(const TreePrep& prep, const Camera& camera, bool wantDepth, bool wantLabels,
                     bool wantIds, const RenderOptions& options, Scratch& scratch) {
    checkImageSize(camera);
    const View view(camera);
    const size_t n = static_cast<size_t>(camera.width) * camera.height;
    std::vector<float> zbuf(n, std::numeric_limits<float>::infinity());
    std::vector<uint8_t> lbuf(n, kLabelBackground);
    std::vector<uint16_t> ibuf(prep.labels ? n : 0, 0);
    drawInto(prep, view, options, zbuf.data(), lbuf.data(), prep.labels ? ibuf.data() : nullptr,
             scratch);
    return finishImage(camera.width, camera.height, zbuf, lbuf, ibuf, wantDepth, wantLabels,
                       wantIds);
}

}  // namespace

SceneCanvas::SceneCanvas(const Camera& camera, const RenderOptions& options)
    : camera_(camera), options_(options) {
    checkImageSize(camera);
    const size_t n = static_cast<size_t>(camera.width) * camera.height;
    zbuf_.assign(n, std::numeric_limits<float>::infinity());
    lbuf_.assign(n, kLabelBackground);
    ibuf_.assign(n, 0);
}

void SceneCanvas::draw(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                       const SceneLabels& labels) {
    if (zbuf_.empty()) throw std::logic_error("SceneCanvas: draw after finish");
    Scratch scratch;
    drawInto(prepareTree(tree, wood, woodNodes, &labels), View(camera_), options_, zbuf_.data(),
             lbuf_.data(), ibuf_.data(), scratch);
}

ViewImage SceneCanvas::finish(bool wantDepth, bool wantLabels, bool wantIds) {
    ViewImage v = finishImage(camera_.width, camera_.height, zbuf_, lbuf_, ibuf_, wantDepth,
                              wantLabels, wantIds);
    zbuf_ = {};
    lbuf_ = {};
    ibuf_ = {};
    return v;
}

ViewImage renderView(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                     const Camera& camera, bool wantDepth, bool wantLabels,
                     const RenderOptions& options) {
    Scratch scratch;
    return renderImpl(prepareTree(tree, wood, woodNodes, nullptr), camera, wantDepth, wantLabels,
                      false, options, scratch);
}

std::vector<ViewImage> renderViews(const Tree& tree, const Mesh& wood,
                                   const std::vector<int32_t>& woodNodes,
                                   const std::vector<Camera>& cameras, bool wantDepth,
                                   bool wantLabels, const RenderOptions& options) {
    const TreePrep prep = prepareTree(tree, wood, woodNodes, nullptr);
    std::vector<ViewImage> views;
    views.reserve(cameras.size());
    Scratch scratch;
    for (const Camera& c : cameras) {
        views.push_back(renderImpl(prep, c, wantDepth, wantLabels, false, options, scratch));
    }
    return views;
}

ViewImage renderScene(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                      const SceneLabels& labels, const Camera& camera, bool wantDepth,
                      bool wantLabels, bool wantIds, const RenderOptions& options) {
    Scratch scratch;
    return renderImpl(prepareTree(tree, wood, woodNodes, &labels), camera, wantDepth, wantLabels,
                      wantIds, options, scratch);
}

ViewImage renderView(const Tree& tree, const Camera& camera, bool wantDepth, bool wantLabels,
                     const TubeOptions& tubes, const RenderOptions& options) {
    std::vector<int32_t> nodes;
    const Mesh wood = tubeMesh(tree, tubes, &nodes);
    return renderView(tree, wood, nodes, camera, wantDepth, wantLabels, options);
}

namespace {

// Pixels counted in 16-bit sums over stretches of 65,535 (none can overflow), which the compiler
// vectorises eight to a register. Summed straight into a size_t, the loops ran a pixel at a
// time: over ez-size's label images 4.3 instructions a pixel, with 32-bit sums 2.2, with 16-bit
// sums 1.2 (callgrind).
constexpr size_t kCountStretch = 65535;

// Pixels of `p` that are not 0 (the tree's) and that are `label`.
void countPixels(const std::vector<uint8_t>& p, uint8_t label, size_t& tree, size_t& labelled) {
    for (size_t start = 0; start < p.size(); start += kCountStretch) {
        const size_t end = std::min(p.size(), start + kCountStretch);
        uint16_t t = 0, l = 0;
        for (size_t k = start; k < end; ++k) {
            t += p[k] != 0;
            l += p[k] == label;
        }
        tree += t;
        labelled += l;
    }
}

}  // namespace

double silhouetteCoverage(const ViewImage& view) {
    if (view.silhouette.empty()) return 0.0;
    size_t tree = 0, background = 0;
    countPixels(view.silhouette, 0, tree, background);
    return static_cast<double>(tree) / view.silhouette.size();
}

Rgb labelColour(uint8_t label) {
    static constexpr Rgb kOrders[] = {
        {214, 120, 34}, {49, 116, 178}, {150, 75, 160}, {0, 158, 150}, {200, 60, 110}};
    if (label == kLabelBackground) return {255, 255, 255};
    if (label == kLabelLeaf) return {60, 170, 70};
    if (label == kLabelRoot) return {150, 30, 30};
    if (label == woodLabel(0)) return {92, 51, 23};
    return kOrders[(label - 2) % 5];
}

std::vector<uint8_t> colourLabels(const std::vector<uint8_t>& labels) {
    std::vector<uint8_t> rgb(3 * labels.size());
    for (size_t k = 0; k < labels.size(); ++k) {
        const Rgb c = labelColour(labels[k]);
        rgb[3 * k] = c.r;
        rgb[3 * k + 1] = c.g;
        rgb[3 * k + 2] = c.b;
    }
    return rgb;
}

double leafPixelFraction(const std::vector<ViewImage>& views) {
    static_assert(kLabelBackground == 0, "countPixels counts the non-zero pixels as the tree's");
    size_t leaf = 0, tree = 0;
    for (const ViewImage& v : views) countPixels(v.labels, kLabelLeaf, tree, leaf);
    return tree > 0 ? static_cast<double>(leaf) / static_cast<double>(tree)
                    : std::numeric_limits<double>::quiet_NaN();
}

double boxCountingDimension(const ViewImage& view) {
    const int w = view.width, h = view.height;
    if (w <= 0 || h <= 0 || view.silhouette.size() != static_cast<size_t>(w) * h) return 0.0;
    // Box sizes 2, 4, 8, … up to min(w, h)/4, at least three of them; boxes tile the image
    // from its top-left corner (partial boxes at the right and bottom edges count).
    std::vector<int> sizes;
    for (int s = 2; s <= std::min(w, h) / 4 || sizes.size() < 3; s *= 2) sizes.push_back(s);
    // A pyramid of occupancy maps: boxes of size 2 from the pixels, then each size from the
    // one below by OR-ing 2×2 boxes (ceil(ceil(w/s)/2) = ceil(w/2s), so partial boxes match).
    std::vector<double> lx, ly;
    int bw = (w + 1) / 2, bh = (h + 1) / 2;
    std::vector<uint8_t> hit(static_cast<size_t>(bw) * bh, 0);
    for (int y = 0; y < h; ++y) {
        const uint8_t* row = view.silhouette.data() + static_cast<size_t>(y) * w;
        uint8_t* hrow = hit.data() + static_cast<size_t>(y / 2) * bw;
        const int pairs = w / 2;  // pixel pairs, so the loop vectorises
        for (int i = 0; i < pairs; ++i) {
            hrow[i] |= static_cast<uint8_t>((row[2 * i] | row[2 * i + 1]) != 0);
        }
        if (w & 1) hrow[pairs] |= static_cast<uint8_t>(row[w - 1] != 0);
    }
    for (size_t level = 0; level < sizes.size(); ++level) {
        if (level > 0) {
            const int nw = (bw + 1) / 2, nh = (bh + 1) / 2;
            std::vector<uint8_t> next(static_cast<size_t>(nw) * nh, 0);
            for (int y = 0; y < bh; ++y) {
                const uint8_t* row = hit.data() + static_cast<size_t>(y) * bw;
                uint8_t* nrow = next.data() + static_cast<size_t>(y / 2) * nw;
                for (int i = 0; i < bw / 2; ++i) nrow[i] |= row[2 * i] | row[2 * i + 1];
                if (bw & 1) nrow[bw / 2] |= row[bw - 1];
            }
            hit.swap(next);
            bw = nw;
            bh = nh;
        }
        size_t count = 0;
        for (uint8_t v : hit) count += v;
        if (count == 0) return 0.0;  // empty image
        lx.push_back(std::log(1.0 / sizes[level]));
        ly.push_back(std::log(static_cast<double>(count)));
    }
    // Least-squares slope of log N against log 1/s.
    const double m = static_cast<double>(lx.size());
    double sx = 0, sy = 0;
    for (size_t i = 0; i < lx.size(); ++i) {
        sx += lx[i];
        sy += ly[i];
    }
    const double mx = sx / m, my = sy / m;
    double sxy = 0, sxx = 0;
    for (size_t i = 0; i < lx.size(); ++i) {
        sxy += (lx[i] - mx) * (ly[i] - my);
        sxx += (lx[i] - mx) * (lx[i] - mx);
    }
    return sxx > 0 ? sxy / sxx : 0.0;
}

}  // namespace sylva
