// SPDX-License-Identifier: Apache-2.0
// A scene of a few primitives (a course's spheres on a ground quad) tested without its tree: each
// query rejects every sphere and every triangle's box at once in AVX double lanes, and only the
// primitives left get their exact test (shapes.hpp). The tree's walk costs such a shadow ray
// more than its tests: the reciprocals and float bounds of the ray, the node's box test, the
// stack, a leaf call per child; S1's shadow rays took ~333 instructions a ray through it
// (benchmarks/README.md, issue 25).
//
// The answers are the tree's: a sphere is rejected only where its own test (sphere_roots) would
// reject it by the same numbers, and a triangle only where hit_node (bvh.hpp), the tree's double
// box test, would cull its box; the exact tests of the rest are the ones the tree's leaves run,
// and an any-hit answer does not depend on the order of the tests.
#pragma once

#include <immintrin.h>

#include <cassert>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "bvh.hpp"
#include "math.hpp"
#include "shapes.hpp"
#include "simd_dispatch.hpp"
#include "triangle_store.hpp"

namespace phong {

// Lanes of four for the spheres and for the triangles' boxes: a scene has a small scene's
// path with at most kSmallSceneGroups × 4 of each. At S1's 4 spheres and 2 triangles one group
// each costs ~60 and ~35 instructions against the walk's ~333; past a few groups the tree, which
// skips what a ray's node boxes miss, is the cheaper (its cost grows with the log of the count).
constexpr int kSmallSceneGroups = 2;
constexpr int kSmallSceneMax = 4 * kSmallSceneGroups;

namespace detail {
// dot() per lane: (u.x·w.x + u.y·w.y) + u.z·w.z.
PHONG_AVX2 inline __m256d dot_lanes(const __m256d (&u)[3], const __m256d (&w)[3]) {
    return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(u[0], w[0]), _mm256_mul_pd(u[1], w[1])),
                         _mm256_mul_pd(u[2], w[2]));
}

// Bit i clear where lane i's sphere test certainly finds no root above t_min: sphere_roots'
// shortcuts from oo = |o|², b = o·d and a = |d|² (c = oo − 1): sphere_leaves (b > 0 and −c <=
// b·t_min·kLeavingMargin) or sphere_misses (g = a·c − b² > kSphereMissMargin·a·(c + 2), g
// finite, a >= kSphereMissMinA), the same operations in the same order.
PHONG_AVX2 inline unsigned kept_lanes(__m256d oo, __m256d b, __m256d a, double t_min) {
    const __m256d c = _mm256_sub_pd(oo, _mm256_set1_pd(1.0));
    const __m256d leaves = _mm256_and_pd(
        _mm256_cmp_pd(b, _mm256_setzero_pd(), _CMP_GT_OQ),
        _mm256_cmp_pd(_mm256_xor_pd(c, _mm256_set1_pd(-0.0)),
                      _mm256_mul_pd(_mm256_mul_pd(b, _mm256_set1_pd(t_min)), _mm256_set1_pd(kLeavingMargin)),
                      _CMP_LE_OQ));
    const __m256d gap = _mm256_sub_pd(_mm256_mul_pd(a, c), _mm256_mul_pd(b, b));
    const __m256d margin =
        _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(kSphereMissMargin), a), _mm256_add_pd(c, _mm256_set1_pd(2.0)));
    const __m256d misses = _mm256_and_pd(
        _mm256_and_pd(_mm256_cmp_pd(gap, margin, _CMP_GT_OQ), _mm256_cmp_pd(gap, _mm256_set1_pd(DBL_MAX), _CMP_LE_OQ)),
        _mm256_cmp_pd(a, _mm256_set1_pd(kSphereMissMinA), _CMP_GE_OQ));
    return unsigned(~_mm256_movemask_pd(_mm256_or_pd(leaves, misses)) & 15);
}
}  // namespace detail

struct alignas(64) SmallScene {
    // Axis-aligned spheres (SphereShape::axis_aligned): object_from_world's diagonal (m0, m5,
    // m10) and translation (m3, m7, m11) by lane, sphere k in group k / 4, lane k % 4.
    // (Held by pointer, so aligned as declared, whatever the alignment of the Scene's storage:
    // unaligned, half the loads crossed cache lines and S1's shadow rays were ~4 % slower.)
    double scale[kSmallSceneGroups][3][4];
    double offset[kSmallSceneGroups][3][4];
    // Triangle k's box: the exact bounds of its corners as the tests read them.
    double lo[kSmallSceneGroups][3][4];
    double hi[kSmallSceneGroups][3][4];
    int spheres = 0, triangles = 0;

