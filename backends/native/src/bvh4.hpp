// SPDX-License-Identifier: Apache-2.0
// The 4-wide BVH the rays walk: the binary SAH tree (bvh.hpp) collapsed so that each node holds
// the float boxes of up to four children in SoA layout, tested against one ray with one SSE slab
// test (baseline x86-64: SSE2, no -march), hit children visited nearest first.
//
// The float slab test is conservative: a box may be entered spuriously, never missed where the
// exact primitive test (double) hits a primitive inside it; so the primitives tested, and with
// them every image, are those of a double-precision walk (FloatSlabRay says why, and when a ray
// takes the double-precision test instead).
#pragma once

#include <emmintrin.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "bvh.hpp"
#include "math.hpp"

namespace phong {

// Four children: boxes[k][i] is child i's lower bound along axis k (k < 3) or its upper bound
// along axis k − 3, as the binary tree stores it (rounded outward from double). An empty slot
// has the empty box lo = +inf, hi = −inf, which no ray enters (every slab distance of it is +inf
// on the near side or −inf on the far side, or NaN, which the test ignores, on at most two axes).
struct alignas(64) Bvh4Node {
    float boxes[6][4];
    int32_t child[4];  // count == 0: index of an interior node (−1: empty slot); else first primitive ref
    int32_t count[4];  // primitives of a leaf child; 0 for an interior child
};

// The wide nodes, root at 0. A large tree's nodes lie in regions with unused slots between them
// (bvh4.cpp), never written and never reached from the root: walk the tree, not the array.
using Bvh4Nodes = UninitialisedVector<Bvh4Node>;

// Collapses `binary` (Bvh::nodes, root at 0) into 4-wide nodes, root at 0 (empty when `binary`
// is). Each node takes a binary node's two children, then repeatedly opens the interior child of
// largest surface area, until it has four. Leaves keep their primitive ranges.
Bvh4Nodes collapse_to_bvh4(const BvhNodes& binary);

// Calls fn(node) for every node reachable from the root of a wide tree, depth-first, children in
// slot order (tests and digests: the order does not depend on where the regions lie).
template <class Nodes, class Fn>
void for_each_wide_node(const Nodes& nodes, Fn&& fn) {
    if (nodes.empty()) return;
    constexpr int width = int(sizeof(nodes[0].child) / sizeof(nodes[0].child[0]));
    std::vector<int32_t> pending{0};
    while (!pending.empty()) {
        const auto& node = nodes[size_t(pending.back())];
        pending.pop_back();
        fn(node);
        for (int i = width - 1; i >= 0; --i)
            if (node.count[i] == 0 && node.child[i] >= 0) pending.push_back(node.child[i]);
    }
}

// Largest number of pending children in a walk: a node replaces itself by at most four, and
// the collapsed tree is no deeper than the binary one (kMaxTraversalDepth).
constexpr int kMaxBvh4Stack = 3 * kMaxTraversalDepth + 1;

// ---------------------------------------------------------------------------------------------
// The float slab test and why it never misses.
//
// Let a primitive be hit at t_h in (t_min, t_max) inside a child's box B (its hit point lies in
// its bounds, which B contains). Exactly, every slab of B then has near_k <= t_h <= far_k. The
// test computes, per axis k with near plane p (lo_k when the direction's sign bit is clear, else
// hi_k) and far plane q:
//   near_k = fl(fl(p − o⁺) · r),   far_k = fl(fl(q − o⁻) · r),   r = float(1/d_k),
// where o⁺ and o⁻ are the origin rounded to float toward the side that makes the exact
// distances (p − o⁺)/d_k <= near_k and (q − o⁻)/d_k >= far_k: the origin's rounding costs
// nothing. What is left is three roundings to nearest float (u = 2^-24 each): the subtraction,
// the reciprocal (1/d_k in double, then to float: u + 2^-53, still below 1.0001u), the product.
// So a computed distance is x·(1 + θ), |θ| <= γ(3) = 3u/(1 − 3u) (Higham), x the exact
// directed-origin distance, as long as no result is subnormal or overflows (the conditions
// below exclude both for the distances that matter).
// Then computed near_k <= t_h·(1 + γ) and computed far_k >= t_h·(1 − γ), so the test
//   t0 = max(near_x, near_y, near_z, t_min↓),  t1 = min(fl(min(far_x, far_y, far_z) · W), t_max↑)
// has t0 <= t1 when W·(1 − γ)(1 − u) >= 1 + γ (the product by W rounds too), i.e.
// W >= 1 + 7u + O(u²), and t_max↑ >= t_max·(1 + γ). kFloatSlabWidening = 1 + 8u = 1 + 2^-21
// satisfies both with a margin of u (a float, so W is exact); t_min↓ and t_max↑ are t_min and
// t_max·W rounded down and up to float.
// NaN: a slab distance 0·inf (the origin on a slab plane, the direction parallel to it) is NaN;
// max/min take their second operand when one is NaN (SSE's maxps/minps rule), which keeps the
// running bound: the slab is ignored, as the double test does (hit_node, which chooses the
// planes by the sign bit in the same way, so that −0 counts as negative). A reciprocal beyond the float
// range (|d_k| < ~2^-128 but not 0) is made NaN for the same effect: that axis does not cull.
// Conditions, checked per ray (else the ray takes the double test, hit_node's, on the same
// nodes): t_min >= kFloatSlabMinTMin, so every distance compared with t_min↓ or t_h is a
// normal float; |o|∞ and the scene's largest coordinate <= kFloatSlabMaxCoordinate and
// kFloatSlabMinDirection <= |d|∞ <= kFloatSlabMaxDirection, so every hit lies at
// t_h <= 2·√3·1e30 / 2^-20 < 4e36, far below FLT_MAX (a near distance that overflows to +inf
// is beyond every hit; a far one that overflows errs on the safe side), and no reciprocal of a
// component that matters is subnormal.
constexpr float kFloatSlabWidening = 1.0f + 0x1p-21f;
constexpr double kFloatSlabMinTMin = 0x1p-125;
constexpr double kFloatSlabMaxCoordinate = 1e30;
constexpr double kFloatSlabMinDirection = 0x1p-20;
constexpr double kFloatSlabMaxDirection = 0x1p20;

// A ray origin rounded to float down and up per axis (o⁻ and o⁺ above): rays that share their
// origin (a perspective camera's, the shadow rays of one shaded point) round it once, in SSE2
// lanes (OutwardFloats, bvh.hpp). Every shaded point rounds its own: S1's render 1.4 % fewer
// instructions than with the scalar functions (tests/native/test_native_bvh4.py checks the lanes
// against them bit for bit).
struct FloatSlabOrigin {
    alignas(16) float down[4], up[4];  // x, y, z (lane 3 unused)
    explicit FloatSlabOrigin(const Vec3& o) {
        const OutwardFloats rounded(o);
        _mm_store_ps(down, rounded.down());
        _mm_store_ps(up, rounded.up());
    }
};

// A ray set up for the float slab test of 4 children at once.
struct FloatSlabRay {
    __m128 origin_near[3], origin_far[3], inv[3];
    int near_row[3], far_row[3];  // rows of Bvh4Node::boxes: the near and far planes per axis
    __m128 t_min;

