// SPDX-License-Identifier: Apache-2.0
// Binned SAH BVH build (Wald, "On fast construction of SAH-based bounding volume
// hierarchies", 2007), flattened depth-first.
#include "bvh.hpp"

#include "build_threads.hpp"
#include "huge_pages.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <future>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>

namespace phong {

namespace {

// Four floats in one SSE register (a GCC/Clang vector extension, so no intrinsics and no
// x86-only code): a box's lo or hi in lanes 0-2; lane 3 is ignored.
typedef float Float4 __attribute__((vector_size(16)));
typedef int32_t Int4 __attribute__((vector_size(16)));

inline Float4 min4(Float4 a, Float4 b) { return b < a ? b : a; }
inline Float4 max4(Float4 a, Float4 b) { return b > a ? b : a; }
inline Float4 load_lo(const PrimRef& p) {
    Float4 v;
    std::memcpy(&v, &p.lo, sizeof v);  // lo[3] and id: lane 3 (the id's bits) is never used
    return v;
}
inline Float4 load_hi(const PrimRef& p) {
    Float4 v;
    std::memcpy(&v, &p.hi, sizeof v);
    return v;
}

constexpr float kHugeF = HUGE_VALF;

struct Box4 {
    Float4 lo{kHugeF, kHugeF, kHugeF, kHugeF};
    Float4 hi{-kHugeF, -kHugeF, -kHugeF, -kHugeF};

