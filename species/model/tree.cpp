// Topology helpers of the shared tree model: CSR children and branch order.
#include "species/model/tree.h"

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sylva {

ChildIndex::ChildIndex(const Tree& tree) {
    const int32_t n = static_cast<int32_t>(tree.nodes.size());
    offset.assign(static_cast<size_t>(n) + 1, 0);
    // Counting sort by parent; children end up in ascending node index (deterministic).
    for (int32_t i = 1; i < n; ++i) {
        int32_t p = tree.nodes[i].parent;
        // Everything downstream relies on parent < child, so reject broken trees loudly.
        if (p < 0 || p >= i) {
            throw std::invalid_argument("ChildIndex: node " + std::to_string(i) +
                                        " has invalid parent " + std::to_string(p));
        }
        ++offset[p + 1];
    }
    for (int32_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
    child.resize(n > 0 ? static_cast<size_t>(n - 1) : 0);
    std::vector<int32_t> fill(offset.begin(), offset.end() - 1);
    for (int32_t i = 1; i < n; ++i) child[fill[tree.nodes[i].parent]++] = i;
}

void assignBranchOrder(Tree& tree) {
    auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (n == 0) return;
    ChildIndex children(tree);

    // Longest path length (m) from each node down to any tip below it. Children have larger
    // indices than their parents, so one reverse sweep sees every child before its parent.
    std::vector<double> downstream(n, 0.0);
    for (int32_t i = n - 1; i > 0; --i) {
        int32_t p = nodes[i].parent;
        double viaChild = distance(nodes[p].position, nodes[i].position) + downstream[i];
        downstream[p] = std::max(downstream[p], viaChild);
    }

    // Picks the continuing child among those accepted by `accept`: longest path through the
    // child, ties to the lower index (children are sorted ascending, so keep the first max).
    auto continuing = [&](int32_t parent, auto accept) {
        int32_t best = -1;
        double bestLen = -1.0;
        for (int32_t k = children.offset[parent]; k < children.offset[parent + 1]; ++k) {
            int32_t c = children.child[k];
            if (!accept(c)) continue;
            double len = distance(nodes[parent].position, nodes[c].position) + downstream[c];
            if (len > bestLen) {
                bestLen = len;
                best = c;
            }
        }
        return best;
    };

    nodes[0].order = 0;
    for (int32_t i = 0; i < n; ++i) {
        if (children.count(i) == 0) continue;
        int32_t keepA, keepB = -1;
        if (i == 0) {
            // The trunk and the taproot are separate axes: each keeps order 0.
            keepA = continuing(0, [&](int32_t c) { return nodes[c].part != kRootPart; });
            keepB = continuing(0, [&](int32_t c) { return nodes[c].part == kRootPart; });
        } else {
            keepA = continuing(i, [](int32_t) { return true; });
        }
        for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            int32_t c = children.child[k];
            nodes[c].order = nodes[i].order + ((c == keepA || c == keepB) ? 0 : 1);
        }
    }
}

void pruneTree(Tree& tree, const std::function<bool(const Vec3&)>& keep) {
    const size_t n = tree.nodes.size();
    std::vector<int32_t> index(n, -1);
    std::vector<SkeletonNode> kept;
    kept.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        const SkeletonNode& node = tree.nodes[i];
        if (i > 0 && (node.parent < 0 || index[node.parent] < 0 || !keep(node.position))) continue;
        index[i] = static_cast<int32_t>(kept.size());
        kept.push_back(node);
        if (node.parent >= 0) kept.back().parent = index[node.parent];
    }
    std::vector<Leaf> leaves;
    leaves.reserve(tree.leaves.size());
    bool cut = kept.size() != n;
    for (Leaf leaf : tree.leaves) {
        if (leaf.node >= 0) {
            if (static_cast<size_t>(leaf.node) >= n || index[leaf.node] < 0) {
                cut = true;
                continue;
            }
            leaf.node = index[leaf.node];
        }
        if (!keep(leaf.position)) {
            cut = true;
            continue;
        }
        leaves.push_back(leaf);
    }
    if (!cut) return;  // nothing cut: the method's own endpoints stay
    std::vector<uint8_t> parentOf(kept.size(), 0);
    for (const SkeletonNode& node : kept) {
        if (node.parent >= 0) parentOf[node.parent] = 1;
    }
    tree.endpoints.clear();
    for (size_t i = 0; i < kept.size(); ++i) {
        if (!parentOf[i]) tree.endpoints.push_back(static_cast<int32_t>(i));
    }
    tree.nodes = std::move(kept);
    tree.leaves = std::move(leaves);
}

}  // namespace sylva
