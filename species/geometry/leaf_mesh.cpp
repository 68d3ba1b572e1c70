// Leaves as double-sided outlines. Frame: +y up, metres.
//
// Per leaf with an outline of n points and t triangles: 2n vertices and 2t triangles.
// Vertices 0 … n−1 are the front face (normal +leaf.normal), n … 2n−1 the back face (same
// positions, normal −leaf.normal); each face's triangles are wound counter-clockwise seen from
// its own side. Separate vertices per side keep the normals right for renderers that cull back
// faces or light per side. UVs are card coordinates shifted to [0, 1]² (x + 0.5, y + 0.5),
// so the card's corners are (0,0), (1,0), (1,1), (0,1) as they always were.
#include "species/geometry/leaf_mesh.h"

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "species/model/leaf_shape.h"

namespace sylva {

LeafMeshSize leafMeshSize(const std::vector<Leaf>& leaves) {
    LeafMeshSize size;
    for (const Leaf& leaf : leaves) {
        const LeafOutline& o = leafOutline(leaf.shape);
        size.vertices += 2 * o.points.size();
        size.triangles += 2 * o.triangleCount();
    }
    return size;
}

Mesh leafMesh(const Tree& tree) {
    Mesh mesh;
    const LeafMeshSize size = leafMeshSize(tree.leaves);
    const size_t nv = size.vertices, ni = 3 * size.triangles;
    mesh.positions.reserve(nv * 3);
    mesh.normals.reserve(nv * 3);
    mesh.uvs.reserve(nv * 2);
    mesh.order.reserve(nv);
    mesh.colour.reserve(nv);
    mesh.indices.reserve(ni);

    std::vector<Vec3> points;
    for (const Leaf& leaf : tree.leaves) {
        const LeafOutline& outline = leafOutline(leaf.shape);
        const LeafFrame frame = leafFrame(leaf);
        leafPoints(leaf, frame, outline, points);
        const uint32_t n = static_cast<uint32_t>(points.size());
        const uint32_t first = static_cast<uint32_t>(mesh.vertexCount());
        for (int side = 0; side < 2; ++side) {
            const Vec3 nrm = side == 0 ? frame.normal : -frame.normal;
            for (uint32_t i = 0; i < n; ++i) {
                const Vec3& p = points[i];
                for (double v : {p.x, p.y, p.z}) mesh.positions.push_back(static_cast<float>(v));
                for (double v : {nrm.x, nrm.y, nrm.z}) {
                    mesh.normals.push_back(static_cast<float>(v));
                }
                mesh.uvs.push_back(static_cast<float>(outline.points[i].x + 0.5));
                mesh.uvs.push_back(static_cast<float>(outline.points[i].y + 0.5));
                mesh.order.push_back(-1);
                mesh.colour.push_back(leaf.colour);
            }
        }
        const uint32_t f = first, b = first + n;
        const std::vector<uint32_t>& tri = outline.triangles;
        for (size_t k = 0; k < tri.size(); k += 3) {  // front
            mesh.indices.insert(mesh.indices.end(), {f + tri[k], f + tri[k + 1], f + tri[k + 2]});
        }
        for (size_t k = 0; k < tri.size(); k += 3) {  // back: reversed
            mesh.indices.insert(mesh.indices.end(), {b + tri[k], b + tri[k + 2], b + tri[k + 1]});
        }
    }
    return mesh;
}

std::vector<LeafSpan> leafSpans(const Mesh& leaves) {
    const size_t n = leaves.vertexCount();
    if (n > 0 && leaves.normals.size() != 3 * n) {
        throw std::invalid_argument("leafSpans: the leaf mesh has no normals");
    }
    // Bitwise comparisons: a leaf's vertices hold copies of one normal (NaN alike).
    auto sameNormal = [&](size_t i, size_t j, bool negated) {
        for (int c = 0; c < 3; ++c) {
            const float a = leaves.normals[3 * i + c];
            const float b = negated ? -leaves.normals[3 * j + c] : leaves.normals[3 * j + c];
            if (std::memcmp(&a, &b, sizeof a) != 0) return false;
        }
        return true;
    };
    auto samePosition = [&](size_t i, size_t j) {
        return std::memcmp(&leaves.positions[3 * i], &leaves.positions[3 * j], 3 * sizeof(float)) ==
               0;
    };
    std::vector<LeafSpan> spans;
    for (size_t first = 0; first < n;) {
        size_t count = 1;  // the front face: the run of vertices sharing the first one's normal
        while (first + count < n && sameNormal(first + count, first, false)) ++count;
        if (first + 2 * count > n) {
            throw std::invalid_argument("leafSpans: the leaf at vertex " + std::to_string(first) +
                                        " has no back face");
        }
        for (size_t i = first; i < first + count; ++i) {
            if (!sameNormal(i + count, first, true) || !samePosition(i + count, i)) {
                throw std::invalid_argument("leafSpans: vertex " + std::to_string(i + count) +
                                            " does not mirror the front face's vertex " +
                                            std::to_string(i));
            }
        }
        spans.push_back({static_cast<uint32_t>(first), static_cast<uint32_t>(count)});
        first += 2 * count;
    }
    return spans;
}

}  // namespace sylva
