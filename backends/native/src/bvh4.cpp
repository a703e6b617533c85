// SPDX-License-Identifier: Apache-2.0
// Collapsing the binary SAH tree into the 4-wide BVH (bvh4.hpp) or the 8-wide one (bvh8.hpp): a
// pass of its own over the built tree, so the binary build stays as it is.
#include "bvh4.hpp"

#include "build_threads.hpp"
#include "bvh8.hpp"
#include "huge_pages.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <future>

namespace phong {

namespace {

// Trees of at least this many binary node slots collapse the root's children in parallel, each
// into a region of its own (collapse_to below). Below it the collapse takes under a millisecond.
constexpr size_t kParallelCollapseMinSlots = size_t(1) << 16;

double half_area(const BvhNode& n) {
    const double x = double(n.hi[0]) - n.lo[0], y = double(n.hi[1]) - n.lo[1], z = double(n.hi[2]) - n.lo[2];
    return x * y + y * z + z * x;
}

template <class Node, int W>
struct Collapser {
    const BvhNodes& binary;
    Node* wide;  // slots enough for every node written (collapse_to)

    // The (at most W) children of the wide node of binary node `index`: their binary indices.
    struct Kids {
        int32_t index[W];
        int n = 0;
    };
    Kids choose(int32_t index) const {
        Kids kids;
        // Each kid's area if it is an interior node (it may be opened), else -1: computed once
        // per kid, not once per kid and round (the collapse of S2 took 0.019 s, serial).
        double openable[W];
        auto set = [&](int i, int32_t kid) {
            kids.index[i] = kid;
            const BvhNode& c = binary[size_t(kid)];
            openable[i] = c.count == 0 ? half_area(c) : -1.0;
        };
        if (binary[size_t(index)].count > 0) {  // a binary leaf (only the root can be one here)
            kids.index[0] = index;
            openable[kids.n++] = -1.0;
            return kids;
        }
        set(kids.n++, index + 1);
        set(kids.n++, binary[size_t(index)].offset);
        // Open the interior child of largest area (the one rays enter most often, by the SAH's
        // measure) until there are W; the first of equal areas.
        while (kids.n < W) {
            int widest = -1;
            double widest_area = -1.0;
            for (int i = 0; i < kids.n; ++i) {
                if (openable[i] > widest_area) {
                    widest = i;
                    widest_area = openable[i];
                }
            }
            if (widest < 0) break;
            const int32_t opened = kids.index[widest];
            set(widest, opened + 1);
            set(kids.n++, binary[size_t(opened)].offset);
        }
        return kids;
    }

    // Writes wide node `self`: the kids' boxes, counts and (leaves) primitive ranges; an interior
    // kid's child index is set by the caller once its node exists.
    void write(int32_t self, const Kids& kids) const {
        Node& node = wide[size_t(self)];
        for (int i = 0; i < W; ++i) {
            for (int k = 0; k < 3; ++k) {
                node.boxes[k][i] = INFINITY;
                node.boxes[3 + k][i] = -INFINITY;
            }
            node.child[i] = -1;
            node.count[i] = 0;
        }
        for (int i = 0; i < kids.n; ++i) {
            const BvhNode& c = binary[size_t(kids.index[i])];
            for (int k = 0; k < 3; ++k) {
                node.boxes[k][i] = c.lo[k];
                node.boxes[3 + k][i] = c.hi[k];
            }
            node.child[i] = c.offset;
            node.count[i] = c.count;
        }
    }

    // The primitives under binary node `index`: its leaves' ranges are contiguous, from its
    // leftmost leaf's first to its rightmost leaf's last (two walks down, O(depth)).
    uint32_t primitives_under(int32_t index) const {
        int32_t left = index, right = index;
        while (binary[size_t(left)].count == 0) left += 1;
        while (binary[size_t(right)].count == 0) right = binary[size_t(right)].offset;
        return uint32_t(binary[size_t(right)].offset + binary[size_t(right)].count - binary[size_t(left)].offset);
    }

