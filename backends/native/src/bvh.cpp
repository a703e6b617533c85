// SPDX-License-Identifier: Apache-2.0
// Binned SAH BVH build (Wald, "On fast construction of SAH-based bounding volume
// hierarchies", 2007), flattened depth-first.
#include "bvh.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <numeric>
#include <thread>
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

// Corner-wise, so that an empty b (lo = +inf, hi = -inf) changes nothing. (Growing by b.lo
// and b.hi as points made an empty bin's union infinite, which priced every split beside an
// empty bin at an infinite SAH cost: a 1M-triangle torus over a ground quad kept the quad's
// 100 x 100 box on every level of half the tree.)
void Bounds::grow(const Bounds& b) {
    lo = {min_of(lo.x, b.lo.x), min_of(lo.y, b.lo.y), min_of(lo.z, b.lo.z)};
    hi = {max_of(hi.x, b.hi.x), max_of(hi.y, b.hi.y), max_of(hi.z, b.hi.z)};
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

// The bin of a centroid coordinate c along an axis whose centroids start at lo, with
// scale = kBins / extent. Validated scenes have finite, representable bounds; this stays in
// range whatever slips through (an infinite extent gives scale 0 and inf·0 = NaN; a NaN or a
// negative offset goes to bin 0, anything past the end to the last bin), never out of bounds.
inline int bin_of(double c, double lo, double scale) {
    const double f = (c - lo) * scale;
    if (!(f > 0.0)) return 0;
    return f >= double(kBins - 1) ? kBins - 1 : int(f);
}
constexpr int kMaxLeafSize = 4;
constexpr double kTraversalCost = 1.0;
constexpr double kIntersectionCost = 1.0;
// Below this depth the SAH decides; deeper, nodes split at the median on the widest centroid
// axis, so adversarial inputs (e.g. exponentially spaced primitives) keep the tree depth below
// kMaxSahDepth + log2(N) < kMaxTraversalDepth (bvh.hpp).
constexpr int kMaxSahDepth = 40;

// Subtrees of at least this many primitives build on their own thread (the two children of a
// node are independent: disjoint ranges of `order`, separate node arrays spliced afterwards, so
// the tree is the same as a sequential build's). Below it a subtree takes < ~10 ms, next to
// ~0.1 ms to start a thread.
constexpr uint32_t kParallelBuildMinPrimitives = 1u << 15;
// Nodes of at least this many primitives bin all three axes in one pass (see build()); 256
// primitives' data (~20 kB) is where it stops being in L1 cache.
constexpr uint32_t kOnePassBinningMinPrimitives = 256;

struct Bin {
    Bounds bounds, centres;
    uint32_t count = 0;
};

struct Builder {
    const std::vector<Bounds>& prim_bounds;
    std::vector<Vec3> centroids;
    std::vector<uint32_t>& order;
    int parallel_splits = 0;  // how many more times a subtree may split across threads

    static void set_bounds(BvhNode& node, const Bounds& b) {
        const double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
        for (int k = 0; k < 3; ++k) {
            node.lo[k] = round_down(lo[k]);
            node.hi[k] = round_up(hi[k]);
        }
    }

    static void make_leaf(BvhNode& node, uint32_t begin, uint32_t end) {
        node.offset = int32_t(begin);
        node.count = int16_t(end - begin);
        node.axis = 0;
    }

    void measure(uint32_t begin, uint32_t end, Bounds& bounds, Bounds& centre_bounds) const {
        for (uint32_t i = begin; i < end; ++i) {
            bounds.grow(prim_bounds[order[i]]);
            centre_bounds.grow(centroids[order[i]]);
        }
    }

    // Builds the subtree of order[begin, end) into nodes[index] (already allocated), appending
    // its descendants depth-first. `bounds` and `centre_bounds` are those of the primitives.
    void build(std::vector<BvhNode>& nodes, int32_t index, uint32_t begin, uint32_t end, int depth,
               const Bounds& bounds, const Bounds& centre_bounds, int parallel_splits) {
        set_bounds(nodes[index], bounds);
        const uint32_t n = end - begin;
        if (n <= 1) { make_leaf(nodes[index], begin, end); return; }

        // Bins of the three axes: large nodes in one pass over the primitives (their data comes
        // from memory; the bins also collect centroid bounds, so the children need no pass of
        // their own); small ones (in cache) one axis at a time (fewer bins to initialise).
        Bin bins[3][kBins];
        const Vec3 extent = centre_bounds.hi - centre_bounds.lo;
        const double lo[3] = {centre_bounds.lo.x, centre_bounds.lo.y, centre_bounds.lo.z};
        const bool binned[3] = {extent.x > 0.0, extent.y > 0.0, extent.z > 0.0};
        const double scale[3] = {kBins / extent.x, kBins / extent.y, kBins / extent.z};
        const bool one_pass = n >= kOnePassBinningMinPrimitives;
        if (one_pass) {
            for (uint32_t i = begin; i < end; ++i) {
                const uint32_t prim = order[i];
                const Vec3& c = centroids[prim];
                const double cs[3] = {c.x, c.y, c.z};
                for (int axis = 0; axis < 3; ++axis) {
                    if (!binned[axis]) continue;
                    Bin& bin = bins[axis][bin_of(cs[axis], lo[axis], scale[axis])];
                    bin.count++;
                    bin.bounds.grow(prim_bounds[prim]);
                    bin.centres.grow(c);
                }
            }
        }

        // Best binned split over the three axes.
        double best_cost = HUGE_VAL;
        int best_axis = -1, best_split = 0;
        for (int axis = 0; axis < 3; ++axis) {
            if (!binned[axis]) continue;
            Bin* bin = bins[axis];
            if (!one_pass) {
                for (uint32_t i = begin; i < end; ++i) {
                    Bin& b = bin[bin_of(centroids[order[i]][axis], lo[axis], scale[axis])];
                    b.count++;
                    b.bounds.grow(prim_bounds[order[i]]);
                }
            }
            // Sweep over the non-empty bins only: a small node (most nodes) fills few of the
            // kBins, and the sweep's unions and areas were the build's largest per-node cost.
            // The result is the same as a sweep over every bin: an empty bin changes neither a
            // side's union (Bounds::grow by an empty box is exact identity) nor its count, so
            // every split between two consecutive non-empty bins j and j' costs the same, and
            // the full sweep's strict `<` kept the first of them, split = j + 1, as here.
            int filled[kBins];
            int k = 0;
            for (int b = 0; b < kBins; ++b)
                if (bin[b].count > 0) filled[k++] = b;
            // Right-side areas and counts (position j: the filled bins from j on), then left side.
            double right_area[kBins];
            uint32_t right_count[kBins];
            Bounds acc;
            uint32_t count = 0;
            for (int j = k - 1; j > 0; --j) {
                acc.grow(bin[filled[j]].bounds);
                count += bin[filled[j]].count;
                right_area[j] = acc.half_area();
                right_count[j] = count;
            }
            acc = Bounds();
            count = 0;
            for (int j = 0; j < k - 1; ++j) {
                acc.grow(bin[filled[j]].bounds);
                count += bin[filled[j]].count;
                const double cost = count * acc.half_area() + right_count[j + 1] * right_area[j + 1];
                if (cost < best_cost) { best_cost = cost; best_axis = axis; best_split = filled[j] + 1; }
            }
        }

        const double area = bounds.half_area();
        const double leaf_cost = kIntersectionCost * n;
        const double split_cost = area > 0.0 ? kTraversalCost + kIntersectionCost * best_cost / area : HUGE_VAL;
        uint32_t mid;
        // The children's bounds: from the bins after a binned split, else measured.
        Bounds left_bounds, left_centres, right_bounds, right_centres;
        bool measured = false;
        if (best_axis < 0) {
            // All centroids coincide: split by count when too many for one leaf.
            if (n <= kMaxLeafSize) { make_leaf(nodes[index], begin, end); return; }
            mid = begin + n / 2;
            best_axis = 0;
        } else if (depth >= kMaxSahDepth) {
            if (n <= kMaxLeafSize) { make_leaf(nodes[index], begin, end); return; }
            const int axis = extent.x >= extent.y ? (extent.x >= extent.z ? 0 : 2) : (extent.y >= extent.z ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                             [&](uint32_t p, uint32_t q) { return centroids[p][axis] < centroids[q][axis]; });
            best_axis = axis;
        } else {
            if (n <= kMaxLeafSize && leaf_cost <= split_cost) { make_leaf(nodes[index], begin, end); return; }
            const int axis = best_axis, split = best_split;
            const double axis_lo = lo[axis], axis_scale = scale[axis];
            auto it = std::partition(order.begin() + begin, order.begin() + end, [&](uint32_t p) {
                return bin_of(centroids[p][axis], axis_lo, axis_scale) < split;
            });
            mid = uint32_t(it - order.begin());
            if (mid == begin || mid == end) {
                mid = begin + n / 2;  // cannot happen; stay safe
            } else if (one_pass) {
                for (int b = 0; b < kBins; ++b) {
                    const Bin& bin = bins[axis][b];
                    (b < split ? left_bounds : right_bounds).grow(bin.bounds);
                    (b < split ? left_centres : right_centres).grow(bin.centres);
                }
                measured = true;
            }
        }
        if (!measured) {
            measure(begin, mid, left_bounds, left_centres);
            measure(mid, end, right_bounds, right_centres);
        }
        nodes[index].count = 0;
        nodes[index].axis = int16_t(best_axis);
        const int32_t left = int32_t(nodes.size());
        nodes.emplace_back();
        if (parallel_splits > 0 && std::min(mid - begin, end - mid) >= kParallelBuildMinPrimitives) {
            // The right subtree into its own array on another thread, spliced after the left.
            std::vector<BvhNode> right_nodes(1);
            right_nodes.reserve(2 * size_t(end - mid));
            auto right_built = std::async(std::launch::async, [&] {
                build(right_nodes, 0, mid, end, depth + 1, right_bounds, right_centres, parallel_splits - 1);
            });
            build(nodes, left, begin, mid, depth + 1, left_bounds, left_centres, parallel_splits - 1);
            right_built.get();
            const int32_t right = int32_t(nodes.size());
            for (BvhNode& node : right_nodes)
                if (node.count == 0) node.offset += right;  // interior: the second child's index
            nodes.insert(nodes.end(), right_nodes.begin(), right_nodes.end());
            nodes[index].offset = right;
        } else {
            build(nodes, left, begin, mid, depth + 1, left_bounds, left_centres, parallel_splits);
            const int32_t right = int32_t(nodes.size());
            nodes.emplace_back();
            build(nodes, right, mid, end, depth + 1, right_bounds, right_centres, parallel_splits);
            nodes[index].offset = right;
        }
    }
};

}  // namespace

void Bvh::build(const std::vector<Bounds>& prim_bounds) {
    nodes.clear();
    order.resize(prim_bounds.size());
    std::iota(order.begin(), order.end(), 0u);
    if (prim_bounds.empty()) return;
    nodes.reserve(2 * prim_bounds.size());
    Builder builder{prim_bounds, {}, order};
    builder.centroids.resize(prim_bounds.size());
    for (size_t i = 0; i < prim_bounds.size(); ++i)
        builder.centroids[i] = (prim_bounds[i].lo + prim_bounds[i].hi) * 0.5;
    // Up to two subtrees per hardware thread (the halves of a split are rarely equal).
    int parallel_splits = 1;
    for (unsigned threads = std::thread::hardware_concurrency(); threads > 1; threads /= 2) parallel_splits++;
    Bounds bounds, centre_bounds;
    builder.measure(0, uint32_t(prim_bounds.size()), bounds, centre_bounds);
    nodes.emplace_back();
    builder.build(nodes, 0, 0, uint32_t(prim_bounds.size()), 0, bounds, centre_bounds, parallel_splits);
    nodes.shrink_to_fit();
}

}  // namespace phong
