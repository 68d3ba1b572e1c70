// The zero level set of a level-set grid as a triangle mesh (shared by the watertight tree
// mesh and `sylva volume`); its OpenVDB call is the module of volumes/vdb_module.h.
#pragma once

#include "species/geometry/mesh.h"
#include "volumes/vdb_module.h"

namespace sylva {

// openvdb::tools::volumeToMesh (isovalue 0, adaptivity 0), every polygon reversed so
// triangles are counter-clockwise seen from outside (volumeToMesh winds them clockwise,
// checked by the signed volume of a sphere in the tests), quads split along their 0–2
// diagonal; area-weighted vertex normals summed in triangle order (deterministic). Only
// positions, normals and indices are filled.
Mesh levelSetMesh(const VdbGrid& grid);

}  // namespace sylva