    // Whether a scene of these primitives takes this path (no other kind of primitive: the
    // caller checks).
    static bool fits(const std::vector<SphereShape>& s, size_t triangle_count) {
        if (s.size() > size_t(kSmallSceneMax) || triangle_count > size_t(kSmallSceneMax)) return false;
        for (const SphereShape& sphere : s)
            if (!sphere.axis_aligned) return false;
        return true;
    }

    SmallScene(const std::vector<SphereShape>& s, const TriangleStore& store)
        : spheres(int(s.size())), triangles(int(store.size())) {
        for (int k = 0; k < kSmallSceneMax; ++k) {
            const int g = k / 4, i = k % 4;
            const double* m = k < spheres ? s[size_t(k)].object_from_world.m : nullptr;
            for (int r = 0; r < 3; ++r) {  // unused lanes: a unit sphere at the origin (never read)
                scale[g][r][i] = m ? m[5 * r] : 1.0;
                offset[g][r][i] = m ? m[4 * r + 3] : 0.0;
                lo[g][r][i] = INFINITY;
                hi[g][r][i] = -INFINITY;
            }
            if (k >= triangles) continue;
            const TriangleShape t = store[size_t(k)];
            for (const Vec3& c : {t.v0, t.v1, t.v2}) {
                const double x[3] = {c.x, c.y, c.z};
                for (int r = 0; r < 3; ++r) {
                    lo[g][r][i] = std::fmin(lo[g][r][i], x[r]);
                    hi[g][r][i] = std::fmax(hi[g][r][i], x[r]);
                }
            }
        }
    }

    // Bit k set unless sphere k certainly has no root in (t_min, ...) on `ray`: unless
    // intersect_sphere would return false at sphere_roots' sphere_leaves or sphere_misses, with
    // these numbers per lane (axis_aligned_point and _vector, the dots left to right, no FMA:
    // -ffp-contract=off). (Where b = 0 the scalar test takes b's sign from the full transform:
    // the rejections read b only as b > 0 and b², which the sign of a zero does not change.)
    PHONG_AVX2 __attribute__((always_inline)) unsigned sphere_candidates(const Ray& ray, double t_min) const {
        // The groups written out (a loop over them compiled to a general one, its constants on
        // the stack: ~2.5 times the instructions). Always inlined: once scene.cpp grew, GCC
        // called it from occluded_small_each (+2.6 % of S1's render instructions).
        unsigned kept = spheres_kept(0, ray, t_min);
        if (spheres > 4) kept |= spheres_kept(1, ray, t_min) << 4;
        return kept & ((1u << spheres) - 1u);
    }

    // Bit k set where hit_node (bvh.hpp) would enter triangle k's box on `ray` beyond t_min:
    // per lane its operations (the reciprocals 1/d, each slab's (bound − o)·inv, the far one
    // widened by kSlabFarWidening, max and min keeping t0 and t1 on NaN), so its argument holds:
    // a triangle hit beyond t_min lies in an entered box. No upper limit, for closest hits too
    // (bvh.hpp, kAnyHitBoxLimit: a cap at t_max·kSlabFarWidening culled hits whose watertight
    // distance fell short of the exact one).
    // `inv`: the ray's reciprocals (reciprocals()).
    PHONG_AVX2 unsigned box_candidates(const Ray& ray, const double (&inv)[4], double t_min) const {
        unsigned kept = boxes_kept(0, ray, inv, t_min);
        if (triangles > 4) kept |= boxes_kept(1, ray, inv, t_min) << 4;
        return kept & ((1u << triangles) - 1u);
    }

