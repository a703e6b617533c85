// SPDX-License-Identifier: Apache-2.0
// Packets of up to 32 rays that share their origin (a perspective camera's primary rays of an
// 8x4 block of pixels) walking the 8-wide BVH together: a node's eight children are tested once
// for the whole packet, against the interval of the rays' inverse directions; a leaf is handed to
// each ray whose own float slab test (FloatSlabRay8's, per lane) enters its box. The walk's node
// visits are shared by the packet; the leaves' tests stay per ray.
//
// Why every ray gets the hit closest_hit() gives it. The single-ray test of a child computes
// per axis near_k = fl(x · r_k) with x = fl(p − o⁺) (bvh4.hpp), where x depends on the box and
// the rounded origin only: the same for every ray of a packet whose direction signs agree (the
// same planes and origin roundings). fl(x · r) is monotonic in r for a fixed x (rounding to
// nearest is monotonic), so with r_k in [lo_k, hi_k] over the packet,
//   min(fl(x·lo_k), fl(x·hi_k)) <= near_k(ray) and max(fl(y·lo_k), fl(y·hi_k)) >= far_k(ray);
// max, min and the product by W are monotonic too, and the packet's far limit is the largest of
// its rays'. So the packet's t0 <= every ray's t0 and its t1 >= every ray's t1: the packet enters
// a child whenever one of its rays would. A ray's closest hit lies in boxes its own test enters
// (its walk relies on that, bvh4.hpp), every box on the way to that leaf is entered by the packet,
// and the leaf itself is handed to the ray by its own test (bit for bit FloatSlabRay8::hit's lane).
// The tests inside a leaf are closest_hit()'s (closest_search.hpp), whose result does not depend
// on the order leaves come in. No NaN arises: the packet is only formed from rays whose float
// inverse directions are finite and non-zero and whose origin and range the float test covers
// (FloatSlabRay::applies); else the rays walk one by one.
#pragma once

#include <immintrin.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "bvh4.hpp"
#include "bvh8.hpp"
#include "math.hpp"

namespace phong {

// Rays per packet: four AVX words of the per-ray leaf test, eight rays a word; a bit each in an
// unsigned.
constexpr int kPacketRays = 32, kPacketWords = kPacketRays / 8;
static_assert(kPacketRays <= 32);
// The bits of rays 0 .. count − 1 (count <= 32: a shift by 32 would be undefined).
constexpr unsigned packet_bits(int count) { return count >= 32 ? ~0u : (1u << count) - 1u; }

// The largest of eight lanes, in every lane.
PHONG_AVX2 inline __m256 lane_max(__m256 v) {
    v = _mm256_max_ps(v, _mm256_permute2f128_ps(v, v, 1));
    v = _mm256_max_ps(v, _mm256_shuffle_ps(v, v, _MM_SHUFFLE(1, 0, 3, 2)));
    return _mm256_max_ps(v, _mm256_shuffle_ps(v, v, _MM_SHUFFLE(2, 3, 0, 1)));
}
// The smallest of eight lanes, in every lane.
PHONG_AVX2 inline __m256 lane_min(__m256 v) {
    v = _mm256_min_ps(v, _mm256_permute2f128_ps(v, v, 1));
    v = _mm256_min_ps(v, _mm256_shuffle_ps(v, v, _MM_SHUFFLE(1, 0, 3, 2)));
    return _mm256_min_ps(v, _mm256_shuffle_ps(v, v, _MM_SHUFFLE(2, 3, 0, 1)));
}

// A packet set up for the interval test of a node's eight children at once (hit) and for its
// rays' own tests of one child, a ray per lane (rays_entering).
struct FloatSlabPacket {
    __m256 origin_near[3], origin_far[3];
    __m256 inv_lo[3], inv_hi[3];  // the interval of the rays' float inverse directions, per axis
    __m256 inv[3][kPacketWords];  // ray r's in lane r % 8 of word r / 8 (lanes past the packet's rays: ray 0's)
    __m256 t_min;
    int near_row[3], far_row[3];

