// SPDX-License-Identifier: Apache-2.0
// Collapsing the binary SAH tree into the 4-wide BVH (bvh4.hpp) or the 8-wide one (bvh8.hpp): a
// pass of its own over the built tree, so the binary build stays as it is.
#include "bvh4.hpp"

#include "bvh8.hpp"
#include "huge_pages.hpp"

namespace phong {

namespace {

double half_area(const BvhNode& n) {
    const double x = double(n.hi[0]) - n.lo[0], y = double(n.hi[1]) - n.lo[1], z = double(n.hi[2]) - n.lo[2];
    return x * y + y * z + z * x;
}

template <class Node, int W>
struct Collapser {
    const BvhNodes& binary;
    std::vector<Node>& wide;

    // The W-wide node of binary node `index`'s subtree, appended depth-first; returns its index.
    // A binary leaf (only the root can be one here) becomes a node with that single child.
    int32_t collapse(int32_t index) {
        int32_t kids[W];
        // Each kid's area if it is an interior node (it may be opened), else -1: computed once
        // per kid, not once per kid and round (the collapse of S2 took 0.019 s, serial).
        double openable[W];
        int n = 0;
        auto add = [&](int i, int32_t kid) {
            kids[i] = kid;
            const BvhNode& c = binary[size_t(kid)];
            openable[i] = c.count == 0 ? half_area(c) : -1.0;
        };
        if (binary[size_t(index)].count > 0) {
            kids[n] = index;
            openable[n++] = -1.0;
        } else {
            add(n++, index + 1);
            add(n++, binary[size_t(index)].offset);
        }
        // Open the interior child of largest area (the one rays enter most often, by the SAH's
        // measure) until there are W; the first of equal areas.
        while (n < W) {
            int widest = -1;
            double widest_area = -1.0;
            for (int i = 0; i < n; ++i) {
                if (openable[i] > widest_area) {
                    widest = i;
                    widest_area = openable[i];
                }
            }
            if (widest < 0) break;
            const int32_t opened = kids[widest];
            add(widest, opened + 1);
            add(n++, binary[size_t(opened)].offset);
        }
        const int32_t self = int32_t(wide.size());
        wide.emplace_back();
        Node& node = wide.back();
        for (int i = 0; i < W; ++i) {
            for (int k = 0; k < 3; ++k) {
                node.boxes[k][i] = INFINITY;
                node.boxes[3 + k][i] = -INFINITY;
            }
            node.child[i] = -1;
            node.count[i] = 0;
        }
        for (int i = 0; i < n; ++i) {
            const BvhNode& c = binary[size_t(kids[i])];
            for (int k = 0; k < 3; ++k) {
                wide[size_t(self)].boxes[k][i] = c.lo[k];
                wide[size_t(self)].boxes[3 + k][i] = c.hi[k];
            }
        }
        for (int i = 0; i < n; ++i) {
            const BvhNode& c = binary[size_t(kids[i])];
            int32_t child = c.offset;
            if (c.count == 0) child = collapse(kids[i]);  // appends: `node` may have moved
            wide[size_t(self)].child[i] = child;
            wide[size_t(self)].count[i] = c.count;
        }
        return self;
    }
};

}  // namespace

std::vector<Bvh4Node> collapse_to_bvh4(const BvhNodes& binary) {
    std::vector<Bvh4Node> wide;
    if (binary.empty()) return wide;
    // At most one wide node per binary interior node (n − 1 for n primitives, whose tree has
    // binary.size() = 2n − 1 slots; a binary leaf at the root: one). Reserved capacity that is never written is never
    // resident, while a reallocation holds the old nodes and a copy at once (10M triangles: +355 MiB at the peak,
    // benchmarks/README.md), so reserve the bound rather than an estimate.
    reserve_huge(wide, binary.size() / 2 + 1);
    Collapser<Bvh4Node, 4>{binary, wide}.collapse(0);
    return wide;
}

std::vector<Bvh8Node> collapse_to_bvh8(const BvhNodes& binary) {
    std::vector<Bvh8Node> wide;
    if (binary.empty()) return wide;
    // The bound, as for the 4-wide tree.
    reserve_huge(wide, binary.size() / 2 + 1);
    Collapser<Bvh8Node, 8>{binary, wide}.collapse(0);
    return wide;
}

}  // namespace phong
