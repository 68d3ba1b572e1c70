// Branch tubes: the skeleton decomposed into chains, each swept as a tapered generalised
// cylinder with rotation-minimising frames and closed at both ends.
// Frame: +y up, metres; u around the tube, v along it in units of the first circumference.
//
// Vertex layout of one chain (chains follow each other in the order they were found; tests
// and debugging tools rely on it):
//   rings      nRings × (sides + 1)  one ring per chain point, column 0 first, column `sides`
//                                    a copy of column 0 with u = 1 (the UV seam)
//   tip cone   (sides + 1) + sides   the last ring again with cone normals, then one apex
//                                    vertex per side (normal and u of that side's middle)
//   base disc  sides + 1             the first ring again with normal −tangent, then the centre
// Every chain is closed on its own (base disc and tip cone), so each is a closed manifold once
// coincident positions are merged; a child's base disc lies inside its parent tube.
#include "species/geometry/tube_mesh.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace sylva {

namespace {

// One branch chain: skeleton nodes in order. If `fromFork`, nodes[0] is the fork node on the
// parent chain: the first ring sits there with the radius of nodes[1] (no gap at the fork).
struct Chain {
    std::vector<int32_t> nodes;
    bool fromFork = false;
};

// The continuing child of node i: same branch order and part as i, lowest index; −1 if none.
int32_t continuingChild(const Tree& tree, const ChildIndex& children, int32_t i) {
    const SkeletonNode& node = tree.nodes[i];
    for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
        const int32_t c = children.child[k];  // ascending indices: the first match is lowest
        if (tree.nodes[c].order == node.order && tree.nodes[c].part == node.part) return c;
    }
    return -1;
}

// Chains in a deterministic order (breadth-first from the root chain). A chain dropped as too
// thin takes everything that branches off it along (no floating pieces).
std::vector<Chain> decompose(const Tree& tree, const TubeOptions& options) {
    std::vector<Chain> chains;
    if (tree.nodes.empty()) return chains;
    const ChildIndex children(tree);
    struct Start {
        int32_t fork;   // −1 for the root chain
        int32_t first;  // first node of the chain proper
    };
    std::vector<Start> queue{{-1, 0}};
    for (size_t q = 0; q < queue.size(); ++q) {
        const Start start = queue[q];
        Chain chain;
        chain.fromFork = start.fork >= 0;
        if (chain.fromFork) chain.nodes.push_back(start.fork);
        const bool dropped = options.dropThin && tree.nodes[start.first].radius < options.minRadius;
        for (int32_t i = start.first; i >= 0;) {
            chain.nodes.push_back(i);
            const int32_t next = continuingChild(tree, children, i);
            if (!dropped) {
                for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
                    if (children.child[k] != next) queue.push_back({i, children.child[k]});
                }
            }
            i = next;
        }
        if (!dropped && chain.nodes.size() >= 2) chains.push_back(std::move(chain));
    }
    return chains;
}

void putVec(std::vector<float>& out, const Vec3& v) {
    out.push_back(static_cast<float>(v.x));
    out.push_back(static_cast<float>(v.y));
    out.push_back(static_cast<float>(v.z));
}

// The sides of a chain's tube (from the radius it starts with), 0 when it has no surface.
int chainSides(const Tree& tree, const Chain& chain, const TubeOptions& options) {
    const SkeletonNode& firstNode = tree.nodes[chain.nodes[chain.fromFork ? 1 : 0]];
    const bool twig = firstNode.radius < options.minRadius;  // only reached when !dropThin
    const double rFirst =
        options.dropThin ? firstNode.radius : std::max(firstNode.radius, options.minRadius);
    if (!(rFirst > 0.0)) return 0;  // a tube of radius 0 has no surface
    const int minSides = std::max(3, options.minSides);
    const int maxSides = std::max(minSides, options.maxSides);
    if (twig) return minSides;
    if (options.edgeLength > 0.0) {
        const double ideal = std::round(2.0 * kPi * rFirst / options.edgeLength);
        return static_cast<int>(std::clamp(ideal, double(minSides), double(maxSides)));
    }
    return maxSides;
}