    // Sets the packet up for `count` rays leaving `origin` (every ray's origin is the same point);
    // false when they cannot walk together (see above): then nothing is set. In AVX lanes, four
    // rays at a time in double: the scalar set-up (a loop per ray and axis) cost S1's render 5 %
    // of its instructions; these are the same operations on the same numbers.
    PHONG_AVX2 bool set_up(const Ray* rays, int count, const FloatSlabOrigin& origin, double t_min_,
                           double scene_magnitude) {
        const Ray& first = rays[0];
        if (!FloatSlabRay::applies(first.origin, first.dir, t_min_, scene_magnitude)) return false;
        alignas(32) double d[3][kPacketRays];  // the directions by axis (lanes past `count`: ray 0's)
        for (int r = 0; r < kPacketRays; ++r) {
            const Vec3& dir = rays[r < count ? r : 0].dir;
            d[0][r] = dir.x;
            d[1][r] = dir.y;
            d[2][r] = dir.z;
        }
        constexpr int kQuads = kPacketRays / 4;  // rays four at a time, in double
        constexpr unsigned kAll = packet_bits(kPacketRays);
        const __m256d sign = _mm256_set1_pd(-0.0), one = _mm256_set1_pd(1.0);
        const __m256d float_max = _mm256_set1_pd(double(FLT_MAX));
        // Bit r set when |x_r| <= limit (false for NaN).
        auto abs_at_most = [&](__m256d x, __m256d limit) PHONG_AVX2 {
            return unsigned(_mm256_movemask_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, x), limit, _CMP_LE_OQ)));
        };
        __m256d d_max[kQuads];
        for (__m256d& m : d_max) m = _mm256_setzero_pd();
        bool usable = true;
        for (int k = 0; k < 3; ++k) {
            unsigned signs = 0, finite = 0;
            __m128 inverse[kQuads];
            for (int q = 0; q < kQuads; ++q) {
                const __m256d x = _mm256_load_pd(d[k] + 4 * q);
                // One sign per axis (the sign bit, as std::signbit: −0 is negative).
                signs |= unsigned(_mm256_movemask_pd(x)) << (4 * q);
                const __m256d inv_x = _mm256_div_pd(one, x);
                // |1/d| <= FLT_MAX, false for ±inf (d = ±0) and NaN: lanes that would be inf or NaN.
                finite |= abs_at_most(inv_x, float_max) << (4 * q);
                inverse[q] = _mm256_cvtpd_ps(inv_x);  // float(1/d), per lane
                d_max[q] = _mm256_max_pd(d_max[q], _mm256_andnot_pd(sign, x));
            }
            usable = usable && (signs == 0 || signs == kAll) && finite == kAll;
            for (int w = 0; w < kPacketWords; ++w) inv[k][w] = _mm256_set_m128(inverse[2 * w + 1], inverse[2 * w]);
        }
        // FloatSlabRay::applies' direction range for every ray (the origin and t_min are ray 0's).
        const __m256d d_least = _mm256_set1_pd(kFloatSlabMinDirection), d_most = _mm256_set1_pd(kFloatSlabMaxDirection);
        for (const __m256d m : d_max)
            usable =
                usable && (_mm256_movemask_pd(_mm256_cmp_pd(m, d_least, _CMP_GE_OQ)) & abs_at_most(m, d_most)) == 0xF;
        if (!usable) return false;
        for (int k = 0; k < 3; ++k) {
            const bool negative = std::signbit(first.dir[k]);
            near_row[k] = negative ? 3 + k : k;
            far_row[k] = negative ? k : 3 + k;
            origin_near[k] = _mm256_set1_ps(negative ? origin.down[k] : origin.up[k]);
            origin_far[k] = _mm256_set1_ps(negative ? origin.up[k] : origin.down[k]);
            __m256 lo = inv[k][0], hi = inv[k][0];
            for (int w = 1; w < kPacketWords; ++w) {
                lo = _mm256_min_ps(lo, inv[k][w]);
                hi = _mm256_max_ps(hi, inv[k][w]);
            }
            inv_lo[k] = lane_min(lo);
            inv_hi[k] = lane_max(hi);
        }
        t_min = _mm256_set1_ps(round_down(t_min_));
        return true;
    }

    // Bit i set when the packet enters child i (one of its rays may); entry[i] a lower bound of
    // every ray's t0 there. `t_max_up`: the largest of the rays' far limits.
    PHONG_AVX2 int hit(const Bvh8Node& node, __m256 t_max_up, __m256& entry) const {
        __m256 t0 = t_min, t1 = _mm256_set1_ps(INFINITY);
        for (int k = 0; k < 3; ++k) {
            const __m256 x = _mm256_sub_ps(_mm256_load_ps(node.boxes[near_row[k]]), origin_near[k]);
            const __m256 y = _mm256_sub_ps(_mm256_load_ps(node.boxes[far_row[k]]), origin_far[k]);
            t0 = _mm256_max_ps(_mm256_min_ps(_mm256_mul_ps(x, inv_lo[k]), _mm256_mul_ps(x, inv_hi[k])), t0);
            t1 = _mm256_min_ps(_mm256_max_ps(_mm256_mul_ps(y, inv_lo[k]), _mm256_mul_ps(y, inv_hi[k])), t1);
        }
        t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(kFloatSlabWidening)), t_max_up);
        entry = t0;
        return _mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
    }

    // Bit r set when ray r enters child i of `node`: FloatSlabRay8::hit's lane i for that ray,
    // the same operations on the same numbers, eight rays per instruction. `t_max_up`: the rays'
    // own far limits, in lanes.
    PHONG_AVX2 unsigned rays_entering(const Bvh8Node& node, int i, const __m256* t_max_up) const {
        __m256 near_plane[3], far_plane[3];
        for (int k = 0; k < 3; ++k) {
            near_plane[k] = _mm256_sub_ps(_mm256_broadcast_ss(&node.boxes[near_row[k]][i]), origin_near[k]);
            far_plane[k] = _mm256_sub_ps(_mm256_broadcast_ss(&node.boxes[far_row[k]][i]), origin_far[k]);
        }
        unsigned entering = 0;
        for (int w = 0; w < kPacketWords; ++w) {
            __m256 t0 = t_min, t1 = _mm256_set1_ps(INFINITY);
            for (int k = 0; k < 3; ++k) {
                t0 = _mm256_max_ps(_mm256_mul_ps(near_plane[k], inv[k][w]), t0);
                t1 = _mm256_min_ps(_mm256_mul_ps(far_plane[k], inv[k][w]), t1);
            }
            t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(kFloatSlabWidening)), t_max_up[w]);
            entering |= unsigned(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ))) << (8 * w);
        }
        return entering;
    }
};