    void grow(Float4 l, Float4 h) {
        lo = min4(lo, l);
        hi = max4(hi, h);
    }
    void grow(const Box4& b) { grow(b.lo, b.hi); }
    bool empty() const { return lo[0] > hi[0]; }
    // Half the surface area (the SAH only needs ratios).
    float half_area() const { return empty() ? 0.0f : half_area_of_filled(); }
    // The same of a box that holds something (a primitive's, or one grown by a filled bin's),
    // without the empty test: the SAH sweeps call it ~20M times in S2's build. (The three
    // products in one vector multiply, the same floats, made S2's build 15 % slower at one
    // thread for 2 % fewer instructions: benchmarks/README.md.)
    float half_area_of_filled() const {
        const Float4 e = hi - lo;
        return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
    }
};

// SAH constants. The binary tree is walked as 4- or 8-wide nodes (bvh4.hpp, bvh8.hpp), one
// visit testing every child's box at once, and leaves stop at kMaxLeafSize primitives. The
// traversal cost trades render speed against the tree's memory: 1 (a visit costs about one
// primitive test) gives the fastest render, 2 the smaller tree. Measured (benchmarks/README.md,
// "Issue 25: the SAH's traversal cost by scene size"): cost 2 makes a 10M-triangle mesh's tree
// 493 -> ~290 MiB (whole process 1303 -> 1103 MiB, issue 23.4's goal) but renders S1 with 5 %
// more instructions (its four spheres become two leaves of two: a ray meeting one tests both) and S2 at
// 100k triangles with 4 % more. At 1M triangles (S2) cost 1 renders 2-3 % faster but builds
// ~10 % slower, a loss at one sample a pixel; below kSmallTreeTraversalCostBelow primitives the
// build takes milliseconds and the tree ~21 B a primitive more (under 1.4 MiB), so those
// scenes take cost 1. The closest hit does not depend on the tree (ties go to the lower
// primitive id), so images are the same either way. (Trees whose leaves the float prefilter
// tests eight triangles at a time weigh a leaf differently: kLaneLeavesTraversalCost below.)
constexpr int kBins = 16;
// Nodes of fewer primitives bin into kFewBins: their cost is mostly per node (emptying and
// sweeping 3 x kBins bins for 9-31 primitives), and half the bins halve it. S2's build 0.415 ->
// 0.395 s at one thread; render CPU unchanged (0.344-0.346 s); below 64 instead of 32 saved
// nothing more measurable.
constexpr uint32_t kFewBinsBelow = 32;
constexpr int kFewBins = 8;
constexpr int kMaxLeafSize = 8;
constexpr float kLargeTreeTraversalCost = 2.0f;
constexpr float kSmallTreeTraversalCost = 1.0f;
constexpr uint32_t kSmallTreeTraversalCostBelow = 1u << 16;
constexpr float kIntersectionCost = 1.0f;
// The traversal cost for a node of at most kMaxLeafSize primitives that are all tested eight to
// an AVX pass (LaneIds: triangles with float corners on the AVX2 walk): as a leaf they cost one
// pass of the prefilter plus the exact tests of the few it keeps, about one node visit (eight
// boxes in one AVX test), whatever their number. At this cost no split of such a node pays (its
// cost is at least 8 + the children's), so it becomes a leaf; a node holding any other
// primitive is weighed as before. Measured (benchmarks/README.md, "Issue 25: leaves of eight for the prefilter"),
// against the cost-2 tree, three alternating rounds: S2's build 0.233-0.267 -> 0.204-0.210 s of
// CPU, its render 0.217-0.218 -> 0.193-0.196 s (its shadow rays from the torus 268 -> ~210 ns:
// 10.3 -> 9.2 node visits a ray), S2-100k's render 0.157-0.172 -> 0.146-0.148 s; S2's scene
// after the build 268 -> 247 MiB. Cost 4 rendered S2 as fast and built it ~10 % slower.
constexpr float kLaneLeavesTraversalCost = float(kMaxLeafSize);
// Below this depth the SAH decides; deeper, nodes split at the median on the widest centroid
// axis, so adversarial inputs (e.g. exponentially spaced primitives) keep the tree depth below
// kMaxSahDepth + log2(N / kExactSahMaxPrimitives) + kExactSahMaxPrimitives - 1
// <= 44 + log2(N) < kMaxTraversalDepth (bvh.hpp).
constexpr int kMaxSahDepth = 40;
// Nodes of at most this many primitives evaluate every split instead of binning (each such
// split removes at least one primitive: at most kExactSahMaxPrimitives - 1 more levels).
constexpr uint32_t kExactSahMaxPrimitives = 8;
// The leaf bound's safety factor (Builder::no_split_pays): its float sum of at most 8 areas is
// within ~8 float roundings (~5e-7 relative) of the exact sum, far inside this.
constexpr float kLeafBoundMargin = 1.0f - 1e-4f;

// Subtrees of at least this many primitives build on their own thread (the two children of a
// node are independent: disjoint ranges of the primitives and of the node slots, Builder::build,
// so the collapsed tree is the same as a sequential build's). Below it a subtree takes < ~10 ms,
// next to ~0.1 ms to start a thread.
constexpr uint32_t kParallelBuildMinPrimitives = 1u << 15;
// A node this large, while no other thread builds (the root, before its children split across
// threads), bins its primitives in one chunk per hardware thread (merged bins are the same as
// one pass's: counts add, boxes unite).
constexpr uint32_t kParallelBinningMinPrimitives = 1u << 16;
// Nodes this large partition in kPartitionPieces fixed pieces, each in place, then swap the
// primitives left on the wrong side of the node's split point (Builder::piecewise_partition),
// the pieces and the swaps on the build's threads while no other thread builds. The pieces are
// fixed by the node's range, not by the threads, so the tree is the same on any number of them.
// S2's root and the node under it (1M primitives each: the root splits off the 2 ground
// triangles) took 3.5 ms each to partition on one thread while the other waited.
constexpr uint32_t kPiecewisePartitionMinPrimitives = 1u << 18;
constexpr uint32_t kPartitionPieces = 16;

// Nodes of at least this many primitives bin every binning_stride(n)-th of them only (by
// position from the node's first, so the same ones on any threads): 64 samples or more choose
// the split, and its sides are still exact (the partition classifies every primitive as the
// binning would, and measures the sides' bounds: the bins' boxes hold only the samples). Measured
// (callgrind, one thread; render at 320 x 180), against binning every primitive:
//   from 2^16: S2's build 3.383G -> 3.223G instructions, its render 154.661M -> 154.660M
//   from 2^14: 3.161G, render 154.742M;  from 2^12: 3.101G, 154.762M
//   from 2^10: 3.041G (-10 %), render 154.739M (+0.05 %); S2-100k's build -8 %, render +0.05 %
// and S2's build CPU 0.384-0.419 -> 0.336-0.337 s (5 alternating processes).
// Later (commit 632cf96's build, 2.571G at 2^10): from 2^9 2.540G, render 154.705M; from 2^8
// 2.509G, render 154.760M (S2-100k 134.772M -> 134.804M), build CPU medians 0.293 -> 0.280 s
// (best of 15 builds in each of 5 alternating processes); from 2^7 2.476G, S2-100k's render
// 134.853M, build CPU no lower than from 2^8.
// Every 4th primitive from there, every 8th from 2^12 (512 samples or more) and every 16th
// from 2^14 (1,024 or more). Against every 4th from 2^8 (the 2.509G above): S2's build 2.427G
// instructions, CPU medians 0.280 -> 0.262 s (as above); render instructions S2 154.760M ->
// 154.799M, S2-100k 134.804M -> 134.347M (every 8th from 2^12 alone: 155.148M and 134.128M: a
// tree that changes moves a render by a few tenths of a per cent either way).
constexpr uint32_t kSampledBinningMinPrimitives = 1u << 8;
constexpr uint32_t kEvery8thMinPrimitives = 1u << 12;
constexpr uint32_t kEvery16thMinPrimitives = 1u << 14;

// The stride of a node's binning: 1 (every primitive), 4, 8 or 16.
inline uint32_t binning_stride(uint32_t n) {
    return n >= kEvery16thMinPrimitives        ? 16
           : n >= kEvery8thMinPrimitives       ? 8
           : n >= kSampledBinningMinPrimitives ? 4
                                               : 1;
}

// Ranges this large bin into two alternating sets (Bins::add); below, copying the second set's
// 1.7 KB of empty bins would cost more than it saves.
constexpr uint32_t kTwoBinSetsMinPrimitives = 1024;

// Twice a primitive's centroid (lo + hi): the build only compares and bins centroids, so the
// halving would change nothing but cost a multiply.
inline Float4 centroid2(const PrimRef& p) { return load_lo(p) + load_hi(p); }

// Bins along the three axes of a node whose doubled centroids span [lo, lo + bins / scale)
// (bins: kBins, or kFewBins for a small node). bin() is the binning's classification, and
// partition() computes the same one along the split axis (so a split's sides hold exactly its
// bins' primitives). An unbinned axis (zero extent) has scale 0: every centroid falls in bin 0.
// A NaN (only from an input that escaped validation) goes to bin 0 too, and anything past the
// end to the last bin: never out of range.
struct BinGrid {
    Float4 lo, scale, last;  // last: the number of bins - 1 in every lane

