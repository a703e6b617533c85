// SPDX-License-Identifier: Apache-2.0
// The 8-wide BVH for CPUs with AVX2: the binary SAH tree collapsed like the 4-wide one
// (bvh4.hpp), eight child boxes per node tested against one ray with one AVX slab test. The
// walk is compiled for AVX2 by a target attribute and chosen at run time (simd_dispatch.hpp), so
// the extension still runs on any x86-64.
//
// Same images as the 4-wide walk: per lane the AVX test does the float operations of
// FloatSlabRay::hit (the same roundings, max/min keeping their second operand on NaN as SSE's
// do; no FMA: -ffp-contract=off), so a child is entered exactly when the 4-wide test would enter
// it, and the conservative-bound argument of bvh4.hpp holds unchanged. The primitives reached
// are those of the binary tree's leaves either way, and both closest-hit and any-hit answers
// are independent of the visiting order (Scene::closest_hit breaks exact ties by primitive id).
#pragma once

#include <immintrin.h>

#include <cassert>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "bvh.hpp"
#include "bvh4.hpp"
#include "math.hpp"
#include "simd_dispatch.hpp"
#include "uninitialised.hpp"

namespace phong {

// Eight children, laid out as Bvh4Node's four (an empty slot: lo = +inf, hi = −inf).
struct alignas(64) Bvh8Node {
    float boxes[6][8];
    int32_t child[8];  // count == 0: index of an interior node (−1: empty slot); else first primitive ref
    int32_t count[8];  // primitives of a leaf child; 0 for an interior child
};

// As Bvh4Nodes: walk the tree, not the array.
using Bvh8Nodes = UninitialisedVector<Bvh8Node>;

// Collapses `binary` into 8-wide nodes as collapse_to_bvh4 does into 4-wide ones (bvh4.cpp).
Bvh8Nodes collapse_to_bvh8(const BvhNodes& binary);

// A node replaces itself by at most eight pending children.
constexpr int kMaxBvh8Stack = 7 * kMaxTraversalDepth + 1;

// FloatSlabRay (bvh4.hpp) for eight children at once.
struct FloatSlabRay8 {
    __m256 origin_near[3], origin_far[3], inv[3];
    int near_row[3], far_row[3];
    __m256 t_min;

    // FloatSlabRay's constructor, the same numbers in eight lanes.
    PHONG_AVX2 FloatSlabRay8(const FloatSlabOrigin& origin, const Vec3& dir, const Vec3& inv_dir, double t_min_) {
        const double d[3] = {dir.x, dir.y, dir.z};
        const double r[3] = {inv_dir.x, inv_dir.y, inv_dir.z};
        float inv_f[3];
        bool negative[3];
        for (int k = 0; k < 3; ++k) {
            negative[k] = std::signbit(d[k]);
            inv_f[k] = slab_inverse(d[k], r[k]);
        }
        set(origin.down, origin.up, inv_f, negative, round_down(t_min_));
    }
    // From its numbers set up elsewhere (several rays' in lanes: FloatSlabLanes below): the
    // origin rounded down and up, the float inverse directions (slab_inverse), the directions'
    // sign bits and t_min rounded down.
    PHONG_AVX2 FloatSlabRay8(const float down[3], const float up[3], const float inv_f[3], const bool negative[3],
                             float t_min_down) {
        set(down, up, inv_f, negative, t_min_down);
    }

    // FloatSlabRay's float reciprocal of direction component d (r = 1/d in double): float(r)
    // where that is finite or d is ±0 (then ±inf, as the double test), else NaN (no culling on
    // this axis: bvh4.hpp).
    static float slab_inverse(double d, double r) {
        return std::fabs(r) <= double(FLT_MAX) ? float(r) : d == 0.0 ? float(r) : NAN;
    }