// The closest-hit walk (traverse_bvh8<true>) for a packet: children nearest first by the
// packet's entry, a pending child skipped once its entry lies beyond every ray's far limit.
// `leaf(rays, first, count, t_cull)` tests a leaf's primitives for the rays of bit mask `rays`
// and sets t_cull[r] to each one's far limit for boxes now (as a double); `rays` here has bit r
// set for the packet's rays, t_cull[r] their limits to start with.
template <class LeafFn>
PHONG_AVX2 void traverse_bvh8_packet(const Bvh8Nodes& nodes, const FloatSlabPacket& packet, unsigned rays,
                                     const double* t_cull, LeafFn&& leaf) {
    if (nodes.empty()) return;
    struct Pending {
        int32_t child, count;
        float entry;
        unsigned rays;  // a leaf's: the rays whose own test entered it
    };
    Pending stack[kMaxBvh8Stack];
    int sp = 0;
    Pending current{0, 0, 0.0f, rays};
    alignas(32) float far[kPacketRays];
    for (int r = 0; r < kPacketRays; ++r)
        far[r] = (rays >> r) & 1 ? round_up(t_cull[r] * double(kFloatSlabWidening)) : -INFINITY;
    __m256 far_lanes[kPacketWords], far_max;
    // The rays' far limits in lanes and their largest, from far[].
    auto load_far = [&]() PHONG_AVX2 __attribute__((always_inline)) {
        far_lanes[0] = _mm256_load_ps(far);
        __m256 largest = far_lanes[0];
        for (int w = 1; w < kPacketWords; ++w) {
            far_lanes[w] = _mm256_load_ps(far + 8 * w);
            largest = _mm256_max_ps(largest, far_lanes[w]);
        }
        far_max = lane_max(largest);
    };
    load_far();
    float far_max_f = _mm256_cvtss_f32(far_max);
    while (true) {
        if (current.count == 0) {
            const Bvh8Node& node = nodes[size_t(current.child)];
            alignas(32) float entry[8];
            __m256 e;
            int mask = packet.hit(node, far_max, e);
            _mm256_store_ps(entry, e);
            if (mask != 0) {
                Pending hits[8];
                int n = 0;
                for (; mask != 0; mask &= mask - 1) {
                    const int i = __builtin_ctz(unsigned(mask));
                    Pending p{node.child[i], node.count[i], entry[i], 0};
                    if (p.count > 0) {
                        p.rays = packet.rays_entering(node, i, far_lanes) & rays;
                        if (p.rays == 0) continue;
                    }
                    int j = n++;
                    for (; j > 0 && hits[j - 1].entry > p.entry; --j) hits[j] = hits[j - 1];
                    hits[j] = p;
                }
                if (n > 0) {
                    for (int j = n - 1; j > 0; --j) stack[sp++] = hits[j];
                    current = hits[0];
                    continue;
                }
            }
        } else {
            bool changed = false;
            double leaf_cull[kPacketRays];
            leaf(current.rays, current.child, current.count, leaf_cull);
            for (unsigned r_bits = current.rays; r_bits != 0; r_bits &= r_bits - 1) {
                const int r = __builtin_ctz(r_bits);
                const float limit = round_up(leaf_cull[r] * double(kFloatSlabWidening));
                if (limit != far[r]) {
                    far[r] = limit;
                    changed = true;
                }
            }
            if (changed) {
                load_far();
                far_max_f = _mm256_cvtss_f32(far_max);
            }
        }
        do {
            if (sp == 0) return;
            current = stack[--sp];
        } while (current.entry > far_max_f);
    }
}

}  // namespace phong