    Int4 bin(Float4 c) const {
        Float4 f = (c - lo) * scale;
        f = f > 0.0f ? f : Float4{0.0f, 0.0f, 0.0f, 0.0f};  // NaN compares false: 0
        f = f < last ? f : last;
        return __builtin_convertvector(f, Int4);
    }
};

// A box as plain data (Box4 without its initialisers), so that Bins is trivially constructible.
struct RawBox {
    Float4 lo, hi;
};

struct Bins {
    RawBox box[3][kBins];
    uint32_t count[3][kBins];

    // Empty bins (boxes empty, counts 0), copied in one memcpy: initialising 48 boxes member by
    // member was the build's largest per-node cost (~280 instructions a node).
    static const Bins& empty() {
        static const Bins bins = [] {
            Bins b;
            const Box4 none;
            for (int axis = 0; axis < 3; ++axis)
                for (int k = 0; k < kBins; ++k) {
                    b.box[axis][k] = {none.lo, none.hi};
                    b.count[axis][k] = 0;
                }
            return b;
        }();
        return bins;
    }
    static void grow(RawBox& r, Float4 l, Float4 h) {
        r.lo = min4(r.lo, l);
        r.hi = max4(r.hi, h);
    }

    // Bins one primitive: a count and a box on each axis.
    void add_one(const PrimRef& p, const BinGrid& grid) {
        const Float4 l = load_lo(p), h = load_hi(p);
        const Int4 b = grid.bin(l + h);
        for (int axis = 0; axis < 3; ++axis) {
            count[axis][b[axis]]++;
            grow(box[axis][b[axis]], l, h);
        }
    }
    // Bins prims[begin, end). Large ranges alternate between these bins and a second set:
    // neighbouring primitives of a mesh mostly fall in the same bins, and each bin update waits
    // for the store of the one before; two sets halve that chain (merged, they are the same as
    // one pass's: counts add, boxes unite). Not inlined: inside build() the loop was compiled
    // to ~10 % slower code. (S2's build, one thread: 0.51 -> 0.49 s and 0.57 -> 0.52 s, best
    // of 10 in alternating processes.) The prefetch runs ~1 KiB ahead (2-3 % on S2's build).
    // With kStride > 1, only prims[begin], prims[begin + kStride], ... (sampled binning).
    template <uint32_t kStride = 1>
    __attribute__((noinline)) void add(const PrimRef* prims, uint32_t begin, uint32_t end, const BinGrid& grid) {
        uint32_t i = begin;
        if ((end - begin) / kStride >= kTwoBinSetsMinPrimitives) {
            Bins odd = Bins::empty();
            for (; i + kStride < end; i += 2 * kStride) {
                __builtin_prefetch(prims + i + 32);
                add_one(prims[i], grid);
                odd.add_one(prims[i + kStride], grid);
            }
            add(odd);
        }
        // The rest (a small range: all of it) in one set, its two halves interleaved: each bin
        // update still waits for the one before to the same bin, but that is now two
        // primitives back (neighbours in the range share bins far more often than primitives
        // half a range apart), which halves the chain as a second set would, without one.
        // (perf, eight S2 builds at one thread: this function's time 574 -> 507 ms; the same
        // bins, the same instructions.)
        const uint32_t half = i < end ? (end - i) / kStride / 2 * kStride : 0;  // (the pairs may pass end)
        for (const uint32_t stop = i + half; i < stop; i += kStride) {
            add_one(prims[i], grid);
            add_one(prims[i + half], grid);
        }
        for (i += half; i < end; i += kStride) add_one(prims[i], grid);
    }
    // Empties the first `used` bins of each axis.
    void reset(int used) {
        for (int axis = 0; axis < 3; ++axis) {
            std::memcpy(static_cast<void*>(box[axis]), empty().box[axis], size_t(used) * sizeof(RawBox));
            std::memset(count[axis], 0, size_t(used) * sizeof(uint32_t));
        }
    }
    void add(const Bins& other) {
        for (int axis = 0; axis < 3; ++axis)
            for (int b = 0; b < kBins; ++b) {
                count[axis][b] += other.count[axis][b];
                grow(box[axis][b], other.box[axis][b].lo, other.box[axis][b].hi);
            }
    }
};

struct Builder {
    PrimRefs& prims;
    BvhNode* nodes;        // 2n - 1 slots (Bvh::build)
    float traversal_cost;  // the SAH's cost of a node visit, in primitive tests (above)
    LaneIds lanes;         // the primitives tested eight to a pass (kLaneLeavesTraversalCost)

    static void make_leaf(BvhNode& node, uint32_t begin, uint32_t end) {
        node.offset = int32_t(begin);
        node.count = int16_t(end - begin);
        node.axis = 0;
    }

