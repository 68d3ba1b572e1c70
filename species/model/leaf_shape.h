// Leaf shapes: each LeafShape is one fixed outline in the leaf card's own frame, triangulated
// once. A leaf's triangles are that outline placed on its card (size along the tangent,
// size·aspect across, facing the normal); the mesh (species/geometry/leaf_mesh.h) and the
// renderer (pipeline/render/render.h) both draw exactly these triangles, and the leaf area
// statistic is their area. Frame: +y up, metres.
//
// Card coordinates: x along the card's tangent from the base (−0.5, where the leaf attaches
// to its twig) to the tip (+0.5); y across it, from −0.5 to 0.5. A leaf maps (x, y) to
// position + tangent·(x·size) + across·(y·size·aspect), across = normal × tangent. Every
// outline lies inside that unit card and spans it: x from −0.5 to 0.5, max |y| = 0.5, so
// `size` stays the leaf's length and `aspect` its width / length.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/math.h"
#include "species/model/tree.h"

namespace sylva {

struct LeafOutline {
    // The vertices of every part, card coordinates.
    std::vector<Vec2> points;
    // Part k is points[parts[k] .. parts[k + 1]): a simple polygon, counter-clockwise; parts
    // do not overlap (they may touch). parts.size() = number of parts + 1.
    std::vector<uint32_t> parts;
    // Three indices into `points` per triangle, counter-clockwise (seen from the card's
    // normal); together they cover the parts exactly.
    std::vector<uint32_t> triangles;
    // Area of the parts (shoelace), in card units: the unit card is 1.
    double area = 0;
    // Width / length of the shape as drawn before fitting it to the card: the aspect that
    // keeps its natural proportions (1 for the card, which has none).
    double naturalAspect = 1;

    size_t triangleCount() const { return triangles.size() / 3; }
    size_t partCount() const { return parts.empty() ? 0 : parts.size() - 1; }
};

// Builds a shape's outline. `resolution` multiplies the number of points along every curved
// edge (1 = the shipped outline; tests raise it to check convergence to closed forms).
LeafOutline buildLeafOutline(LeafShape shape, int resolution = 1);

// The shipped outline of a shape, built once (thread-safe).
const LeafOutline& leafOutline(LeafShape shape);

// Every shape with its spec word ("card", "simple", …), in enum order.
const std::vector<std::pair<std::string, LeafShape>>& leafShapeWords();

// The leaf's orthonormal frame: unit normal, the tangent made perpendicular to it, and
// across = normal × tangent ((tangent, across, normal) right-handed).
struct LeafFrame {
    Vec3 normal, tangent, across;
};
LeafFrame leafFrame(const Leaf& leaf);

// Replaces `out` with the leaf's outline points in world space (metres), in outline order:
// position + tangent·(x·size) + across·(y·(size·aspect)).
void leafPoints(const Leaf& leaf, const LeafFrame& frame, const LeafOutline& outline,
                std::vector<Vec3>& out);

// One side's area of the leaf, m²: size² · aspect · outline area.
double leafArea(const Leaf& leaf);

// Ear clipping of one simple polygon (counter-clockwise, no repeated points, no three
// consecutive points collinear): n − 2 counter-clockwise triangles as indices into `polygon`.
// Of the ears at each step it clips the one with the shortest new diagonal (ties: the first
// in polygon order), which cuts blades into strips rather than fans of long slivers. Throws
// std::invalid_argument when it finds no ear (the polygon is not simple or not
// counter-clockwise).
std::vector<uint32_t> triangulatePolygon(const std::vector<Vec2>& polygon);

}  // namespace sylva
