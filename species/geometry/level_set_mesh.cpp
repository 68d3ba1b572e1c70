#include "species/geometry/level_set_mesh.h"

#include <utility>
#include <vector>

#include "core/math.h"

namespace sylva {

Mesh levelSetMesh(const VdbGrid& grid) {
    std::vector<float> points;
    std::vector<uint32_t> triangles, quads;
    vdbModule().volumeToMesh(grid, points, triangles, quads);

    Mesh mesh;
    mesh.indices.reserve(triangles.size() + 6 * (quads.size() / 4));
    for (size_t i = 0; i < quads.size(); i += 4) {
        const uint32_t* q = &quads[i];
        const uint32_t t[6] = {q[0], q[2], q[1], q[0], q[3], q[2]};
        mesh.indices.insert(mesh.indices.end(), t, t + 6);
    }
    for (size_t i = 0; i < triangles.size(); i += 3) {
        const uint32_t r[3] = {triangles[i], triangles[i + 2], triangles[i + 1]};
        mesh.indices.insert(mesh.indices.end(), r, r + 3);
    }
    const size_t nv = points.size() / 3;
    mesh.positions = std::move(points);
    const std::vector<float>& p = mesh.positions;

    std::vector<double> acc(3 * nv, 0.0);
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
        const Vec3 p0{p[3 * i0], p[3 * i0 + 1], p[3 * i0 + 2]};
        const Vec3 p1{p[3 * i1], p[3 * i1 + 1], p[3 * i1 + 2]};
        const Vec3 p2{p[3 * i2], p[3 * i2 + 1], p[3 * i2 + 2]};
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