    // Bounds and doubled-centroid bounds of prims[begin, end).
    void measure(uint32_t begin, uint32_t end, Box4& bounds, Box4& centres) const {
        for (uint32_t i = begin; i < end; ++i) {
            const Float4 l = load_lo(prims[i]), h = load_hi(prims[i]);
            bounds.grow(l, h);
            centres.grow(l + h, l + h);
        }
    }

    // Bins prims[begin, end), or (sampled) every binning_stride(n)-th of them from begin.
    void bin(Bins& bins, uint32_t begin, uint32_t end, const BinGrid& grid, bool parallel) const {
        const uint32_t n = end - begin, stride = binning_stride(n);
        // Chunk [from, to)'s share: from its first sample on when sampled.
        auto add = [&](Bins& to_bins, uint32_t from, uint32_t to) {
            const uint32_t first = begin + (from - begin + stride - 1) / stride * stride;
            switch (stride) {
                case 1:
                    return to_bins.add<1>(prims.data(), first, to, grid);
                case 4:
                    return to_bins.add<4>(prims.data(), first, to, grid);
                case 8:
                    return to_bins.add<8>(prims.data(), first, to, grid);
                default:
                    return to_bins.add<16>(prims.data(), first, to, grid);
            }
        };
        // build_threads() may read sysfs: asked only of the few nodes large enough.
        const unsigned threads = parallel && n >= kParallelBinningMinPrimitives ? build_threads() : 1;
        if (threads < 2) {
            add(bins, begin, end);
            return;
        }
        std::vector<Bins> partial(threads - 1, Bins::empty());
        std::vector<std::future<void>> running;
        for (unsigned c = 1; c < threads; ++c)
            running.push_back(std::async(std::launch::async, [&, c] {
                add(partial[c - 1], begin + uint32_t(uint64_t(n) * c / threads),
                    begin + uint32_t(uint64_t(n) * (c + 1) / threads));
            }));
        add(bins, begin, begin + n / threads);
        for (unsigned c = 1; c < threads; ++c) {
            running[c - 1].get();
            bins.add(partial[c - 1]);
        }
    }