    // 1 / d per axis, and 1 / 1 in the last lane: box_candidates' reciprocals. Asked for before
    // sphere_candidates, their division's latency passes during the sphere lanes (waiting for it
    // was ~4 % of S1's render).
    PHONG_AVX2 static void reciprocals(const Ray& ray, double (&inv)[4]) {
        _mm256_store_pd(inv, _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_setr_pd(ray.dir.x, ray.dir.y, ray.dir.z, 1.0)));
    }

  private:
    // sphere_candidates for the spheres of group g.
    PHONG_AVX2 __attribute__((always_inline)) unsigned spheres_kept(int g, const Ray& ray, double t_min) const {
        const double p[3] = {ray.origin.x, ray.origin.y, ray.origin.z}, v[3] = {ray.dir.x, ray.dir.y, ray.dir.z};
        __m256d o[3], d[3];
        for (int r = 0; r < 3; ++r) {
            const __m256d s = _mm256_load_pd(scale[g][r]);
            o[r] = _mm256_add_pd(_mm256_mul_pd(s, _mm256_set1_pd(p[r])), _mm256_load_pd(offset[g][r]));
            d[r] = _mm256_mul_pd(s, _mm256_set1_pd(v[r]));
        }
        return detail::kept_lanes(detail::dot_lanes(o, o), detail::dot_lanes(o, d), detail::dot_lanes(d, d), t_min);
    }

    // box_candidates for the triangles of group g, inv the ray's reciprocals.
    PHONG_AVX2 __attribute__((always_inline)) unsigned boxes_kept(int g, const Ray& ray, const double (&inv)[4],
                                                                  double t_min) const {
        const double o[3] = {ray.origin.x, ray.origin.y, ray.origin.z}, d[3] = {ray.dir.x, ray.dir.y, ray.dir.z};
        __m256d t0 = _mm256_set1_pd(t_min), t1 = _mm256_set1_pd(INFINITY);
        for (int r = 0; r < 3; ++r) {
            // 1/d has d's sign (also for ±0, ±inf and NaN): read from d, the choice need not wait
            // for the division.
            const bool negative = std::signbit(d[r]);
            const __m256d from = _mm256_set1_pd(o[r]), scale_r = _mm256_set1_pd(inv[r]);
            const __m256d near =
                _mm256_mul_pd(_mm256_sub_pd(_mm256_load_pd(negative ? hi[g][r] : lo[g][r]), from), scale_r);
            const __m256d far = _mm256_mul_pd(
                _mm256_mul_pd(_mm256_sub_pd(_mm256_load_pd(negative ? lo[g][r] : hi[g][r]), from), scale_r),
                _mm256_set1_pd(kSlabFarWidening));
            t0 = _mm256_max_pd(near, t0);  // near > t0 ? near : t0 (NaN near: t0)
            t1 = _mm256_min_pd(far, t1);   // far < t1 ? far : t1 (NaN far: t1)
        }
        return unsigned(_mm256_movemask_pd(_mm256_cmp_pd(t0, t1, _CMP_LE_OQ)));
    }
};

// Bit j set unless ray j of a packet certainly has no root on the axis-aligned sphere s: the rays
// share `origin`, ray j's direction is (dx[j], dy[j], dz[j]), j < count (arrays of count rounded
// up to a multiple of four, 32-byte aligned; unused entries any finite direction). Per lane sphere_candidates' test,
// from intersect_sphere's o and c, which the rays share.
PHONG_AVX2 inline unsigned rays_near_sphere(const SphereShape& s, const Vec3& origin, const double* dx,
                                            const double* dy, const double* dz, int count, double t_min) {
    assert(s.axis_aligned);
    const double* m = s.object_from_world.m;
    const Vec3 o = s.object_from_world.axis_aligned_point(origin);
    const __m256d oo = _mm256_set1_pd(dot(o, o));
    const __m256d o4[3] = {_mm256_set1_pd(o.x), _mm256_set1_pd(o.y), _mm256_set1_pd(o.z)};
    const __m256d scale[3] = {_mm256_set1_pd(m[0]), _mm256_set1_pd(m[5]), _mm256_set1_pd(m[10])};
    auto group = [&](int first) PHONG_AVX2 __attribute__((always_inline)) {
        const __m256d d[3] = {_mm256_mul_pd(scale[0], _mm256_load_pd(dx + first)),
                              _mm256_mul_pd(scale[1], _mm256_load_pd(dy + first)),
                              _mm256_mul_pd(scale[2], _mm256_load_pd(dz + first))};
        return detail::kept_lanes(oo, detail::dot_lanes(o4, d), detail::dot_lanes(d, d), t_min);
    };
    unsigned near = 0;
    for (int first = 0; first < count; first += 4) near |= unsigned(group(first)) << first;
    return near;
}

}  // namespace phong
