// SPDX-License-Identifier: Apache-2.0
// A light's shadow rays from a group of shaded points (up to 64: Scene::occluded_tree_each)
// walking the 8-wide BVH together. Near the root, where boxes are large and every ray enters
// most of them, a node's eight children are tested once for the whole group, against the
// interval of the rays' float origins and of their float inverse directions; deeper, each
// walking ray tests the node's children with its own float slab test (FloatSlabRay8::hit's
// operations) and a child is visited for the rays that enter it. A leaf is handed to each ray
// whose own test enters its box.
//
// Why each ray's answer is its own walk's. Ray r's test of a child computes per axis
// near_k = fl(x_r · i_r) with x_r = fl(p − o_r) (bvh4.hpp: FloatSlabRay), p the near plane, o_r
// the ray's float origin rounded for that plane, i_r its float inverse direction. For the group
// every ray's direction has the same sign on each axis, so every i_r has that sign and lies in
// [i_lo, i_hi]. fl(p − o) is monotonic (non-increasing) in o, fl(x · i) monotonic in x for a
// fixed i of known sign and in i for a fixed x (rounding to nearest is monotonic). Take
// x_g = fl(p − o_max) where i > 0 (x_r >= x_g, and fl(x · i_r) grows with x) and
// x_g = fl(p − o_min) where i < 0 (x_r <= x_g, and fl(x · i_r) falls as x grows); either way
//   fl(x_r · i_r) >= fl(x_g · i_r) >= min(fl(x_g · i_lo), fl(x_g · i_hi)),
// and alike the far plane's product is at most max(fl(y_g · i_lo), fl(y_g · i_hi)). max, min and
// the product by W are monotonic, the group's far limit is the largest of its rays': so the
// group's t0 <= every ray's t0 and its t1 >= every ray's t1, and the group enters a child
// whenever one of its rays' own test would. Every box on a ray's own way to a leaf is thus
// visited for it, and the leaf is handed to the ray by its own test: each ray tests at least the
// leaves its own walk tests, and only leaves its own test enters. An any-hit answer does not
// depend on which further leaves are tested nor in which order (every test is exact), so each
// ray is blocked exactly when its own walk says so. No NaN arises in the group's test: the group
// is only formed from rays whose float inverse directions are finite and whose numbers the float
// test covers (FloatSlabLanes' applies and bounded bits); an infinite product (an empty slot's
// ±inf planes) compares as in each ray's test.
#pragma once

#include <immintrin.h>

#include <cassert>
#include <cmath>
#include <cstdint>

#include "bvh8.hpp"
#include "bvh8_packet.hpp"
#include "scene.hpp"

namespace phong {

// The levels of the tree (the root's is 0) where a group's walk tests a node once for all its
// rays; below them each ray tests it, the interval test entering too many boxes no ray enters.
// S2's render under callgrind with 1/2/3/4 levels: 1,315.8/1,305.1/1,338.1/1,690.2M
// instructions (8831efd, which counted a node's later children a level too deep, 1,298.4M,
// level with 2 in CPU time over 12 alternating rounds).
constexpr int kGroupTestLevels = 2;

// A set of a group's rays as AVX masks, eight rays (a byte of the set) per mask: the least and
// the largest of a number kept per ray (FloatSlabLanes' arrays) over the set, eight rays per
// instruction. (Lanes past the rays set up are read and masked out.)
struct RaySetLanes {
    __m256 member[kMaxRaysTogether / 8];
    unsigned words = 0;  // bit w: the set has rays in byte w

    PHONG_AVX2 explicit RaySetLanes(RayBits set) {
        const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        for (int w = 0; w < kMaxRaysTogether / 8; ++w) {
            const int byte = int(set >> (8 * w) & 0xFFu);
            if (byte == 0) continue;
            words |= 1u << w;
            member[w] = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(byte), bit), bit));
        }
    }
    // The least and the largest of values[r] over the set.
    PHONG_AVX2 void range(const float* values, float& least, float& largest) const {
        const __m256 up = _mm256_set1_ps(INFINITY), down = _mm256_set1_ps(-INFINITY);
        __m256 lo = up, hi = down;
        for (unsigned w_bits = words; w_bits != 0; w_bits &= w_bits - 1) {
            const int w = __builtin_ctz(w_bits);
            const __m256 v = _mm256_loadu_ps(values + 8 * w);
            lo = _mm256_min_ps(lo, _mm256_blendv_ps(up, v, member[w]));
            hi = _mm256_max_ps(hi, _mm256_blendv_ps(down, v, member[w]));
        }
        least = _mm256_cvtss_f32(lane_min(lo));
        largest = _mm256_cvtss_f32(lane_max(hi));
    }
};