    // Builds the subtree of prims[begin, end) into nodes[index] (already allocated), its
    // descendants depth-first from nodes[next] on (`next` advances past them; the first child is
    // nodes[index + 1]). `bounds` and `centres` are those of the primitives (centres: doubled
    // centroids). `alone`: no other thread is building now.
    void build(int32_t index, int32_t& next, uint32_t begin, uint32_t end, int depth, const Box4& bounds,
               const Box4& centres, int parallel_splits, bool alone) {
        BvhNode& node = nodes[size_t(index)];
        for (int k = 0; k < 3; ++k) {
            node.lo[k] = bounds.lo[k];
            node.hi[k] = bounds.hi[k];
        }
        const uint32_t n = end - begin;
        if (n <= 1) {
            make_leaf(node, begin, end);
            return;
        }

        if (n <= kExactSahMaxPrimitives) {
            build_small(index, next, begin, end, depth, bounds, parallel_splits, alone);
            return;
        }
        const Float4 extent = centres.hi - centres.lo;
        const bool binned[3] = {extent[0] > 0.0f, extent[1] > 0.0f, extent[2] > 0.0f};
        const int used_bins = n < kFewBinsBelow ? kFewBins : kBins;
        const float last = float(used_bins - 1);
        BinGrid grid{centres.lo, {}, {last, last, last, last}};
        for (int k = 0; k < 3; ++k) grid.scale[k] = binned[k] ? float(used_bins) / extent[k] : 0.0f;
        grid.scale[3] = 0.0f;

        // Best binned split over the three axes.
        float best_cost = kHugeF;
        int best_axis = -1, best_split = 0;
        Bins bins;  // uninitialised: set from Bins::empty() only where binned
        const bool sampled = n >= kSampledBinningMinPrimitives;
        const bool any_binned = binned[0] || binned[1] || binned[2];
        if (any_binned && depth < kMaxSahDepth) {
            bins.reset(used_bins);
            bin(bins, begin, end, grid, alone);
            for (int axis = 0; axis < 3; ++axis) {
                if (!binned[axis]) continue;
                const uint32_t* count = bins.count[axis];
                const RawBox* box = bins.box[axis];
                // Sweep over the non-empty bins only: a small node (most nodes) fills few of
                // the kBins, and an empty bin changes neither a side's union nor its count, so
                // every split between two consecutive non-empty bins j and j' costs the same;
                // the strict `<` keeps the first of them, split = j + 1.
                int filled[kBins];
                int k = 0;
                for (int b = 0; b < used_bins; ++b) {  // branch-free: whether a bin is filled is random
                    filled[k] = b;
                    k += count[b] > 0;
                }
                // Right-side areas and counts (position j: the filled bins from j on), then left side.
                float right_area[kBins];
                uint32_t right_count[kBins];
                Box4 acc;
                uint32_t sum = 0;
                for (int j = k - 1; j > 0; --j) {
                    acc.grow(box[filled[j]].lo, box[filled[j]].hi);
                    sum += count[filled[j]];
                    right_area[j] = acc.half_area_of_filled();
                    right_count[j] = sum;
                }
                acc = Box4();
                sum = 0;
                for (int j = 0; j < k - 1; ++j) {
                    acc.grow(box[filled[j]].lo, box[filled[j]].hi);
                    sum += count[filled[j]];
                    const float cost =
                        float(sum) * acc.half_area_of_filled() + float(right_count[j + 1]) * right_area[j + 1];
                    if (cost < best_cost) {
                        best_cost = cost;
                        best_axis = axis;
                        best_split = filled[j] + 1;
                    }
                }
            }
        }

        uint32_t mid;
        Box4 left_bounds, left_centres, right_bounds, right_centres;
        bool measured = false;
        if (!any_binned) {
            // All centroids coincide: split by count when too many for one leaf.
            if (n <= kMaxLeafSize) {
                make_leaf(node, begin, end);
                return;
            }
            mid = begin + n / 2;
            best_axis = 0;
        } else if (depth >= kMaxSahDepth || best_axis < 0) {
            // (best_axis < 0: every split's cost overflowed float, on boxes beyond ~1e19.)
            if (n <= kMaxLeafSize) {
                make_leaf(node, begin, end);
                return;
            }
            const int axis =
                extent[0] >= extent[1] ? (extent[0] >= extent[2] ? 0 : 2) : (extent[1] >= extent[2] ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(prims.begin() + begin, prims.begin() + mid, prims.begin() + end,
                             [axis](const PrimRef& p, const PrimRef& q) {
                                 return p.lo[axis] + p.hi[axis] < q.lo[axis] + q.hi[axis];
                             });
            best_axis = axis;
        } else {
            const float area = bounds.half_area();
            const float leaf_cost = kIntersectionCost * float(n);
            const float split_cost = area > 0.0f ? traversal_cost + kIntersectionCost * best_cost / area : kHugeF;
            if (n <= kMaxLeafSize && leaf_cost <= split_cost) {
                make_leaf(node, begin, end);
                return;
            }
            if (n >= kPiecewisePartitionMinPrimitives)  // (sampled too: its sides' bounds are measured)
                mid = piecewise_partition(begin, end, grid, best_axis, best_split, left_centres, right_centres,
                                          left_bounds, right_bounds, alone);
            else
                mid = sampled ? partition<true>(begin, end, grid, best_axis, best_split, left_centres, right_centres,
                                                left_bounds, right_bounds)
                              : partition<false>(begin, end, grid, best_axis, best_split, left_centres, right_centres,
                                                 left_bounds, right_bounds);
            if (mid == begin || mid == end) {
                // Cannot happen: both sides' bins hold primitives (samples are primitives, and the
                // partition classifies them as the binning did); stay safe.
                mid = begin + n / 2;
                left_centres = right_centres = left_bounds = right_bounds = Box4();
            } else {
                if (!sampled)  // the bins' boxes are the sides' (sampled, the partition measured them)
                    for (int b = 0; b < used_bins; ++b)
                        (b < best_split ? left_bounds : right_bounds)
                            .grow(bins.box[best_axis][b].lo, bins.box[best_axis][b].hi);
                measured = true;
            }
        }
        if (!measured) {
            measure(begin, mid, left_bounds, left_centres);
            measure(mid, end, right_bounds, right_centres);
        }
        nodes[size_t(index)].count = 0;
        nodes[size_t(index)].axis = int16_t(best_axis);
        const int32_t left = next++;
        if (parallel_splits > 0 && std::min(mid - begin, end - mid) >= kParallelBuildMinPrimitives) {
            // The right subtree on another thread, in the same array past the most the left one
            // can take (a subtree of m primitives has at most 2m - 1 nodes): no copy to splice
            // the two, and the unused nodes between them are never written, so never resident.
            const int32_t right = left + 2 * int32_t(mid - begin) - 1;
            int32_t right_next = right + 1;
            auto right_built = std::async(std::launch::async, [&] {
                build(right, right_next, mid, end, depth + 1, right_bounds, right_centres, parallel_splits - 1, false);
            });
            build(left, next, begin, mid, depth + 1, left_bounds, left_centres, parallel_splits - 1, false);
            right_built.get();
            next = right_next;
            nodes[size_t(index)].offset = right;
        } else {
            build(left, next, begin, mid, depth + 1, left_bounds, left_centres, parallel_splits, alone);
            const int32_t right = next++;
            build(right, next, mid, end, depth + 1, right_bounds, right_centres, parallel_splits, alone);
            nodes[size_t(index)].offset = right;
        }
    }

    // A node of at most kExactSahMaxPrimitives: the exact SAH over every split of the primitives
    // sorted by centroid, on each axis (cheaper than 48 bins at this size, and no worse a tree).
    void build_small(int32_t index, int32_t& next, uint32_t begin, uint32_t end, int depth, const Box4& bounds,
                     int parallel_splits, bool alone) {
        const uint32_t n = end - begin;
        PrimRef* p = prims.data() + begin;
        const float visit = visit_cost(p, n);
        if (n <= kMaxLeafSize && no_split_pays(p, n, bounds.half_area(), visit)) {
            make_leaf(nodes[size_t(index)], begin, end);
            return;
        }
        // The boxes read once; the sorts below order 64-bit keys in registers, not 32-byte
        // primitives, and the primitives move once, at the end.
        Float4 lo[kExactSahMaxPrimitives], hi[kExactSahMaxPrimitives];
        for (uint32_t i = 0; i < n; ++i) {
            lo[i] = load_lo(p[i]);
            hi[i] = load_hi(p[i]);
        }
        uint8_t order[kExactSahMaxPrimitives];  // position j holds primitive p[order[j]]
        for (uint32_t i = 0; i < n; ++i) order[i] = uint8_t(i);
        float best_cost = kHugeF;
        int best_axis = -1;
        uint32_t best_count = 0;
        float right_area[kExactSahMaxPrimitives];
        for (int axis = 0; axis < 3; ++axis) {
            sort_by_centroid(order, n, lo, hi, axis);
            Box4 acc;
            for (uint32_t j = n - 1; j > 0; --j) {
                acc.grow(lo[order[j]], hi[order[j]]);
                right_area[j] = acc.half_area_of_filled();
            }
            acc = Box4();
            for (uint32_t j = 0; j + 1 < n; ++j) {
                acc.grow(lo[order[j]], hi[order[j]]);
                const float cost = float(j + 1) * acc.half_area_of_filled() + float(n - j - 1) * right_area[j + 1];
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_count = j + 1;
                }
            }
        }
        const float area = bounds.half_area();
        const float split_cost = area > 0.0f ? visit + kIntersectionCost * best_cost / area : kHugeF;
        if (n <= kMaxLeafSize && (best_axis < 0 || kIntersectionCost * float(n) <= split_cost)) {
            reorder(p, order, n);
            make_leaf(nodes[size_t(index)], begin, end);
            return;
        }
        if (best_axis < 0) best_axis = 0, best_count = n / 2;               // costs overflowed float: by count
        if (best_axis != 2) sort_by_centroid(order, n, lo, hi, best_axis);  // (the last sort was along axis 2)
        reorder(p, order, n);
        const uint32_t mid = begin + best_count;
        Box4 left_bounds, left_centres, right_bounds, right_centres;
        measure(begin, mid, left_bounds, left_centres);
        measure(mid, end, right_bounds, right_centres);
        BvhNode& node = nodes[size_t(index)];
        node.count = 0;
        node.axis = int16_t(best_axis);
        const int32_t left = next++;
        build(left, next, begin, mid, depth + 1, left_bounds, left_centres, parallel_splits, alone);
        const int32_t right = next++;
        build(right, next, mid, end, depth + 1, right_bounds, right_centres, parallel_splits, alone);
        nodes[size_t(index)].offset = right;
    }

