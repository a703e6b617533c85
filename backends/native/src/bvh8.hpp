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

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "bvh.hpp"
#include "bvh4.hpp"
#include "math.hpp"
#include "simd_dispatch.hpp"

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
        for (int k = 0; k < 3; ++k) {
            const bool negative = std::signbit(d[k]);
            near_row[k] = negative ? 3 + k : k;
            far_row[k] = negative ? k : 3 + k;
            origin_near[k] = _mm256_set1_ps(negative ? origin.down[k] : origin.up[k]);
            origin_far[k] = _mm256_set1_ps(negative ? origin.up[k] : origin.down[k]);
            const float inv_k = std::fabs(r[k]) <= double(FLT_MAX) ? float(r[k]) : d[k] == 0.0 ? float(r[k]) : NAN;
            inv[k] = _mm256_set1_ps(inv_k);
        }
        t_min = _mm256_set1_ps(round_down(t_min_));
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