// The group's interval test, and its rays' own tests.
struct FloatSlabGroup8 {
    const FloatSlabLanes* lanes;
    const float* origin_near[3];  // by ray: each ray's FloatSlabRay8::origin_near[k]
    const float* origin_far[3];
    __m256 group_near[3], group_far[3];  // the origins giving the least near and the largest far
    __m256 inv_lo[3], inv_hi[3];
    __m256 t_min, far_max;
    int near_row[3], far_row[3];

    // Sets the group up for the rays of `rays` (`set`: the same rays): each with FloatSlabLanes'
    // applies and bounded bits, their directions' signs the same on each axis.
    PHONG_AVX2 void set_up(const FloatSlabLanes& lanes_, RayBits rays, const RaySetLanes& set) {
        assert(rays != 0 && (rays & ~(lanes_.applies & lanes_.bounded)) == 0);
        lanes = &lanes_;
        for (int k = 0; k < 3; ++k) {
            const RayBits signs = lanes_.negative[k] & rays;
            assert(signs == 0 || signs == rays);
            const bool negative = signs != 0;
            near_row[k] = negative ? 3 + k : k;
            far_row[k] = negative ? k : 3 + k;
            origin_near[k] = negative ? lanes_.down[k] : lanes_.up[k];
            origin_far[k] = negative ? lanes_.up[k] : lanes_.down[k];
            float near_lo, near_hi, far_lo, far_hi, lo, hi;
            set.range(lanes_.inv[k], lo, hi);
            set.range(origin_near[k], near_lo, near_hi);
            set.range(origin_far[k], far_lo, far_hi);
            inv_lo[k] = _mm256_set1_ps(lo);
            inv_hi[k] = _mm256_set1_ps(hi);
            // The near plane's offset p − o is least for the largest o where i > 0 (so is the
            // product), and largest for the least o where i < 0 (the product least then).
            group_near[k] = _mm256_set1_ps(negative ? near_lo : near_hi);
            group_far[k] = _mm256_set1_ps(negative ? far_hi : far_lo);
        }
        float nearest, farthest;
        set.range(lanes_.far_up, nearest, farthest);
        far_max = _mm256_set1_ps(farthest);
        t_min = _mm256_set1_ps(lanes_.t_min_down);
    }

    // Bit i set when the group enters child i (one of its rays may).
    PHONG_AVX2 int hit(const Bvh8Node& node) const {
        __m256 t0 = t_min, t1 = _mm256_set1_ps(INFINITY);
        for (int k = 0; k < 3; ++k) {
            const __m256 x = _mm256_sub_ps(_mm256_load_ps(node.boxes[near_row[k]]), group_near[k]);
            const __m256 y = _mm256_sub_ps(_mm256_load_ps(node.boxes[far_row[k]]), group_far[k]);
            t0 = _mm256_max_ps(_mm256_min_ps(_mm256_mul_ps(x, inv_lo[k]), _mm256_mul_ps(x, inv_hi[k])), t0);
            t1 = _mm256_min_ps(_mm256_max_ps(_mm256_mul_ps(y, inv_lo[k]), _mm256_mul_ps(y, inv_hi[k])), t1);
        }
        t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(kFloatSlabWidening)), far_max);
        return _mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
    }

    // Bit i set when ray r enters child i: FloatSlabRay8::hit for that ray, the same
    // operations on the same numbers, the node's planes (near_planes, far_planes) loaded once.
    PHONG_AVX2 unsigned ray_enters(const __m256* near_planes, const __m256* far_planes, int r) const {
        __m256 t0 = t_min, t1 = _mm256_set1_ps(INFINITY);
        for (int k = 0; k < 3; ++k) {
            const __m256 inv = _mm256_broadcast_ss(lanes->inv[k] + r);
            t0 = _mm256_max_ps(
                _mm256_mul_ps(_mm256_sub_ps(near_planes[k], _mm256_broadcast_ss(origin_near[k] + r)), inv), t0);
            t1 = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(far_planes[k], _mm256_broadcast_ss(origin_far[k] + r)), inv),
                               t1);
        }
        t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(kFloatSlabWidening)),
                           _mm256_broadcast_ss(lanes->far_up + r));
        return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)));
    }

    // The rays of `rays` whose own test enters child i of `node`: FloatSlabRay8::hit's lane i
    // for each, eight rays per instruction.
    PHONG_AVX2 RayBits rays_entering(const Bvh8Node& node, int i, RayBits rays) const {
        __m256 near_plane[3], far_plane[3];
        for (int k = 0; k < 3; ++k) {
            near_plane[k] = _mm256_broadcast_ss(&node.boxes[near_row[k]][i]);
            far_plane[k] = _mm256_broadcast_ss(&node.boxes[far_row[k]][i]);
        }
        RayBits entering = 0;
        for (int w = 0; w < kMaxRaysTogether / 8; ++w) {
            if ((rays >> (8 * w) & 0xFFu) == 0) continue;
            const int at = 8 * w;
            __m256 t0 = t_min, t1 = _mm256_set1_ps(INFINITY);
            for (int k = 0; k < 3; ++k) {
                const __m256 inv = _mm256_loadu_ps(lanes->inv[k] + at);
                t0 = _mm256_max_ps(
                    _mm256_mul_ps(_mm256_sub_ps(near_plane[k], _mm256_loadu_ps(origin_near[k] + at)), inv), t0);
                t1 = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(far_plane[k], _mm256_loadu_ps(origin_far[k] + at)), inv),
                                   t1);
            }
            t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(kFloatSlabWidening)),
                               _mm256_loadu_ps(lanes->far_up + at));
            entering |= RayBits(unsigned(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)))) << at;
        }
        return entering & rays;
    }
};

