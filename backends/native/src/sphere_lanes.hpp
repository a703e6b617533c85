// SPDX-License-Identifier: Apache-2.0
// A sphere against four rays that share their origin, in AVX double lanes: the primary rays of a
// packet meeting a sphere's leaf (ray_packets.cpp). The sphere test is a chain of a division and
// two square roots and then two divisions (shapes.hpp: sphere_roots) whose latency, more than its
// instructions, sets its time (a shadow ray's test, one at a time, is ~10 % of S1's render time
// for ~3 % of its instructions); four lanes take one chain. Per lane the same IEEE operations in the same order as the
// scalar test (no FMA: -ffp-contract=off), its branches replaced by selects of both sides, as intersect_sphere_pair
// (shapes.hpp) does for shadow bundles; so each lane's answer and root are the scalar test's bit
// for bit. A lane whose b = o·d is zero under the axis-aligned transform takes the scalar test
// (its sign rule: shapes.hpp).
#pragma once

#include <immintrin.h>

#include <cmath>

#include "bvh8.hpp"
#include "math.hpp"
#include "shapes.hpp"

namespace phong {

// Rays tested together by intersect_sphere_lanes.
constexpr int kSphereLanes = 4;

// Bit i set when intersect_sphere(s, Ray{origin, (dx, dy, dz) lane i}, t_min, t_max lane i, t)
// would return true; t[i] then holds its root. Lanes past the rays in use may hold any finite
// direction (their bits are ignored by the caller).
PHONG_AVX2 inline int intersect_sphere_lanes(const SphereShape& s, const Vec3& origin, __m256d dx, __m256d dy,
                                             __m256d dz, double t_min, __m256d t_max, double (&t)[kSphereLanes]) {
    const double* m = s.object_from_world.m;
    // The object-space origin and c = |o|² − 1, shared by the four rays: intersect_sphere's
    // (axis_aligned_point on the axis-aligned path, sphere_origin's point() elsewhere).
    const Vec3 o = s.axis_aligned ? s.object_from_world.axis_aligned_point(origin) : s.object_from_world.point(origin);
    const double c = dot(o, o) - 1.0;
    __m256d d[3];
    if (s.axis_aligned) {
        d[0] = _mm256_mul_pd(_mm256_set1_pd(m[0]), dx);
        d[1] = _mm256_mul_pd(_mm256_set1_pd(m[5]), dy);
        d[2] = _mm256_mul_pd(_mm256_set1_pd(m[10]), dz);
    } else {
        for (int r = 0; r < 3; ++r)
            d[r] = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(m[4 * r]), dx),
                                               _mm256_mul_pd(_mm256_set1_pd(m[4 * r + 1]), dy)),
                                 _mm256_mul_pd(_mm256_set1_pd(m[4 * r + 2]), dz));
    }
    auto dot_lanes = [](const __m256d(&u)[3], const __m256d(&v)[3]) PHONG_AVX2 {
        return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(u[0], v[0]), _mm256_mul_pd(u[1], v[1])),
                             _mm256_mul_pd(u[2], v[2]));
    };
    const __m256d o4[3] = {_mm256_set1_pd(o.x), _mm256_set1_pd(o.y), _mm256_set1_pd(o.z)};
    const __m256d b = dot_lanes(o4, d), a = dot_lanes(d, d);
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0), sign = _mm256_set1_pd(-0.0);
    const int scalar_lanes = s.axis_aligned ? _mm256_movemask_pd(_mm256_cmp_pd(b, zero, _CMP_EQ_OQ)) : 0;
    // sphere_roots: f = o − d (b/a), disc = a (1 − |f|)(1 + |f|).
    const __m256d ratio = _mm256_div_pd(b, a);
    const __m256d f[3] = {_mm256_sub_pd(o4[0], _mm256_mul_pd(d[0], ratio)),
                          _mm256_sub_pd(o4[1], _mm256_mul_pd(d[1], ratio)),
                          _mm256_sub_pd(o4[2], _mm256_mul_pd(d[2], ratio))};
    const __m256d len_f = _mm256_sqrt_pd(dot_lanes(f, f));
    const __m256d disc = _mm256_mul_pd(_mm256_mul_pd(a, _mm256_sub_pd(one, len_f)), _mm256_add_pd(one, len_f));
    int hits = _mm256_movemask_pd(_mm256_cmp_pd(disc, zero, _CMP_GE_OQ));  // !(disc >= 0): a miss (NaN too)
    if (hits & ~scalar_lanes) {
        // q = −(b + copysign(sqrt(disc), b)); q = 0: the double root t0 = t1 = 0.
        const __m256d root = _mm256_sqrt_pd(disc);
        const __m256d q =
            _mm256_xor_pd(_mm256_add_pd(b, _mm256_or_pd(_mm256_andnot_pd(sign, root), _mm256_and_pd(sign, b))), sign);
        const __m256d tangent = _mm256_cmp_pd(q, zero, _CMP_EQ_OQ);
        const __m256d t0 = _mm256_andnot_pd(tangent, _mm256_div_pd(q, a));
        const __m256d t1 = _mm256_andnot_pd(tangent, _mm256_div_pd(_mm256_set1_pd(c), q));
        const __m256d swap = _mm256_cmp_pd(t0, t1, _CMP_GT_OQ);  // if (t0 > t1) swap
        const __m256d near = _mm256_blendv_pd(t0, t1, swap), far = _mm256_blendv_pd(t1, t0, swap);
        const __m256d lo = _mm256_set1_pd(t_min);
        const __m256d near_in =
            _mm256_and_pd(_mm256_cmp_pd(near, lo, _CMP_GT_OQ), _mm256_cmp_pd(near, t_max, _CMP_LT_OQ));
        const __m256d far_in = _mm256_and_pd(_mm256_cmp_pd(far, lo, _CMP_GT_OQ), _mm256_cmp_pd(far, t_max, _CMP_LT_OQ));
        hits &= _mm256_movemask_pd(_mm256_or_pd(near_in, far_in));
        _mm256_storeu_pd(t, _mm256_blendv_pd(far, near, near_in));  // the near root where it is in range
    }
    if (scalar_lanes) {
        alignas(32) double x[kSphereLanes], y[kSphereLanes], z[kSphereLanes], limit[kSphereLanes];
        _mm256_store_pd(x, dx);
        _mm256_store_pd(y, dy);
        _mm256_store_pd(z, dz);
        _mm256_store_pd(limit, t_max);
        for (int i = 0; i < kSphereLanes; ++i) {
            if (!(scalar_lanes & (1 << i))) continue;
            hits = intersect_sphere(s, Ray{origin, Vec3{x[i], y[i], z[i]}}, t_min, limit[i], t[i]) ? hits | (1 << i)
                                                                                                   : hits & ~(1 << i);
        }
    }
    return hits;
}

}  // namespace phong
