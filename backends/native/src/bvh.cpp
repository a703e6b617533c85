// SPDX-License-Identifier: Apache-2.0
// Binned SAH BVH build (Wald, "On fast construction of SAH-based bounding volume
// hierarchies", 2007), flattened depth-first.
#include "bvh.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

namespace phong {

// Plain comparisons, not std::fmin/fmax: those are libm calls without -ffast-math (their NaN
// rules have no single x86 instruction), and a validated scene has no NaN.
static inline double min_of(double a, double b) { return b < a ? b : a; }
static inline double max_of(double a, double b) { return b > a ? b : a; }

void Bounds::grow(const Vec3& p) {
    lo = {min_of(lo.x, p.x), min_of(lo.y, p.y), min_of(lo.z, p.z)};
    hi = {max_of(hi.x, p.x), max_of(hi.y, p.y), max_of(hi.z, p.z)};
}

void Bounds::grow(const Bounds& b) {
    grow(b.lo);
    grow(b.hi);
}

double Bounds::half_area() const {
    if (empty()) return 0.0;
    const Vec3 e = hi - lo;
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

namespace {

// SAH constants: a node visit costs about as much as one primitive test (both are a few
// dozen flops on data that is already in cache); leaves stop at kMaxLeafSize primitives.
constexpr int kBins = 16;
constexpr int kMaxLeafSize = 4;
constexpr double kTraversalCost = 1.0;
constexpr double kIntersectionCost = 1.0;
// Below this depth the SAH decides; deeper, nodes split at the median on the widest centroid
// axis, so adversarial inputs (e.g. exponentially spaced primitives) keep the tree depth below
// kMaxSahDepth + log2(N) < kMaxTraversalDepth (bvh.hpp).
constexpr int kMaxSahDepth = 40;

struct Builder {
    const std::vector<Bounds>& prim_bounds;
    std::vector<Vec3> centroids;
    std::vector<uint32_t>& order;
    std::vector<BvhNode>& nodes;

    void set_bounds(BvhNode& node, const Bounds& b) {
        const double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
        for (int k = 0; k < 3; ++k) {
            node.lo[k] = round_down(lo[k]);
            node.hi[k] = round_up(hi[k]);
        }
    }

    void make_leaf(int32_t index, uint32_t begin, uint32_t end) {
        nodes[index].offset = int32_t(begin);
        nodes[index].count = int16_t(end - begin);
        nodes[index].axis = 0;
    }

    // Builds the subtree of order[begin, end) into nodes[index] (already allocated).
    void build(int32_t index, uint32_t begin, uint32_t end, int depth) {
        Bounds bounds, centre_bounds;
        for (uint32_t i = begin; i < end; ++i) {
            bounds.grow(prim_bounds[order[i]]);
            centre_bounds.grow(centroids[order[i]]);
        }
        set_bounds(nodes[index], bounds);
        const uint32_t n = end - begin;
        if (n <= 1) { make_leaf(index, begin, end); return; }

        // Best binned split over the three axes.
        double best_cost = HUGE_VAL;
        int best_axis = -1, best_split = 0;
        const Vec3 extent = centre_bounds.hi - centre_bounds.lo;
        for (int axis = 0; axis < 3; ++axis) {
            const double lo = centre_bounds.lo[axis], ext = extent[axis];
            if (!(ext > 0.0)) continue;
            Bounds bin_bounds[kBins];
            uint32_t bin_count[kBins] = {};
            const double scale = kBins / ext;
            for (uint32_t i = begin; i < end; ++i) {
                int bin = std::min(kBins - 1, int((centroids[order[i]][axis] - lo) * scale));
                bin_count[bin]++;
                bin_bounds[bin].grow(prim_bounds[order[i]]);
            }
            // Sweep: right-side areas and counts, then left side.
            double right_area[kBins];
            uint32_t right_count[kBins];
            Bounds acc;
            uint32_t count = 0;
            for (int b = kBins - 1; b > 0; --b) {
                acc.grow(bin_bounds[b]);
                count += bin_count[b];
                right_area[b] = acc.half_area();
                right_count[b] = count;
            }
            acc = Bounds();
            count = 0;
            for (int b = 0; b < kBins - 1; ++b) {
                acc.grow(bin_bounds[b]);
                count += bin_count[b];
                if (count == 0 || right_count[b + 1] == 0) continue;
                const double cost = count * acc.half_area() + right_count[b + 1] * right_area[b + 1];
                if (cost < best_cost) { best_cost = cost; best_axis = axis; best_split = b + 1; }
            }
        }

        const double area = bounds.half_area();
        const double leaf_cost = kIntersectionCost * n;
        const double split_cost = area > 0.0 ? kTraversalCost + kIntersectionCost * best_cost / area : HUGE_VAL;
        uint32_t mid;
        if (best_axis < 0) {
            // All centroids coincide: split by count when too many for one leaf.
            if (n <= kMaxLeafSize) { make_leaf(index, begin, end); return; }
            mid = begin + n / 2;
            best_axis = 0;
        } else if (depth >= kMaxSahDepth) {
            if (n <= kMaxLeafSize) { make_leaf(index, begin, end); return; }
            const int axis = extent.x >= extent.y ? (extent.x >= extent.z ? 0 : 2) : (extent.y >= extent.z ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                             [&](uint32_t p, uint32_t q) { return centroids[p][axis] < centroids[q][axis]; });
            best_axis = axis;
        } else {
            if (n <= kMaxLeafSize && leaf_cost <= split_cost) { make_leaf(index, begin, end); return; }
            const double lo = centre_bounds.lo[best_axis], scale = kBins / extent[best_axis];
            const int axis = best_axis, split = best_split;
            auto it = std::partition(order.begin() + begin, order.begin() + end, [&](uint32_t p) {
                return std::min(kBins - 1, int((centroids[p][axis] - lo) * scale)) < split;
            });
            mid = uint32_t(it - order.begin());
            if (mid == begin || mid == end) mid = begin + n / 2;  // cannot happen; stay safe
        }
        const int32_t left = int32_t(nodes.size());
        nodes.emplace_back();
        build(left, begin, mid, depth + 1);
        const int32_t right = int32_t(nodes.size());
        nodes.emplace_back();
        build(right, mid, end, depth + 1);
        nodes[index].offset = right;
        nodes[index].count = 0;
        nodes[index].axis = int16_t(best_axis);
    }
};

}  // namespace

void Bvh::build(const std::vector<Bounds>& prim_bounds) {
    nodes.clear();
    order.resize(prim_bounds.size());
    std::iota(order.begin(), order.end(), 0u);
    if (prim_bounds.empty()) return;
    nodes.reserve(2 * prim_bounds.size());
    Builder builder{prim_bounds, {}, order, nodes};
    builder.centroids.resize(prim_bounds.size());
    for (size_t i = 0; i < prim_bounds.size(); ++i)
        builder.centroids[i] = (prim_bounds[i].lo + prim_bounds[i].hi) * 0.5;
    nodes.emplace_back();
    builder.build(0, 0, uint32_t(prim_bounds.size()), 0);
    nodes.shrink_to_fit();
}

}  // namespace phong
