// QSM ground truth: a hand-built tree's cylinder table entry by entry, TreeQSM's invariants and
// the wood volume on a grown library tree, zero-length segments, and the CSV / TreeQSM text
// layouts.
#include "pipeline/formats/qsm_writer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <sstream>

#include "core/math.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

// A trunk of 4 one-metre segments (radius 0.2 → 0.04), a first-order branch from node 1 along
// +x (2 segments), a second-order twig from its first node along −z, and a root.
Tree handTree() {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2, 0);
    addNode(t, 0, {0, 1, 0}, 0.16, 0);
    addNode(t, 1, {0, 2, 0}, 0.12, 0);
    addNode(t, 2, {0, 3, 0}, 0.08, 0);
    addNode(t, 3, {0, 4, 0}, 0.04, 0);
    addNode(t, 1, {1, 1.5, 0}, 0.05, 1);             // 5
    addNode(t, 5, {2, 2, 0}, 0.03, 1);               // 6
    addNode(t, 5, {1, 1.5, -1}, 0.02, 2);            // 7
    addNode(t, 0, {0, -0.5, 0}, 0.1, 0, kRootPart);  // 8: left out
    return t;
}

void expectVec(const Vec3& a, const Vec3& b) {
    EXPECT_NEAR(a.x, b.x, 1e-12);
    EXPECT_NEAR(a.y, b.y, 1e-12);
    EXPECT_NEAR(a.z, b.z, 1e-12);
}

TEST(QsmCylinders, HandTreeGivesTheKnownTable) {
    const std::vector<QsmCylinder> c = qsmCylinders(handTree());
    ASSERT_EQ(c.size(), 7u);
    // Stem: cylinders 1–4, branch 1, order 0, each the extension of the one below.
    for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(c[k].parent, k) << k;  // 0 = none for the first
        EXPECT_EQ(c[k].extension, k < 3 ? k + 2 : 0) << k;
        EXPECT_EQ(c[k].branch, 1);
        EXPECT_EQ(c[k].branchOrder, 0);
        EXPECT_EQ(c[k].positionInBranch, k + 1);
        EXPECT_EQ(c[k].node, k + 1);
        EXPECT_DOUBLE_EQ(c[k].length, 1.0);
        expectVec(c[k].start, {0, 0, double(k)});  // z up
        expectVec(c[k].axis, {0, 0, 1});
    }
    const double r0 = 0.2, r1 = 0.16;
    EXPECT_DOUBLE_EQ(c[0].radius, std::sqrt((r0 * r0 + r0 * r1 + r1 * r1) / 3));
    // The branch from node 1: its parent is the stem cylinder ending at node 1; it starts with
    // its own first node's radius (as the tube mesh draws it).
    EXPECT_EQ(c[4].parent, 1);
    EXPECT_EQ(c[4].extension, 6);
    EXPECT_EQ(c[4].branch, 2);
    EXPECT_EQ(c[4].branchOrder, 1);
    EXPECT_EQ(c[4].positionInBranch, 1);
    EXPECT_EQ(c[4].node, 5);
    EXPECT_DOUBLE_EQ(c[4].radius, 0.05);
    EXPECT_DOUBLE_EQ(c[4].length, std::sqrt(1.25));
    expectVec(c[4].start, {0, 0, 1});
    expectVec(c[4].axis, {1 / std::sqrt(1.25), 0, 0.5 / std::sqrt(1.25)});
    EXPECT_EQ(c[5].parent, 5);
    EXPECT_EQ(c[5].extension, 0);
    EXPECT_EQ(c[5].positionInBranch, 2);
    EXPECT_DOUBLE_EQ(c[5].radius, std::sqrt((0.05 * 0.05 + 0.05 * 0.03 + 0.03 * 0.03) / 3));
    // The twig along scene −z, which is +y (north) in TreeQSM's frame.
    EXPECT_EQ(c[6].parent, 5);
    EXPECT_EQ(c[6].extension, 0);
    EXPECT_EQ(c[6].branch, 3);
    EXPECT_EQ(c[6].branchOrder, 2);
    EXPECT_EQ(c[6].node, 7);
    expectVec(c[6].start, {1, 0, 1.5});
    expectVec(c[6].axis, {0, 1, 0});
}

TEST(QsmCylinders, ZeroLengthSegmentsHangTheirChildrenBelow) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1, 0);
    addNode(t, 0, {0, 0, 0}, 0.1, 0);  // zero length at the base
    addNode(t, 1, {0, 1, 0}, 0.08, 0);
    addNode(t, 2, {0, 1, 0}, 0.08, 0);  // zero length in the stem
    addNode(t, 3, {0, 2, 0}, 0.05, 0);
    addNode(t, 3, {1, 1, 0}, 0.03, 1);  // a branch from the collapsed node
    const std::vector<QsmCylinder> c = qsmCylinders(t);
    ASSERT_EQ(c.size(), 3u);
    EXPECT_EQ(c[0].parent, 0);
    EXPECT_EQ(c[0].node, 2);
    EXPECT_EQ(c[0].extension, 2);
    EXPECT_EQ(c[1].parent, 1);
    EXPECT_EQ(c[1].node, 4);
    EXPECT_EQ(c[1].positionInBranch, 2);
    EXPECT_EQ(c[2].parent, 1);  // node 3 collapsed onto cylinder 1
    EXPECT_EQ(c[2].branch, 2);
    EXPECT_TRUE(qsmCylinders(Tree{}).empty());
}