    // `inv` = (1/dir.x, 1/dir.y, 1/dir.z) in double; `origin` the ray's, rounded.
    FloatSlabRay(const FloatSlabOrigin& origin, const Vec3& dir, const Vec3& inv_dir, double t_min_) {
        const double d[3] = {dir.x, dir.y, dir.z};
        const double r[3] = {inv_dir.x, inv_dir.y, inv_dir.z};
        for (int k = 0; k < 3; ++k) {
            const bool negative = std::signbit(d[k]);
            near_row[k] = negative ? 3 + k : k;
            far_row[k] = negative ? k : 3 + k;
            // Positive direction: near = (lo − o)/d is smallest with o rounded up, far = (hi − o)/d
            // largest with o rounded down; a negative one swaps the two.
            origin_near[k] = _mm_set1_ps(negative ? origin.down[k] : origin.up[k]);
            origin_far[k] = _mm_set1_ps(negative ? origin.up[k] : origin.down[k]);
            const float inv_k = std::fabs(r[k]) <= double(FLT_MAX) ? float(r[k])
                                : d[k] == 0.0                      ? float(r[k])  // ±inf, as the double test
                                                                   : NAN;         // see above: no culling on k
            inv[k] = _mm_set1_ps(inv_k);
        }
        t_min = _mm_set1_ps(round_down(t_min_));
    }

    // Whether the float test's error bound holds for this ray (see above).
    // (Plain comparisons: std::fmax, in max_abs_component, is a libm call.)
    static bool applies(const Vec3& origin, const Vec3& dir, double t_min, double scene_magnitude) {
        auto within = [](double x, double limit) { return x <= limit && x >= -limit; };
        const double d = std::fabs(dir.x) > std::fabs(dir.y) ? std::fabs(dir.x) : std::fabs(dir.y);
        const double d_max = d > std::fabs(dir.z) ? d : std::fabs(dir.z);
        return t_min >= kFloatSlabMinTMin && scene_magnitude <= kFloatSlabMaxCoordinate &&
               within(origin.x, kFloatSlabMaxCoordinate) && within(origin.y, kFloatSlabMaxCoordinate) &&
               within(origin.z, kFloatSlabMaxCoordinate) && d_max >= kFloatSlabMinDirection &&
               d_max <= kFloatSlabMaxDirection;
    }

