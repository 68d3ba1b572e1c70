// The zero level set of an OpenVDB grid as a triangle mesh (shared by the watertight tree
// mesh and `sylva volume`). Includes OpenVDB: include it only from .cpp files that link it.
#pragma once

#include <openvdb/openvdb.h>

#include "species/geometry/mesh.h"

namespace sylva {

// openvdb::tools::volumeToMesh (isovalue 0, adaptivity 0), every polygon reversed so
// triangles are counter-clockwise seen from outside (volumeToMesh winds them clockwise,
// checked by the signed volume of a sphere in the tests), quads split along their 0–2
// diagonal; area-weighted vertex normals summed in triangle order (deterministic). Only
// positions, normals and indices are filled.
Mesh levelSetMesh(const openvdb::FloatGrid& grid);

}  // namespace sylva