// Appends one chain's closed tube to `mesh` (see the layout at the top of the file).
void sweepChain(const Tree& tree, const Chain& chain, const TubeOptions& options, Mesh& mesh,
                std::vector<int32_t>* triangleNodes) {
    const size_t n = chain.nodes.size();
    const SkeletonNode& firstNode = tree.nodes[chain.nodes[chain.fromFork ? 1 : 0]];

    // Points, drawn radii (thickened to minRadius unless thin branches are dropped).
    std::vector<Vec3> x(n);
    std::vector<double> r(n);
    for (size_t k = 0; k < n; ++k) {
        const SkeletonNode& node = tree.nodes[chain.nodes[k]];
        x[k] = node.position;
        r[k] = node.radius;
    }
    if (chain.fromFork) r[0] = r[1];
    if (!options.dropThin) {
        for (double& rk : r) rk = std::max(rk, options.minRadius);
    }
    const double rFirst = r[0];
    const int sides = chainSides(tree, chain, options);
    if (sides == 0) return;

    // Unit segment directions; zero-length segments borrow a neighbour's direction.
    std::vector<Vec3> dir(n - 1);
    std::vector<double> s(n, 0.0);  // arc length along the chain, metres
    int lastValid = -1;
    for (size_t k = 0; k + 1 < n; ++k) {
        const Vec3 d = x[k + 1] - x[k];
        const double len = length(d);
        s[k + 1] = s[k] + len;
        if (len > 1e-12) {
            dir[k] = d / len;
            if (lastValid < 0) {
                for (size_t j = 0; j < k; ++j) dir[j] = dir[k];
            }
            lastValid = static_cast<int>(k);
        } else if (lastValid >= 0) {
            dir[k] = dir[lastValid];
        } else {
            dir[k] = Vec3{0, firstNode.part == kRootPart ? -1.0 : 1.0, 0};  // until one is valid
        }
    }

    // Tangents: segment direction at the ends, normalised sum of both neighbours inside.
    std::vector<Vec3> t(n);
    t[0] = dir[0];
    t[n - 1] = dir[n - 2];
    for (size_t k = 1; k + 1 < n; ++k) {
        const Vec3 sum = dir[k - 1] + dir[k];
        t[k] = length2(sum) > 1e-12 ? normalize(sum) : dir[k];
    }

    // Rotation-minimising reference vectors by the double-reflection method: Wang, Jüttler,
    // Zheng & Liu 2008, "Computation of rotation minimizing frames", ACM TOG 27(1), Sec. 4
    // (Algorithm "double reflection"). Reflect frame i in the bisector plane of x_i x_{i+1}
    // (R1), then in the plane that maps the reflected tangent onto t_{i+1} (R2).
    std::vector<Vec3> ref(n);
    ref[0] =
        Frame::alignY(t[0]).u;  // varies continuously with the axis: similar twigs, similar seams
    for (size_t k = 0; k + 1 < n; ++k) {
        Vec3 rL = ref[k], tL = t[k];
        const Vec3 v1 = x[k + 1] - x[k];
        const double c1 = dot(v1, v1);
        if (c1 > 1e-24) {
            rL = ref[k] - v1 * (2.0 / c1 * dot(v1, ref[k]));
            tL = t[k] - v1 * (2.0 / c1 * dot(v1, t[k]));
        }
        const Vec3 v2 = t[k + 1] - tL;
        const double c2 = dot(v2, v2);
        Vec3 next = c2 > 1e-24 ? rL - v2 * (2.0 / c2 * dot(v2, rL)) : rL;
        // Keep it exactly perpendicular and unit despite rounding (and degenerate steps).
        next = next - t[k + 1] * dot(next, t[k + 1]);
        ref[k + 1] = length2(next) > 1e-24 ? normalize(next) : anyPerpendicular(t[k + 1]);
    }

    // dr/ds per point (central differences inside), for taper-corrected normals.
    auto slope = [&](size_t a, size_t b) {
        const double ds = s[b] - s[a];
        return ds > 1e-12 ? (r[b] - r[a]) / ds : 0.0;
    };

    std::vector<double> cosT(sides), sinT(sides);
    for (int j = 0; j < sides; ++j) {
        const double theta = 2.0 * kPi * j / sides;
        cosT[j] = std::cos(theta);
        sinT[j] = std::sin(theta);
    }

    const uint32_t base = static_cast<uint32_t>(mesh.vertexCount());
    const uint32_t ringSize = static_cast<uint32_t>(sides + 1);
    const double vScale = 1.0 / (2.0 * kPi * rFirst);
    const int32_t order = firstNode.order;
    auto vertex = [&](const float* p, const Vec3& normal, double u, double v) {
        mesh.positions.insert(mesh.positions.end(), p, p + 3);
        putVec(mesh.normals, normalize(normal));
        mesh.uvs.push_back(static_cast<float>(u));
        mesh.uvs.push_back(static_cast<float>(v));
        mesh.order.push_back(order);
        mesh.colour.push_back(0);
    };
    auto triangle = [&](uint32_t a, uint32_t b, uint32_t c) {
        mesh.indices.insert(mesh.indices.end(), {a, b, c});
    };

    // Ring positions are computed once (as floats) and reused by the seam column, the tip cone
    // and the base disc, so coincident vertices are bit-identical and the tube closes exactly.
    std::vector<float> ringPos(3 * sides);
    std::vector<float> firstRing, lastRing;
    std::vector<Vec3> radial(sides);
    auto makeRing = [&](size_t k) {
        const Vec3 b = cross(t[k], ref[k]);  // (ref, b, t) right-handed: θ turns about t
        for (int j = 0; j < sides; ++j) {
            radial[j] = ref[k] * cosT[j] + b * sinT[j];
            const Vec3 p = x[k] + radial[j] * r[k];
            ringPos[3 * j] = static_cast<float>(p.x);
            ringPos[3 * j + 1] = static_cast<float>(p.y);
            ringPos[3 * j + 2] = static_cast<float>(p.z);
        }
    };

    for (size_t k = 0; k < n; ++k) {
        makeRing(k);
        const double drds =
            k == 0 ? slope(0, 1) : (k + 1 == n ? slope(n - 2, n - 1) : slope(k - 1, k + 1));
        const double v = s[k] * vScale;
        for (int j = 0; j <= sides; ++j) {
            const int jj = j == sides ? 0 : j;
            // Surface normal of a cone whose radius changes by dr/ds along t.
            vertex(&ringPos[3 * jj], radial[jj] - t[k] * drds, double(j) / sides, v);
        }
        if (k == 0) firstRing = ringPos;
        if (k + 1 == n) lastRing = ringPos;
    }
    // The node ending each triangle's segment (see triangleNodes in the header).
    auto noteNode = [&](int32_t node, size_t triangles) {
        if (triangleNodes) triangleNodes->insert(triangleNodes->end(), triangles, node);
    };
    for (size_t k = 0; k + 1 < n; ++k) {
        noteNode(chain.nodes[k + 1], 2 * static_cast<size_t>(sides));
        const uint32_t lo = base + static_cast<uint32_t>(k) * ringSize, hi = lo + ringSize;
        for (uint32_t j = 0; j < static_cast<uint32_t>(sides); ++j) {
            triangle(lo + j, lo + j + 1, hi + j + 1);  // counter-clockwise seen from outside
            triangle(lo + j, hi + j + 1, hi + j);
        }
    }

    // Tip cone to an apex one tip radius beyond the last point. Cone of base radius rt and
    // height h: outward normal ∝ h·radial + rt·t.
    {
        const size_t k = n - 1;
        const double rt = r[k], h = rt;
        const Vec3 apex = x[k] + t[k] * h;
        const float apexF[3] = {static_cast<float>(apex.x), static_cast<float>(apex.y),
                                static_cast<float>(apex.z)};
        const Vec3 b = cross(t[k], ref[k]);
        auto coneNormal = [&](double c, double sn) {
            const Vec3 n0 = (ref[k] * c + b * sn) * h + t[k] * rt;
            return length2(n0) > 0 ? n0 : t[k];
        };
        const uint32_t ring = static_cast<uint32_t>(mesh.vertexCount());
        const double v = s[k] * vScale;
        for (int j = 0; j <= sides; ++j) {
            const int jj = j == sides ? 0 : j;
            vertex(&lastRing[3 * jj], coneNormal(cosT[jj], sinT[jj]), double(j) / sides, v);
        }
        const uint32_t apexes = static_cast<uint32_t>(mesh.vertexCount());
        for (int j = 0; j < sides; ++j) {
            const double mid = 2.0 * kPi * (j + 0.5) / sides;
            vertex(apexF, coneNormal(std::cos(mid), std::sin(mid)), (j + 0.5) / sides,
                   (s[k] + h) * vScale);
        }
        noteNode(chain.nodes[n - 1], static_cast<size_t>(sides));
        for (uint32_t j = 0; j < static_cast<uint32_t>(sides); ++j) {
            triangle(ring + j, ring + j + 1, apexes + j);
        }
    }

    // Base disc: a flat fan facing −t at the first point (planar UVs).
    {
        const uint32_t rim = static_cast<uint32_t>(mesh.vertexCount());
        for (int j = 0; j < sides; ++j) {
            vertex(&firstRing[3 * j], -t[0], 0.5 + 0.5 * cosT[j], 0.5 + 0.5 * sinT[j]);
        }
        const float centre[3] = {static_cast<float>(x[0].x), static_cast<float>(x[0].y),
                                 static_cast<float>(x[0].z)};
        const uint32_t c = static_cast<uint32_t>(mesh.vertexCount());
        vertex(centre, -t[0], 0.5, 0.5);
        noteNode(chain.nodes[1], static_cast<size_t>(sides));
        for (uint32_t j = 0; j < static_cast<uint32_t>(sides); ++j) {
            const uint32_t j1 = (j + 1) % static_cast<uint32_t>(sides);
            triangle(c, rim + j1, rim + j);
        }
    }
}

}  // namespace

int64_t tubeTriangleCount(const Tree& tree, const TubeOptions& options) {
    int64_t triangles = 0;
    for (const Chain& chain : decompose(tree, options)) {
        // Rings: 2 per side and segment; tip cone and base disc: 1 per side each.
        triangles += 2 * static_cast<int64_t>(chainSides(tree, chain, options)) *
                     static_cast<int64_t>(chain.nodes.size());
    }
    return triangles;
}

Mesh tubeMesh(const Tree& tree, const TubeOptions& options, std::vector<int32_t>* triangleNodes) {
    Mesh mesh;
    if (triangleNodes) triangleNodes->clear();
    for (const Chain& chain : decompose(tree, options)) {
        sweepChain(tree, chain, options, mesh, triangleNodes);
    }
    return mesh;
}

}  // namespace sylva
