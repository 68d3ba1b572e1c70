#include "pipeline/formats/qsm_writer.h"

#include <cmath>
#include <cstdio>

#include "core/atomic_file.h"
#include "core/params.h"

namespace sylva {

namespace {

// TreeQSM's frame (z up) from the tree's (+y up); the same map as the scan's survey frame.
Vec3 zUp(const Vec3& p) { return {p.x, -p.z, p.y}; }

// The continuing child of node i (as the tube mesh, species/geometry/tube_mesh.cpp): same
// branch order and part, lowest index; −1 if none.
int32_t continuingChild(const Tree& tree, const ChildIndex& children, int32_t i) {
    const SkeletonNode& node = tree.nodes[i];
    for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
        const int32_t c = children.child[k];
        if (tree.nodes[c].order == node.order && tree.nodes[c].part == node.part) return c;
    }
    return -1;
}

// save_model_text.m: round(10000 * v) / 10000 printed with %g (MATLAB's fprintf is C's).
std::string matlabG(double v) {
    if (std::isnan(v)) return "NaN";
    double r = std::round(10000 * v) / 10000;
    if (r == 0) r = 0;  // no "-0"
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", r);
    return buf;
}

}  // namespace

std::vector<QsmCylinder> qsmCylinders(const Tree& tree) {
    std::vector<QsmCylinder> out;
    if (tree.nodes.empty() || tree.nodes[0].part != kShootPart) return out;
    const ChildIndex children(tree);
    struct Start {
        int32_t fork;   // −1 for the stem
        int32_t first;  // first node of the branch proper
    };
    std::vector<Start> queue{{-1, 0}};
    // The 1-based cylinder ending at each node (0: none, at the root or below a zero-length
    // segment at the stem base).
    std::vector<int32_t> cylinderAt(tree.nodes.size(), 0);
    int32_t branches = 0;
    for (size_t q = 0; q < queue.size(); ++q) {
        const Start start = queue[q];
        if (start.fork >= 0 && tree.nodes[start.first].part == kRootPart) continue;
        std::vector<int32_t> chain;
        if (start.fork >= 0) chain.push_back(start.fork);
        for (int32_t i = start.first; i >= 0;) {
            chain.push_back(i);
            const int32_t next = continuingChild(tree, children, i);
            for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
                if (children.child[k] != next) queue.push_back({i, children.child[k]});
            }
            i = next;
        }
        int32_t branch = 0, position = 0;
        int32_t previous = start.fork >= 0 ? cylinderAt[start.fork] : 0;
        for (size_t k = 1; k < chain.size(); ++k) {
            const SkeletonNode& a = tree.nodes[chain[k - 1]];
            const SkeletonNode& b = tree.nodes[chain[k]];
            const Vec3 p0 = zUp(a.position), d = zUp(b.position) - p0;
            const double len = length(d);
            if (!(len > 0)) {
                cylinderAt[chain[k]] = previous;
                continue;
            }
            // The tube starts a branch at the fork with its first node's radius (no gap).
            const double r0 = (k == 1 && start.fork >= 0) ? b.radius : a.radius, r1 = b.radius;
            if (branch == 0) branch = ++branches;
            QsmCylinder c;
            c.radius = std::sqrt((r0 * r0 + r0 * r1 + r1 * r1) / 3);
            c.length = len;
            c.start = p0;
            c.axis = d / len;
            c.parent = previous;
            c.branch = branch;
            c.branchOrder = b.order;
            c.positionInBranch = ++position;
            c.node = chain[k];
            out.push_back(c);
            const int32_t index = static_cast<int32_t>(out.size());
            if (position > 1) out[previous - 1].extension = index;
            cylinderAt[chain[k]] = index;
            previous = index;
        }
    }
    return out;
}

std::string qsmCylinderCsv(const std::vector<QsmCylinder>& cylinders) {
    std::string out =
        "radius,length,start_x,start_y,start_z,axis_x,axis_y,axis_z,parent,extension,branch,"
        "BranchOrder,PositionInBranch,added,UnmodRadius,node_id\n";
    for (const QsmCylinder& c : cylinders) {
        out += formatFixed(c.radius, 6) + "," + formatFixed(c.length, 6);
        for (int a = 0; a < 3; ++a) out += "," + formatFixed(c.start[a], 6);
        for (int a = 0; a < 3; ++a) out += "," + formatFixed(c.axis[a], 6);
        for (int32_t v : {c.parent, c.extension, c.branch, c.branchOrder, c.positionInBranch}) {
            out += "," + std::to_string(v);
        }
        out += ",0," + formatFixed(c.radius, 6) + "," + std::to_string(c.node) + "\n";
    }
    return out;
}

std::string qsmCylinderTreeQsmTxt(const std::vector<QsmCylinder>& cylinders) {
    std::string out =
        "radius (m)\tlength (m)\tstart_point\taxis_direction\tparent\textension\tbranch\t"
        "branch_order\tposition_in_branch\tmad\tSurfCov\tadded\tUnmodRadius (m)\n";
    const double nan = std::nan("");
    for (const QsmCylinder& c : cylinders) {
        out += matlabG(c.radius) + "\t" + matlabG(c.length);
        for (int a = 0; a < 3; ++a) out += "\t" + matlabG(c.start[a]);
        for (int a = 0; a < 3; ++a) out += "\t" + matlabG(c.axis[a]);
        // Indices as integers (TreeQSM's %g of a single prints them alike below 10⁶).
        for (int32_t v : {c.parent, c.extension, c.branch, c.branchOrder, c.positionInBranch}) {
            out += "\t" + std::to_string(v);
        }
        out += "\t" + matlabG(nan) + "\t" + matlabG(nan) + "\t0\t" + matlabG(c.radius) + "\n";
    }
    return out;
}

void writeQsmCylinders(const std::filesystem::path& csvPath, const Tree& tree,
                       const std::filesystem::path& txtPath) {
    const std::vector<QsmCylinder> cylinders = qsmCylinders(tree);
    writeFileAtomic(csvPath, qsmCylinderCsv(cylinders));
    if (!txtPath.empty()) writeFileAtomic(txtPath, qsmCylinderTreeQsmTxt(cylinders));
}

}  // namespace sylva
