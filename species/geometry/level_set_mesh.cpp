#include "species/geometry/level_set_mesh.h"

#include <openvdb/tools/VolumeToMesh.h>

#include <vector>

#include "core/math.h"

namespace sylva {

Mesh levelSetMesh(const openvdb::FloatGrid& grid) {
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(grid, points, triangles, quads, 0.0, 0.0);

    Mesh mesh;
    mesh.indices.reserve(3 * (triangles.size() + 2 * quads.size()));
    for (const auto& q : quads) {
        const uint32_t t[6] = {q[0], q[2], q[1], q[0], q[3], q[2]};
        mesh.indices.insert(mesh.indices.end(), t, t + 6);
    }
    for (const auto& t : triangles) {
        const uint32_t r[3] = {t[0], t[2], t[1]};
        mesh.indices.insert(mesh.indices.end(), r, r + 3);
    }
    const size_t nv = points.size();
    mesh.positions.resize(3 * nv);
    for (size_t v = 0; v < nv; ++v)
        for (int a = 0; a < 3; ++a) mesh.positions[3 * v + a] = points[v][a];

    std::vector<double> acc(3 * nv, 0.0);
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
        const Vec3 p0{points[i0][0], points[i0][1], points[i0][2]};
        const Vec3 p1{points[i1][0], points[i1][1], points[i1][2]};
        const Vec3 p2{points[i2][0], points[i2][1], points[i2][2]};
        const Vec3 n = cross(p1 - p0, p2 - p0);
        for (uint32_t i : {i0, i1, i2})
            for (int a = 0; a < 3; ++a) acc[3 * i + a] += n[a];
    }
    mesh.normals.resize(3 * nv);
    for (size_t v = 0; v < nv; ++v) {
        const Vec3 n = normalize({acc[3 * v], acc[3 * v + 1], acc[3 * v + 2]});
        for (int a = 0; a < 3; ++a) mesh.normals[3 * v + a] = static_cast<float>(n[a]);
    }
    return mesh;
}

}  // namespace sylva