TEST(QsmCylinders, GrownTreeKeepsTreeQsmsInvariantsAndTheWoodVolume) {
    const SpeciesFile species =
        loadSpecies(SYLVA_SOURCE_DIR "/species/papers/xu-mould-2012/xm-a.toml");
    Tree tree = growSpecies(species, 1, nullptr, true).tree;
    assignBranchOrder(tree);
    const std::vector<QsmCylinder> c = qsmCylinders(tree);
    double volume = 0, frustums = 0;
    int segments = 0;
    std::vector<int> segmentEnds;  // nodes ending a segment of positive length
    std::vector<int> cylinderOfNode(tree.nodes.size(), 0);
    for (size_t i = 1; i < tree.nodes.size(); ++i) {
        const SkeletonNode& n = tree.nodes[i];
        if (n.part != kShootPart) continue;
        const SkeletonNode& p = tree.nodes[n.parent];
        const double len = length(n.position - p.position);
        if (len > 0) ++segments, segmentEnds.push_back(static_cast<int>(i));
    }
    ASSERT_GT(segments, 50);
    EXPECT_EQ(static_cast<int>(c.size()), segments);
    std::map<int, int> branchLength;
    for (size_t k = 0; k < c.size(); ++k) {
        const int index = static_cast<int>(k + 1);
        const QsmCylinder& q = c[k];
        cylinderOfNode[q.node] = index;
        EXPECT_LT(q.parent, index);
        EXPECT_NEAR(length(q.axis), 1.0, 1e-12);
        const SkeletonNode& end = tree.nodes[q.node];
        const SkeletonNode& start = tree.nodes[end.parent];
        EXPECT_EQ(end.part, kShootPart);
        expectVec(q.start, {start.position.x, -start.position.z, start.position.y});
        expectVec(q.start + q.axis * q.length, {end.position.x, -end.position.z, end.position.y});
        // Branches are contiguous runs numbered in order, positions 1, 2, … within them.
        EXPECT_EQ(q.positionInBranch, ++branchLength[q.branch]);
        if (q.positionInBranch > 1) {
            EXPECT_EQ(c[k - 1].branch, q.branch);
            EXPECT_EQ(q.parent, index - 1);
            EXPECT_EQ(c[k - 1].extension, index);
        } else {
            EXPECT_EQ(q.branch, k == 0 ? 1 : c[k - 1].branch + 1);
        }
        // TreeQSM's branch-order rule (cylinders.m): an extension keeps its parent's order, any
        // other child adds one. It holds on a tree ordered by assignBranchOrder.
        if (q.parent > 0) {
            const QsmCylinder& parent = c[q.parent - 1];
            const bool extension = parent.extension == index;
            EXPECT_EQ(q.branchOrder, parent.branchOrder + (extension ? 0 : 1)) << index;
        } else {
            EXPECT_EQ(q.branchOrder, 0);
        }
        // The tube's frustum (r0 = the parent's radius, or the branch's own at a fork).
        const double r1 = end.radius;
        const double r0 = q.positionInBranch == 1 && q.parent > 0 ? r1 : start.radius;
        frustums += kPi / 3 * q.length * (r0 * r0 + r0 * r1 + r1 * r1);
        volume += kPi * q.radius * q.radius * q.length;
    }
    EXPECT_NEAR(volume, frustums, 1e-9 * frustums);
    for (int i : segmentEnds) EXPECT_GT(cylinderOfNode[i], 0) << "node " << i;
}

TEST(QsmTables, CsvAndTreeQsmText) {
    const std::vector<QsmCylinder> c = qsmCylinders(handTree());
    const std::string csv = qsmCylinderCsv(c);
    std::istringstream in(csv);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line,
              "radius,length,start_x,start_y,start_z,axis_x,axis_y,axis_z,parent,extension,"
              "branch,BranchOrder,PositionInBranch,added,UnmodRadius,node_id");
    std::getline(in, line);
    EXPECT_EQ(line,
              "0.180370,1.000000,0.000000,0.000000,0.000000,0.000000,0.000000,1.000000,"
              "0,2,1,0,1,0,0.180370,1");
    int rows = 0;
    while (std::getline(in, line)) ++rows;
    EXPECT_EQ(rows, 6);

    const std::string txt = qsmCylinderTreeQsmTxt(c);
    std::istringstream tin(txt);
    std::getline(tin, line);
    EXPECT_EQ(line,
              "radius (m)\tlength (m)\tstart_point\taxis_direction\tparent\textension\tbranch\t"
              "branch_order\tposition_in_branch\tmad\tSurfCov\tadded\tUnmodRadius (m)");
    std::getline(tin, line);
    EXPECT_EQ(line, "0.1804\t1\t0\t0\t0\t0\t0\t1\t0\t2\t1\t0\t1\tNaN\tNaN\t0\t0.1804");
    std::getline(tin, line);
    std::getline(tin, line);
    std::getline(tin, line);
    std::getline(tin, line);  // cylinder 5: the branch along +x
    EXPECT_EQ(line, "0.05\t1.118\t0\t0\t1\t0.8944\t0\t0.4472\t1\t6\t2\t1\t1\tNaN\tNaN\t0\t0.05");
}

TEST(QsmTables, WritesBothFilesAtomically) {
    test::TempDir dir;
    writeQsmCylinders(dir.path() / "t" / "qsm.csv", handTree(), dir.path() / "t" / "qsm.txt");
    EXPECT_EQ(test::slurp(dir.path() / "t" / "qsm.csv"), qsmCylinderCsv(qsmCylinders(handTree())));
    EXPECT_EQ(test::slurp(dir.path() / "t" / "qsm.txt"),
              qsmCylinderTreeQsmTxt(qsmCylinders(handTree())));
    writeQsmCylinders(dir.path() / "only.csv", handTree());
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "only.csv"));
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "only.txt"));
}

}  // namespace
}  // namespace sylva