    // Bit i set when child i's box is entered; entry[i] its t0 (FloatSlabRay::hit, per lane).
    PHONG_AVX2 int hit(const Bvh8Node& node, __m256 t_max_up, __m256& entry) const {
        __m256 t0 = t_min, t1 = _mm256_set1_ps(INFINITY);
        for (int k = 0; k < 3; ++k) {
            const __m256 near =
                _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(node.boxes[near_row[k]]), origin_near[k]), inv[k]);
            const __m256 far =
                _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(node.boxes[far_row[k]]), origin_far[k]), inv[k]);
            t0 = _mm256_max_ps(near, t0);  // NaN near: t0
            t1 = _mm256_min_ps(far, t1);   // NaN far: t1
        }
        t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(kFloatSlabWidening)), t_max_up);
        entry = t0;
        return _mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
    }

  private:
    PHONG_AVX2 void set(const float down[3], const float up[3], const float inv_f[3], const bool negative[3],
                        float t_min_down) {
        for (int k = 0; k < 3; ++k) {
            near_row[k] = negative[k] ? 3 + k : k;
            far_row[k] = negative[k] ? k : 3 + k;
            // Positive direction: near = (lo − o)/d is smallest with o rounded up, far = (hi − o)/d
            // largest with o rounded down; a negative one swaps the two.
            origin_near[k] = _mm256_set1_ps(negative[k] ? down[k] : up[k]);
            origin_far[k] = _mm256_set1_ps(negative[k] ? up[k] : down[k]);
            inv[k] = _mm256_set1_ps(inv_f[k]);
        }
        t_min = _mm256_set1_ps(t_min_down);
    }
};

// round_down and round_up (bvh.hpp) of four doubles, lane by lane: OutwardFloats' operations.
PHONG_AVX2 inline void round_outward_lanes(__m256d x, __m128& down, __m128& up) {
    const __m128 f = _mm256_cvtpd_ps(x);
    const __m256d back = _mm256_cvtps_pd(f);
    // A 64-bit comparison mask narrowed to 32-bit lanes.
    auto narrow = [](__m256d m) PHONG_AVX2 {
        const __m256 m32 = _mm256_castpd_ps(m);
        return _mm_castps_si128(
            _mm_shuffle_ps(_mm256_castps256_ps128(m32), _mm256_extractf128_ps(m32, 1), _MM_SHUFFLE(2, 0, 2, 0)));
    };
    const __m128i above = narrow(_mm256_cmp_pd(back, x, _CMP_GT_OQ)),
                  below = narrow(_mm256_cmp_pd(back, x, _CMP_LT_OQ));
    const __m128i bits = _mm_castps_si128(f);
    const __m128i twice_sign = _mm_add_epi32(_mm_srai_epi32(bits, 31), _mm_srai_epi32(bits, 31));
    down = _mm_castsi128_ps(_mm_add_epi32(bits, _mm_and_si128(_mm_sub_epi32(_mm_set1_epi32(-1), twice_sign), above)));
    up = _mm_castsi128_ps(_mm_add_epi32(bits, _mm_and_si128(_mm_add_epi32(_mm_set1_epi32(1), twice_sign), below)));
}

// Up to eight rays' FloatSlabRay8 numbers (and FloatSlabRay::applies, far_limit) at once, four
// rays per AVX instruction in double: per lane the operations of FloatSlabOrigin, FloatSlabRay8's
// constructor, applies and far_limit, so each ray's numbers are those it would set up alone.
// For a light's shadow rays from a packet's points (Scene::occluded_tree_each), which each set
// up alone cost S2's render ~110 instructions a ray.
struct FloatSlabLanes {
    static constexpr int kRays = 64;                                // a bit each in a uint64_t
    alignas(16) float down[3][kRays], up[3][kRays], inv[3][kRays];  // by axis, then ray
    alignas(16) float far_up[kRays];                                // FloatSlabRay::far_limit(t_max[r])
    uint64_t negative[3];                                           // bit r: ray r's direction's sign bit on axis k
    uint64_t applies;                                               // bit r: FloatSlabRay::applies for ray r
    uint64_t bounded;  // bit r: ray r's float inverse directions are finite on every axis (never ±inf nor NaN)
    float t_min_down;  // round_down(t_min)

