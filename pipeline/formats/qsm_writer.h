// QSM ground truth: a tree's skeleton as the cylinder table of a quantitative structure model,
// laid out as TreeQSM (InverseTampere/TreeQSM, src/main_steps/cylinders.m and
// src/tools/save_model_text.m) writes it, so QSM reconstructions of sylva's scans can be scored
// against the true tree. Columns and their mapping: docs/scanning.md, "QSM ground truth".
//
// One cylinder per skeleton segment (no merging along straight runs: the table is the
// skeleton exactly, and each cylinder maps to the skeleton node whose wood a LAS point's
// node_id names). Branches are the tube mesh's chains (species/geometry/tube_mesh.cpp): from a
// fork, the child of the same branch order and part, lowest index, continues the branch (the
// parent cylinder's `extension`); every other child starts a new branch. Shoot only: the root
// system (part kRootPart) is left out, as a scan of the ground cannot see it. The mesh's level
// of detail (TubeOptions::minRadius, dropThin) does not apply: every segment is a cylinder.
//
// Frame: TreeQSM's, z up: (x, y, z) of the tree's frame (+y up; a plot tree's plot-local
// metres) become (x, −z, y) — the survey frame of the scan's LAS files, so cylinders and
// points line up.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/math.h"
#include "species/model/tree.h"

namespace sylva {

struct QsmCylinder {
    double radius = 0;             // metres: the frustum's volume-equivalent radius (below)
    double length = 0;             // metres, > 0
    Vec3 start;                    // metres, z up: the segment's parent-end node
    Vec3 axis;                     // unit, z up: start → end
    int32_t parent = 0;            // 1-based index of the parent cylinder; 0 = none (the stem base)
    int32_t extension = 0;         // 1-based index of the cylinder continuing the branch; 0 = none
    int32_t branch = 0;            // 1-based branch index (1 = the stem)
    int32_t branchOrder = 0;       // the branch's skeleton order (0 = stem)
    int32_t positionInBranch = 0;  // 1-based, from the branch's base
    int32_t node = -1;             // the skeleton node ending the segment (LAS node_id)
};

// The cylinders, in TreeQSM's order: branch by branch (breadth-first from the stem, so a
// parent's index is always lower than its children's), each branch's cylinders base to tip.
// A segment's radius tapers linearly from r0 to r1 (r0 = the parent node's radius, or at a
// fork the branch's first node's radius, as the tube mesh draws it); the cylinder has the
// frustum's volume: r = √((r0² + r0·r1 + r1²) / 3), so Σ π r² length is the wood volume of the
// tube mesh without its tip cones. Zero-length segments give no cylinder (their children hang
// on the cylinder below). A tree without shoot segments gives an empty table.
std::vector<QsmCylinder> qsmCylinders(const Tree& tree);

// CSV (RFC 4180, "\n" line ends), a header row then one row per cylinder:
//   radius,length,start_x,start_y,start_z,axis_x,axis_y,axis_z,parent,extension,branch,
//   BranchOrder,PositionInBranch,added,UnmodRadius,node_id
// lengths in metres with 6 decimals, axis components with 6; added 0 and UnmodRadius =
// radius (TreeQSM's gap-filling flag and its radius before corrections: the truth has
// neither). TreeQSM's fit-quality columns mad and SurfCov are left out: they measure points
// against a fitted cylinder, and there are no points here.
std::string qsmCylinderCsv(const std::vector<QsmCylinder>& cylinders);

// The text file TreeQSM's save_model_text.m writes (cylinder_<name>.txt): tab-separated, its 13
// header names (start_point and axis_direction name 3 columns each, 17 in all), values rounded
// to 4 decimals and printed as MATLAB's %g; mad and SurfCov NaN (not measured, see above).
std::string qsmCylinderTreeQsmTxt(const std::vector<QsmCylinder>& cylinders);

// Writes qsmCylinderCsv(qsmCylinders(tree)) to `csvPath` and, unless `txtPath` is empty, the
// TreeQSM text layout to `txtPath`; atomically.
void writeQsmCylinders(const std::filesystem::path& csvPath, const Tree& tree,
                       const std::filesystem::path& txtPath = {});

}  // namespace sylva