    // The cost of a node visit for the n primitives at p as the SAH weighs it: lower where a
    // leaf of them would be tested eight to a pass (kLaneLeavesTraversalCost).
    float visit_cost(const PrimRef* p, uint32_t n) const {
        if (lanes.begin == lanes.end || n > uint32_t(kMaxLeafSize)) return traversal_cost;
        for (uint32_t i = 0; i < n; ++i)
            if (p[i].id < lanes.begin || p[i].id >= lanes.end) return traversal_cost;
        return kLaneLeavesTraversalCost;
    }

    // Whether the exact SAH below would make the n primitives a leaf, decided without sorting:
    // a split costs at least visit + kIntersectionCost * (sum of the primitives' areas)
    // / area, since each side's box holds each of its primitives' boxes. When n is no more
    // than that bound, no split can pay. On S2, 307k of the 577k nodes of at most 8 primitives
    // end here (0 of them split by the full test), their build 0.395 -> 0.388 s at one thread
    // (best of 8 in alternating processes; ~2 %). The same leaves as the full test's
    // (kLeafBoundMargin covers the float sums' rounding); only their order within a leaf
    // differs, and hits do not depend on it.
    bool no_split_pays(const PrimRef* p, uint32_t n, float area, float visit) const {
        if (area == 0.0f) return true;       // the full test: a split's cost is then infinite
        if (!(area < kHugeF)) return false;  // overflowed: leave it to the full test
        float sum = 0.0f;
        for (uint32_t i = 0; i < n; ++i) {
            Box4 box;
            box.grow(load_lo(p[i]), load_hi(p[i]));
            sum += box.half_area_of_filled();
        }
        if (!(sum < kHugeF)) return false;  // overflowed: leave it to the full test
        return kIntersectionCost * float(n) <= visit + kIntersectionCost * kLeafBoundMargin * sum / area;
    }

