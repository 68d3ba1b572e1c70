// Branch tubes: the skeleton swept as tapered generalised cylinders. Frame: +y up, metres.
#pragma once

#include <cstdint>
#include <vector>

#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

// Level of detail for branch tubes.
struct TubeOptions {
    int minSides = 3;          // sides of the thinnest tube
    int maxSides = 16;         // sides of the thickest tube
    double edgeLength = 0.03;  // target length of a ring edge, metres: sides ≈ 2πr / edge
    double minRadius = 0.0;    // branches thinner than this (metres) are ...
    bool dropThin = false;     // ... dropped (true) or drawn as minSides tubes of minRadius
};

// Every branch chain (fork to tip) swept as one tapered generalised cylinder along the
// skeleton with rotation-minimising frames (double reflection, Wang et al. 2008); child
// tubes start at the fork node, inside their parent, so forks have no gaps; tips and the
// root base are closed. Per-vertex normals, bark UVs (u around, v along in units of the
// circumference) and branch order. With `triangleNodes`, also per triangle the skeleton node
// ending the segment it sweeps (tip cone: the tip; base disc: the end of the chain's first
// segment), so a renderer can label the tubes as the skeleton (root or shoot, branch order).
Mesh tubeMesh(const Tree& tree, const TubeOptions& options,
              std::vector<int32_t>* triangleNodes = nullptr);

// The number of triangles tubeMesh makes, counted without making them (to hold a mesh to a
// budget before it is built).
int64_t tubeTriangleCount(const Tree& tree, const TubeOptions& options);

}  // namespace sylva