    PHONG_AVX2 void set_up(const Ray* rays, int count, double t_min, const double* t_max, double scene_magnitude) {
        assert(count >= 1 && count <= kRays);
        alignas(32) double o[3][kRays], d[3][kRays], limit[kRays];
        const int lanes = (count + 3) & ~3;  // whole groups of four
        for (int r = 0; r < lanes; ++r) {
            const int from = r < count ? r : 0;  // lanes past `count`: ray 0 again
            const Ray& ray = rays[from];
            o[0][r] = ray.origin.x, o[1][r] = ray.origin.y, o[2][r] = ray.origin.z;
            d[0][r] = ray.dir.x, d[1][r] = ray.dir.y, d[2][r] = ray.dir.z;
            limit[r] = t_max[from];
        }
        const __m256d sign = _mm256_set1_pd(-0.0);
        const __m256d max_coordinate = _mm256_set1_pd(kFloatSlabMaxCoordinate);
        const __m256d float_max = _mm256_set1_pd(double(FLT_MAX)), zero = _mm256_setzero_pd();
        const __m256d nan = _mm256_set1_pd(NAN), one = _mm256_set1_pd(1.0);
        applies = 0;
        bounded = ~uint64_t(0);
        negative[0] = negative[1] = negative[2] = 0;
        for (int at = 0; at < lanes; at += 4) {
            __m256d within = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
            __m256d abs_d[3];
            for (int k = 0; k < 3; ++k) {
                const __m256d ok = _mm256_load_pd(o[k] + at), dk = _mm256_load_pd(d[k] + at);
                within = _mm256_and_pd(within, _mm256_cmp_pd(_mm256_andnot_pd(sign, ok), max_coordinate, _CMP_LE_OQ));
                __m128 lo, hi;
                round_outward_lanes(ok, lo, hi);
                _mm_store_ps(down[k] + at, lo);
                _mm_store_ps(up[k] + at, hi);
                negative[k] |= uint64_t(_mm256_movemask_pd(dk)) << at;
                const __m256d r = _mm256_div_pd(one, dk);
                const __m256d finite = _mm256_or_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, r), float_max, _CMP_LE_OQ),
                                                    _mm256_cmp_pd(dk, zero, _CMP_EQ_OQ));
                _mm_store_ps(inv[k] + at, _mm256_cvtpd_ps(_mm256_blendv_pd(nan, r, finite)));
                // |1/d| <= FLT_MAX: float(1/d) finite (false for d = ±0 and NaN).
                bounded &= ~(
                    uint64_t(~_mm256_movemask_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, r), float_max, _CMP_LE_OQ)) & 0xF)
                    << at);
                abs_d[k] = _mm256_andnot_pd(sign, dk);
            }
            // applies' d_max: (|x| > |y| ? |x| : |y|), then against |z| alike: maxpd's rule,
            // NaN included (it returns the second operand unless the first is greater).
            const __m256d d_max = _mm256_max_pd(_mm256_max_pd(abs_d[0], abs_d[1]), abs_d[2]);
            within = _mm256_and_pd(within, _mm256_cmp_pd(d_max, _mm256_set1_pd(kFloatSlabMinDirection), _CMP_GE_OQ));
            within = _mm256_and_pd(within, _mm256_cmp_pd(d_max, _mm256_set1_pd(kFloatSlabMaxDirection), _CMP_LE_OQ));
            applies |= uint64_t(_mm256_movemask_pd(within)) << at;
            __m128 unused, far;
            round_outward_lanes(_mm256_mul_pd(_mm256_load_pd(limit + at), _mm256_set1_pd(double(kFloatSlabWidening))),
                                unused, far);
            _mm_store_ps(far_up + at, far);
        }
        if (!(t_min >= kFloatSlabMinTMin && scene_magnitude <= kFloatSlabMaxCoordinate)) applies = 0;
        applies &= ~uint64_t(0) >> (kRays - count);
        t_min_down = round_down(t_min);
    }

    // Ray r's FloatSlabRay8 (where applies has bit r).
    PHONG_AVX2 void emplace(int r, Deferred<FloatSlabRay8>& ray) const {
        const float lo[3] = {down[0][r], down[1][r], down[2][r]}, hi[3] = {up[0][r], up[1][r], up[2][r]};
        const float inverse[3] = {inv[0][r], inv[1][r], inv[2][r]};
        const bool neg[3] = {bool(negative[0] >> r & 1u), bool(negative[1] >> r & 1u), bool(negative[2] >> r & 1u)};
        ray.emplace(lo, hi, inverse, neg, t_min_down);
    }
};

