// The ground of a plot: heightfields made from the spec's terrain options, and its mesh.
#pragma once

#include "core/rng.h"
#include "species/geometry/mesh.h"
#include "species/plot/plot.h"

namespace sylva {

// The terrain mesh: two triangles per heightfield cell, counter-clockwise seen from above
// (normals +y side), every vertex with order −1 and colour 0.
Mesh terrainMesh(const Terrain& terrain);

}  // namespace sylva
