// Leaf cards: one double-sided quad per leaf. Frame: +y up, metres.
//
// Per leaf, 8 vertices and 4 triangles: vertices 0–3 are the front face (normal +leaf.normal),
// 4–7 the back face (same positions, normal −leaf.normal), each face two triangles wound
// counter-clockwise seen from its own side. Separate vertices per side keep the normals right
// for renderers that cull back faces or light per side. Corners in card coordinates
// (along the tangent, across it), UVs alike: (0,0), (1,0), (1,1), (0,1).
#include "species/geometry/leaf_mesh.h"

#include <cmath>
#include <cstdint>

namespace sylva {

Mesh leafMesh(const Tree& tree) {
    Mesh mesh;
    const size_t n = tree.leaves.size();
    mesh.positions.reserve(n * 8 * 3);
    mesh.normals.reserve(n * 8 * 3);
    mesh.uvs.reserve(n * 8 * 2);
    mesh.order.reserve(n * 8);
    mesh.colour.reserve(n * 8);
    mesh.indices.reserve(n * 12);

    static constexpr double kCorner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (const Leaf& leaf : tree.leaves) {
        // Orthonormalise defensively: the card must stay flat and rectangular.
        const Vec3 normal = normalize(leaf.normal);
        Vec3 tangent = leaf.tangent - normal * dot(leaf.tangent, normal);
        tangent = length2(tangent) > 1e-24 ? normalize(tangent) : anyPerpendicular(normal);
        const Vec3 across = cross(normal, tangent);  // (tangent, across, normal) right-handed
        const double length = leaf.size, width = leaf.size * leaf.aspect;

        const uint32_t first = static_cast<uint32_t>(mesh.vertexCount());
        for (int side = 0; side < 2; ++side) {
            const Vec3 nrm = side == 0 ? normal : -normal;
            for (const auto& c : kCorner) {
                const Vec3 p = leaf.position + tangent * ((c[0] - 0.5) * length) +
                               across * ((c[1] - 0.5) * width);
                for (double v : {p.x, p.y, p.z}) mesh.positions.push_back(static_cast<float>(v));
                for (double v : {nrm.x, nrm.y, nrm.z}) {
                    mesh.normals.push_back(static_cast<float>(v));
                }
                mesh.uvs.push_back(static_cast<float>(c[0]));
                mesh.uvs.push_back(static_cast<float>(c[1]));
                mesh.order.push_back(-1);
                mesh.colour.push_back(leaf.colour);
            }
        }
        const uint32_t f = first, b = first + 4;
        mesh.indices.insert(mesh.indices.end(), {f, f + 1, f + 2, f, f + 2, f + 3});  // front
        mesh.indices.insert(mesh.indices.end(), {b, b + 2, b + 1, b, b + 3, b + 2});  // back
    }
    return mesh;
}

}  // namespace sylva