    // t_max↑ for hit(): t_max·W rounded up to float.
    static __m128 far_limit(double t_max) { return _mm_set1_ps(round_up(t_max * double(kFloatSlabWidening))); }

    // Bit i set when child i's box is entered; entry[i] its t0 (a lower bound of any hit inside).
    int hit(const Bvh4Node& node, __m128 t_max_up, __m128& entry) const {
        __m128 t0 = t_min, t1 = _mm_set1_ps(INFINITY);
        for (int k = 0; k < 3; ++k) {
            const __m128 near = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.boxes[near_row[k]]), origin_near[k]), inv[k]);
            const __m128 far = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.boxes[far_row[k]]), origin_far[k]), inv[k]);
            t0 = _mm_max_ps(near, t0);  // NaN near: t0
            t1 = _mm_min_ps(far, t1);   // NaN far: t1
        }
        t1 = _mm_min_ps(_mm_mul_ps(t1, _mm_set1_ps(kFloatSlabWidening)), t_max_up);
        entry = t0;
        return _mm_movemask_ps(_mm_cmple_ps(t0, t1));
    }
};

// One child's box of a node (4- or 8-wide), in the shape hit_node() and the bundle tests take.
struct ChildBox {
    float lo[3], hi[3];
    template <class Node>  // Bvh4Node or Bvh8Node (bvh8.hpp)
    ChildBox(const Node& node, int i)
        : lo{node.boxes[0][i], node.boxes[1][i], node.boxes[2][i]},
          hi{node.boxes[3][i], node.boxes[4][i], node.boxes[5][i]} {}
};

// Walks the 4-wide BVH; `leaf(first, count, t_max)` tests a leaf's primitives and returns true
// to stop the walk (any-hit); it may shrink t_max (closest hit), after which pending children
// whose entry lies beyond it are skipped. `ordered`: visit hit children nearest first (closest
// hit); any-hit walks take them as they come. `origin` is FloatSlabOrigin(ray.origin).
template <bool ordered, class LeafFn>
void traverse_bvh4(const Bvh4Nodes& nodes, double scene_magnitude, const Ray& ray, const FloatSlabOrigin& origin,
                   double t_min, double& t_max, LeafFn&& leaf) {
    if (nodes.empty()) return;
    struct Pending {
        int32_t child, count;
        float entry;
    };
    Pending stack[kMaxBvh4Stack];
    int sp = 0;
    Pending current{0, 0, 0.0f};
    const bool float_test = FloatSlabRay::applies(ray.origin, ray.dir, t_min, scene_magnitude);
    // The double-precision fallback (hit_node per child) for rays outside the float test's range.
    const Vec3 inv{1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z};
    const FloatSlabRay fray(origin, ray.dir, inv, t_min);
    __m128 t_max_up = FloatSlabRay::far_limit(t_max);
    float t_max_f = _mm_cvtss_f32(t_max_up);
    while (true) {
        if (current.count == 0) {
            const Bvh4Node& node = nodes[size_t(current.child)];
            alignas(16) float entry[4];
            int mask = 0;
            if (float_test) {
                __m128 e;
                mask = fray.hit(node, t_max_up, e);
                _mm_store_ps(entry, e);
            } else {
                for (int i = 0; i < 4; ++i) {
                    double t_entry;
                    // An any-hit walk's boxes uncapped (hit_node's cap, kAnyHitBoxLimit).
                    if (hit_node(ChildBox(node, i), ray.origin, inv, t_min, ordered ? t_max : kAnyHitBoxLimit,
                                 t_entry)) {
                        mask |= 1 << i;
                        entry[i] = round_down(t_entry);
                    }
                }
            }
            if (mask != 0) {
                Pending hits[4];
                int n = 0;
                for (int i = 0; i < 4; ++i) {
                    if (!(mask & (1 << i))) continue;
                    Pending p{node.child[i], node.count[i], entry[i]};
                    int j = n++;
                    if (ordered)  // insertion by entry, nearest first
                        for (; j > 0 && hits[j - 1].entry > p.entry; --j) hits[j] = hits[j - 1];
                    hits[j] = p;
                }
                for (int j = n - 1; j > 0; --j) stack[sp++] = hits[j];
                current = hits[0];
                continue;
            }
        } else {
            const double before = t_max;
            if (leaf(current.child, current.count, t_max)) return;
            if (t_max != before) {
                t_max_up = FloatSlabRay::far_limit(t_max);
                t_max_f = _mm_cvtss_f32(t_max_up);
            }
        }
        // Next pending child whose entry is not beyond t_max (a closer hit was found since).
        do {
            if (sp == 0) return;
            current = stack[--sp];
        } while (ordered && current.entry > t_max_f);
    }
}

}  // namespace phong