// The any-hit walk of a group: children as they come (the first next, the others pending).
// `leaf(rays, first, count)` tests a leaf for the rays of `rays` and returns those it blocks; a
// blocked ray drops out, and the walk ends when none is left. Returns the rays blocked.
template <class LeafFn>
PHONG_AVX2 RayBits traverse_bvh8_group(const Bvh8Nodes& nodes, const FloatSlabGroup8& group, RayBits rays,
                                       LeafFn&& leaf) {
    struct Pending {
        int32_t child, count;
        RayBits rays;  // the rays to test it: all still walking near the root, else those entering
        int level;
    };
    // As a single walk's stack: a node's children wait while the walk is below it, at most 7 a
    // level of the current path.
    Pending stack[kMaxBvh8Stack];
    int sp = 0;
    Pending current{0, 0, rays, 0};
    RayBits blocked = 0;
    while (true) {
        const RayBits walking = current.rays & ~blocked;
        if (walking != 0) {
            if (current.count == 0) {
                const Bvh8Node& node = nodes[size_t(current.child)];
                const int level = current.level + 1;  // the children's (visit replaces current)
                bool descended = false;
                auto visit = [&](const Pending& p) __attribute__((always_inline)) {
                    if (descended) {
                        stack[sp++] = p;
                    } else {
                        current = p;
                        descended = true;
                    }
                };
                if (current.level < kGroupTestLevels) {
                    for (int mask = group.hit(node); mask != 0; mask &= mask - 1) {
                        const int i = __builtin_ctz(unsigned(mask));
                        Pending p{node.child[i], node.count[i], walking, level};
                        if (p.count > 0 && (p.rays = group.rays_entering(node, i, walking)) == 0) continue;
                        visit(p);
                    }
                } else {
                    // Ray r's children in byte r % 8 of masks[r / 8]; child i's rays are bit i of
                    // each byte.
                    uint64_t masks[kMaxRaysTogether / 8] = {};
                    __m256 near_planes[3], far_planes[3];
                    for (int k = 0; k < 3; ++k) {
                        near_planes[k] = _mm256_load_ps(node.boxes[group.near_row[k]]);
                        far_planes[k] = _mm256_load_ps(node.boxes[group.far_row[k]]);
                    }
                    for (RayBits bits = walking; bits != 0; bits &= bits - 1) {
                        const int r = __builtin_ctzll(bits);
                        masks[r >> 3] |= uint64_t(group.ray_enters(near_planes, far_planes, r)) << (8 * (r & 7));
                    }
                    uint64_t any = masks[0];
                    for (int w = 1; w < kMaxRaysTogether / 8; ++w) any |= masks[w];
                    any |= any >> 32;
                    any |= any >> 16;
                    for (unsigned entered = unsigned((any | any >> 8) & 0xFFu); entered != 0; entered &= entered - 1) {
                        const int i = __builtin_ctz(entered);
                        // Bit 8r of `column` is ray r's. The product puts bit 8r times 2^(7j + 7)
                        // at 8r + 7j + 7: distinct for every (r, j), so nothing carries, and in the
                        // top byte only for j = 7 − r, at bit 56 + r.
                        RayBits rays_in = 0;
                        for (int w = 0; w < kMaxRaysTogether / 8; ++w) {
                            const uint64_t column = (masks[w] >> i) & 0x0101010101010101ull;
                            rays_in |= ((column * 0x0102040810204080ull) >> 56) << (8 * w);
                        }
                        visit(Pending{node.child[i], node.count[i], rays_in, level});
                    }
                }
                if (descended) continue;
            } else {
                blocked |= leaf(walking, current.child, current.count);
                if ((rays & ~blocked) == 0) return blocked;
            }
        }
        if (sp == 0) return blocked;
        current = stack[--sp];
    }
}

}  // namespace phong