// traverse_bvh4 (bvh4.hpp) over the 8-wide tree: the same leaf calls in an order of its own.
template <bool ordered, class LeafFn>
PHONG_AVX2 void traverse_bvh8(const Bvh8Nodes& nodes, double scene_magnitude, const Ray& ray,
                              const FloatSlabOrigin& origin, double t_min, double& t_max, LeafFn&& leaf) {
    if (nodes.empty()) return;
    struct Pending {
        int32_t child, count;
        float entry;
    };
    Pending stack[kMaxBvh8Stack];
    int sp = 0;
    Pending current{0, 0, 0.0f};
    const bool float_test = FloatSlabRay::applies(ray.origin, ray.dir, t_min, scene_magnitude);
    const Vec3 inv{1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z};
    const FloatSlabRay8 fray(origin, ray.dir, inv, t_min);
    __m256 t_max_up = _mm256_set1_ps(_mm_cvtss_f32(FloatSlabRay::far_limit(t_max)));
    float t_max_f = _mm256_cvtss_f32(t_max_up);
    while (true) {
        if (current.count == 0) {
            const Bvh8Node& node = nodes[size_t(current.child)];
            alignas(32) float entry[8];
            int mask = 0;
            if (float_test) {
                __m256 e;
                mask = fray.hit(node, t_max_up, e);
                if (ordered) _mm256_store_ps(entry, e);  // an any-hit walk never reads the entries
            } else {
                for (int i = 0; i < 8; ++i) {
                    double t_entry;
                    // An any-hit walk's boxes uncapped (hit_node's cap, kAnyHitBoxLimit).
                    if (hit_node(ChildBox(node, i), ray.origin, inv, t_min, ordered ? t_max : kAnyHitBoxLimit,
                                 t_entry)) {
                        mask |= 1 << i;
                        entry[i] = round_down(t_entry);
                    }
                }
            }
            if (!ordered && mask != 0) {  // children as they come: the first next, the others pending
                const int first = __builtin_ctz(unsigned(mask));
                for (mask &= mask - 1; mask != 0; mask &= mask - 1) {
                    const int i = __builtin_ctz(unsigned(mask));
                    stack[sp++] = Pending{node.child[i], node.count[i], 0.0f};
                }
                current = Pending{node.child[first], node.count[first], 0.0f};
                continue;
            }
            if (mask != 0) {
                Pending hits[8];
                int n = 0;
                for (; mask != 0; mask &= mask - 1) {
                    const int i = __builtin_ctz(unsigned(mask));
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
                t_max_up = _mm256_set1_ps(_mm_cvtss_f32(FloatSlabRay::far_limit(t_max)));
                t_max_f = _mm256_cvtss_f32(t_max_up);
            }
        }
        do {
            if (sp == 0) return;
            current = stack[--sp];
        } while (ordered && current.entry > t_max_f);
    }
}

}  // namespace phong