    // The wide subtree of binary node `index`, depth-first from slot `next` on (`next` advances
    // past it); returns its root's slot.
    int32_t collapse(int32_t index, int32_t& next) const {
        const Kids kids = choose(index);
        const int32_t self = next++;
        write(self, kids);
        for (int i = 0; i < kids.n; ++i)
            if (binary[size_t(kids.index[i])].count == 0) wide[size_t(self)].child[i] = collapse(kids.index[i], next);
        return self;
    }
};

// Collapses `binary` into `wide` (empty). A small tree collapses depth-first, node after node. A
// large one writes the root at slot 0 and collapses each interior child of the root into a
// region of its own, the children in parallel: region i starts where region i − 1's bound ends.
// Each wide node is made for a distinct binary interior node, and a subtree over m primitives
// has at most m − 1 of them (at most m leaves), so that is the region's size: the primitive
// counts, unlike the binary tree's slots (whose gaps depend on the build's threads: bvh.cpp),
// are the same for any threads, and so are the layout and the tree's digest. The slots a region
// leaves unused are never written (never resident) and never reached. The regions fit in the
// n slots reserved for n primitives: 1 + sum (m_i − 1) <= 1 + n − 2.
// (S2's collapse took 17 ms on one thread while the other waited; ~9 ms on two.)
template <class Node, int W>
void collapse_to(const BvhNodes& binary, UninitialisedVector<Node>& wide) {
    if (binary.empty()) return;
    resize_huge(wide, binary.size() / 2 + 1);
    const Collapser<Node, W> collapser{binary, wide.data()};
    int32_t used = 0;
    if (binary.size() < kParallelCollapseMinSlots) {
        collapser.collapse(0, used);
        wide.resize(size_t(used));
        return;
    }
    const auto kids = collapser.choose(0);
    collapser.write(0, kids);
    struct Region {
        int kid;
        int32_t start, bound;  // slots [start, start + bound)
        int32_t end;           // after the collapse: the first slot it left unused
    };
    Region regions[W];
    int n_regions = 0;
    int32_t start = 1;
    for (int i = 0; i < kids.n; ++i) {
        if (binary[size_t(kids.index[i])].count != 0) continue;
        const int32_t bound = int32_t(collapser.primitives_under(kids.index[i])) - 1;
        regions[n_regions++] = {i, start, bound, start};
        start += bound;
    }
    assert(size_t(start) <= wide.size());
    // The largest first, so that the last to start are the shortest.
    Region* order[W];
    for (int r = 0; r < n_regions; ++r) order[r] = &regions[r];
    std::sort(order, order + n_regions, [](const Region* a, const Region* b) { return a->bound > b->bound; });
    std::atomic<int> taken{0};
    auto work = [&] {
        for (int r; (r = taken.fetch_add(1)) < n_regions;) {
            Region& region = *order[r];
            region.end = region.start;
            collapser.collapse(kids.index[region.kid], region.end);
            assert(region.end <= region.start + region.bound);
        }
    };
    const unsigned threads = std::min(build_threads(), unsigned(n_regions));
    std::vector<std::future<void>> helpers;
    for (unsigned t = 1; t < threads; ++t) helpers.push_back(std::async(std::launch::async, work));
    work();
    for (std::future<void>& h : helpers) h.get();
    used = 1;
    for (int r = 0; r < n_regions; ++r) {
        wide[0].child[regions[r].kid] = regions[r].start;
        used = std::max(used, regions[r].end);
        // The rest of the huge page a region's last node fell in (up to 2 MiB a region: the
        // 10M-triangle mesh's whole process 1,104 -> 1,116 MiB without this).
        if (regions[r].end < regions[r].start + regions[r].bound)
            release_unused(wide.data() + regions[r].end, wide.data() + regions[r].start + regions[r].bound);
    }
    wide.resize(size_t(used));
}

}  // namespace

Bvh4Nodes collapse_to_bvh4(const BvhNodes& binary) {
    Bvh4Nodes wide;
    collapse_to<Bvh4Node, 4>(binary, wide);
    return wide;
}

Bvh8Nodes collapse_to_bvh8(const BvhNodes& binary) {
    Bvh8Nodes wide;
    collapse_to<Bvh8Node, 8>(binary, wide);
    return wide;
}

}  // namespace phong
