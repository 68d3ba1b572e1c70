// A GLB made compact: positions and normals quantised (KHR_mesh_quantization) and every vertex
// and index buffer view compressed with meshoptimizer's codecs (EXT_meshopt_compression), as
// three.js's GLTFLoader (with its MeshoptDecoder), Babylon.js, gltfpack and Blender 3.1+ read
// them. Both extensions are required: a reader without them refuses the file instead of
// drawing garbage.
//
//   std::string small = compressGlbMeshopt(meshGlb(mesh, look), &report);
//
// What changes, for a GLB as meshGlb writes it (each accessor its own tightly packed buffer
// view, no sparse accessors, nodes without transforms):
//   POSITION  SHORT (−32767 … 32767, 4 per vertex, the 4th 0), one grid for the whole file:
//             every node that holds a mesh gets translation t and uniform scale s, so
//             p = t + s·q; t is the centre of the positions' bounds and s half their largest
//             extent / 32767, so a coordinate is off by at most s / 2 (report.positionError).
//   NORMAL    BYTE normalised (round(127·n), 4 per vertex): off by at most 1/254 per component.
//   COLOR_0   UNSIGNED_BYTE normalised (round(255·c), 4 per vertex): off by at most 1/510.
//   TEXCOORD_0  where every value lies in [0, 1] (the leaves' outline UVs) UNSIGNED_SHORT
//             normalised (round(65535·u), off by at most 1/131070); else (the tubes' UVs, which
//             run along a branch past 1) floats as they were.
//   the rest  (_ORDER, _COLOUR) as they were, floats.
//   indices   UNSIGNED_INT, meshoptimizer's triangle codec (version 1): the same triangles in
//             the same order, each possibly rotated (a, b, c → b, c, a; the winding kept).
// GPU instances (EXT_mesh_gpu_instancing: meshGlb's instanced leaves): the instanced mesh's
// POSITION stays float (its own small frame, off the grid) and its node takes the grid's
// translation only; the instances' TRANSLATION (then relative to that centre) and SCALE go
// through meshoptimizer's exponential filter (a 16-bit mantissa under each translation's
// largest coordinate, a 12-bit one under each scale's: report.positionError includes the
// translations' largest error), ROTATION through its quaternion filter (SHORT normalised,
// 12 bits a component, ≈ 0.03°); _COLOR_0 through the exponential filter too (10 bits,
// ≤ 0.1 % of the lightness); other instance attributes (_LEAF) stay floats.
// Buffer 0 (the BIN chunk) holds the compressed views and any image (the bark texture: already
// PNG, kept as it is); buffer 1 is EXT_meshopt_compression's fallback buffer — no bytes, only
// its length, the decoded views' home.
//
// compressGlbDraco: the same file with every mesh that is not drawn as instances compressed by
// Draco (KHR_draco_mesh_compression, Google's Draco as three.js's DRACOLoader, Blender, Babylon.js
// and glTF Transform decode it), about 0.4 of meshoptimizer's bytes for a tree's tubes:
// Draco codes the connectivity with Edgebreaker and predicts each vertex from its neighbours
// (parallelogram prediction). Its accessors keep their glTF types (floats) and take the
// decoded counts (Draco may split a vertex where the surface is not a manifold) and the decoded
// positions' bounds; they have no buffer view. Quantisation inside the Draco data:
//   POSITION  one grid for the file: 16 bits over the positions' largest extent, so a
//             coordinate is off by at most half its step (report.positionError);
//   NORMAL    8 bits, octahedral (about 1° at most: half a cell's diagonal seen head-on on an
//             octahedron face is 0.96°); COLOR_0 8 bits;
//   TEXCOORD_0  at least 12 bits and at least 512 steps a unit (a texture's repeat) over the
//             coordinates' range: off by at most 1/1024;
//   _ORDER, _COLOUR  whole numbers, so integers (UNSIGNED_BYTE, or SHORT past 255), exact.
// The vertices and triangles come in Draco's order, not meshGlb's. Nodes keep no transform.
// The GPU instances and their leaf cards go through meshoptimizer as above (then the file uses
// EXT_meshopt_compression and KHR_mesh_quantization as well); without instances it uses
// KHR_draco_mesh_compression alone, required.
#pragma once

#include <cstdint>
#include <string>

#include "pipeline/formats/mesh_writers.h"

namespace sylva {

struct GlbCompression {
    uint64_t bytesBefore = 0, bytesAfter = 0;
    double positionError = 0.0;  // metres: the largest error of a coordinate, s / 2
};

// Throws std::invalid_argument for a GLB it cannot take (not GLB 2.0, sparse or shared
// accessors, a node with a transform of its own).
std::string compressGlbMeshopt(const std::string& glb, GlbCompression* report = nullptr);

// The same from meshGlb's parts (mesh_writers.h meshGlbParts), without writing the plain file
// and reading it back: the same bytes as compressGlbMeshopt(glbFromParts(parts)).
std::string compressGlbMeshopt(const GlbParts& parts, GlbCompression* report = nullptr);

// Draco for the meshes, meshoptimizer for GPU instances (above); refuses what
// compressGlbMeshopt refuses, and primitives that are not indexed triangle lists.
std::string compressGlbDraco(const std::string& glb, GlbCompression* report = nullptr);
std::string compressGlbDraco(const GlbParts& parts, GlbCompression* report = nullptr);

}  // namespace sylva