    // Sorts order[0, n) (n <= 8) by doubled centroid along `axis`, stably (ties keep their
    // order, so the result is an insertion sort's), with a sorting network on 64-bit keys: the
    // centroid's float bits made to order as unsigned integers, then the current position (the
    // primitive rides in the low byte). No
    // branch depends on the data: the insertion sort of the primitives this replaced
    // mispredicted its inner loop's exit about once a primitive (a node of <= 8 primitives
    // sorts three or four times). S2's build, one thread: 1 % more instructions (2.956G ->
    // 2.987G), 6 % less CPU (medians 0.344 -> 0.322 s and 0.352 -> 0.330 s, two rounds of 8
    // alternating processes); the same tree.
    static void sort_by_centroid(uint8_t* order, uint32_t n, const Float4* lo, const Float4* hi, int axis) {
        uint64_t key[8];
        for (uint32_t j = 0; j < 8; ++j) {
            if (j >= n) {
                key[j] = ~uint64_t(0);  // padding: after every real key
                continue;
            }
            const float c = (lo[order[j]] + hi[order[j]])[axis] + 0.0f;  // (+ 0: -0 becomes +0, as == has it)
            uint32_t bits;
            std::memcpy(&bits, &c, sizeof bits);
            bits = (bits >> 31) ? ~bits : bits | 0x80000000u;                 // ascending floats, ascending integers
            key[j] = (uint64_t(bits) << 32) | (uint64_t(j) << 8) | order[j];  // ties: by position
        }
        // Batcher's odd-even merge sort of 8 (19 compare-exchanges).
        auto exchange = [&key](int a, int b) {
            const uint64_t x = key[a], y = key[b];
            key[a] = x < y ? x : y;
            key[b] = x < y ? y : x;
        };
        exchange(0, 1), exchange(2, 3), exchange(4, 5), exchange(6, 7);
        exchange(0, 2), exchange(1, 3), exchange(4, 6), exchange(5, 7);
        exchange(1, 2), exchange(5, 6);
        exchange(0, 4), exchange(1, 5), exchange(2, 6), exchange(3, 7);
        exchange(2, 4), exchange(3, 5);
        exchange(1, 2), exchange(3, 4), exchange(5, 6);
        for (uint32_t j = 0; j < n; ++j) order[j] = uint8_t(key[j]);
    }

    // p[0, n) rearranged so that position j holds what was at order[j].
    static void reorder(PrimRef* p, const uint8_t* order, uint32_t n) {
        PrimRef moved[kExactSahMaxPrimitives];
        for (uint32_t j = 0; j < n; ++j) moved[j] = p[order[j]];
        std::copy(moved, moved + n, p);
    }

    // partition<true> of a large node in kPartitionPieces pieces: each piece partitioned in place
    // (its left primitives, then its right ones), then the k-th right primitive found before the
    // node's split point swapped with the k-th left one found after it, both counted in piece
    // order. `parallel` (no other thread builds): the pieces and the swaps on the build's
    // threads; the result is the same either way.
    uint32_t piecewise_partition(uint32_t begin, uint32_t end, const BinGrid& grid, int axis, int split,
                                 Box4& left_centres, Box4& right_centres, Box4& left_bounds, Box4& right_bounds,
                                 bool parallel) {
        struct Piece {
            uint32_t begin, end, mid;
            Box4 left_centres, right_centres, left_bounds, right_bounds;
        };
        const uint32_t n = end - begin;
        Piece pieces[kPartitionPieces];
        for (uint32_t c = 0; c < kPartitionPieces; ++c) {
            pieces[c].begin = begin + uint32_t(uint64_t(n) * c / kPartitionPieces);
            pieces[c].end = begin + uint32_t(uint64_t(n) * (c + 1) / kPartitionPieces);
        }
        auto partition_piece = [&](uint32_t c) {
            Piece& q = pieces[c];
            q.mid = partition<true>(q.begin, q.end, grid, axis, split, q.left_centres, q.right_centres, q.left_bounds,
                                    q.right_bounds);
        };
        const unsigned threads = parallel ? std::min(build_threads(), unsigned(kPartitionPieces)) : 1;
        if (threads < 2) {
            for (uint32_t c = 0; c < kPartitionPieces; ++c) partition_piece(c);
        } else {
            std::atomic<uint32_t> taken{0};
            auto work = [&] {
                for (uint32_t c; (c = taken.fetch_add(1)) < kPartitionPieces;) partition_piece(c);
            };
            std::vector<std::future<void>> helpers;
            for (unsigned t = 1; t < threads; ++t) helpers.push_back(std::async(std::launch::async, work));
            work();
            for (std::future<void>& h : helpers) h.get();
        }
        uint32_t mid = begin;
        for (const Piece& q : pieces) {
            mid += q.mid - q.begin;
            left_centres.grow(q.left_centres);
            right_centres.grow(q.right_centres);
            left_bounds.grow(q.left_bounds);
            right_bounds.grow(q.right_bounds);
        }
        // The misplaced: each piece's right primitives before `mid`, its left ones from `mid` on;
        // as many of one as of the other.
        struct Run {
            uint32_t begin, end;
        };
        Run rights[kPartitionPieces], lefts[kPartitionPieces];
        int n_rights = 0, n_lefts = 0;
        uint32_t misplaced = 0;
        for (const Piece& q : pieces) {  // (non-empty runs only)
            if (q.mid < std::min(q.end, mid)) {
                rights[n_rights++] = {q.mid, std::min(q.end, mid)};
                misplaced += std::min(q.end, mid) - q.mid;
            }
            if (std::max(q.begin, mid) < q.mid) lefts[n_lefts++] = {std::max(q.begin, mid), q.mid};
        }
        // Swaps misplaced pairs [from, to) (pair k: the k-th of the rights and of the lefts).
        PrimRef* const p = prims.data();
        auto swap_pairs = [&](size_t from, size_t to) {
            int r = 0, l = 0;
            uint32_t i = rights[0].begin, j = lefts[0].begin;
            // Step to pair `from`: skip whole runs, then into the run.
            for (size_t skip = from; skip > 0;) {
                const uint32_t left_in_run = rights[r].end - i;
                if (skip < left_in_run) {
                    i += uint32_t(skip);
                    break;
                }
                skip -= left_in_run;
                i = rights[++r].begin;
            }
            for (size_t skip = from; skip > 0;) {
                const uint32_t left_in_run = lefts[l].end - j;
                if (skip < left_in_run) {
                    j += uint32_t(skip);
                    break;
                }
                skip -= left_in_run;
                j = lefts[++l].begin;
            }
            for (size_t k = from; k < to; ++k) {
                if (i == rights[r].end) i = rights[++r].begin;
                if (j == lefts[l].end) j = lefts[++l].begin;
                std::swap(p[i++], p[j++]);
            }
        };
        if (misplaced == 0) return mid;
        if (parallel)
            for_chunks(misplaced, swap_pairs);
        else
            swap_pairs(0, misplaced);
        return mid;
    }

    // Moves the primitives whose bin along `axis` is below `split` to the front and returns
    // where the others start; collects both sides' centroid bounds on the way (the pass the
    // children would otherwise spend measuring them).
    //
    // Branch-free, in Lomuto's scheme: each primitive in turn swaps with the first of the right
    // side, whose start advances when the primitive went left. Below the top levels the side a
    // primitive goes to is close to random, and the two-ended scheme this replaced (a branch
    // per primitive) spent as long in mispredictions as the binning pass takes in all: S2's
    // build 0.69 -> 0.52 s at one thread, 0.41 -> 0.32 s at two (best of 10, alternating).
    // kMeasure: the sides' bounds too (after sampled binning).
    template <bool kMeasure>
    uint32_t partition(uint32_t begin, uint32_t end, const BinGrid& grid, int axis, int split, Box4& left_centres,
                       Box4& right_centres, Box4& left_bounds, Box4& right_bounds) {
        // grid.bin(c)[axis] < split in scalar arithmetic along the one axis: the same IEEE
        // operations as that vector lane, so the same bins. Clamping to [0, bins - 1] cannot
        // change the answer for 1 <= split <= bins - 1, and a NaN (bin 0) goes left.
        const float lo = grid.lo[axis], scale = grid.scale[axis], limit = float(split);
        PrimRef* const p = prims.data();
        uint32_t mid = begin;
        // Each side's centroid (and, kMeasure, box) bounds, indexed by the side: [0] right, [1]
        // left. Growing the one a primitive goes to by index takes no branch and no select.
        Box4 centres[2], boxes[2];
        for (uint32_t i = begin; i < end; ++i) {
            const bool left = !(((p[i].lo[axis] + p[i].hi[axis]) - lo) * scale >= limit);
            const PrimRef moved = p[i];
            p[i] = p[mid];
            p[mid] = moved;
            mid += left;
            const Float4 l = load_lo(moved), h = load_hi(moved), c = l + h;
            centres[left].grow(c, c);
            if constexpr (kMeasure) boxes[left].grow(l, h);
        }
        left_centres.grow(centres[1]);
        right_centres.grow(centres[0]);
        if constexpr (kMeasure) {
            left_bounds.grow(boxes[1]);
            right_bounds.grow(boxes[0]);
        }
        return mid;
    }
};

}  // namespace

void Bvh::build(PrimRefs prims, LaneIds lanes) {
    nodes.clear();
    order.clear();
    if (prims.empty()) return;
    if (prims.size() > kMaxBvhPrimitives) throw std::length_error("too many primitives for one BVH");
    const uint32_t n = uint32_t(prims.size());
    // At most 2n - 1 nodes; slots that are never written are never resident, so no
    // shrink_to_fit (its copy would double the nodes' peak memory).
    resize_huge(nodes, 2 * size_t(n) - 1);
    Builder builder{prims, nodes.data(),
                    n < kSmallTreeTraversalCostBelow ? kSmallTreeTraversalCost : kLargeTreeTraversalCost, lanes};
    // Up to two subtrees per build thread (the halves of a split are rarely equal); none with one.
    const unsigned threads = build_threads();
    int parallel_splits = threads > 1 ? 1 : 0;
    for (unsigned t = threads; t > 1; t /= 2) parallel_splits++;
    // The root's bounds, and at the end the leaf order, in chunks on the build's threads (S2 at
    // two threads: 1.0 and 1.5 ms serial before; unions of boxes are the same in any order).
    Box4 bounds, centres;
    std::mutex bounds_mutex;
    for_chunks(n, [&](size_t begin, size_t end) {
        Box4 chunk_bounds, chunk_centres;
        builder.measure(uint32_t(begin), uint32_t(end), chunk_bounds, chunk_centres);
        const std::lock_guard<std::mutex> lock(bounds_mutex);
        bounds.grow(chunk_bounds);
        centres.grow(chunk_centres);
    });
    int32_t next = 1;
    builder.build(0, next, 0, n, 0, bounds, centres, parallel_splits, true);
    resize_huge(order, n);
    for_chunks(n, [&](size_t begin, size_t end) {
        for (size_t k = begin; k < end; ++k) order[k] = prims[k].id;
    });
}

}  // namespace phong
