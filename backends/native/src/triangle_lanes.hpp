// SPDX-License-Identifier: Apache-2.0
// A triangle against four rays that share their origin, in AVX double lanes: the primary rays of
// a packet meeting a leaf whose triangles each ray would test in full (ray_packets.cpp: the
// leaves the float prefilter does not take, such as a ground quad's two triangles, 1.40 of S2's
// 2.10 exact tests a pixel). Per lane the same IEEE operations in the same order as the scalar
// watertight test (shapes.hpp: intersect_triangle; no FMA: -ffp-contract=off), its branches
// replaced by masks, so each lane's answer, distance and weights are the scalar test's bit for
// bit. The rays' shared origin makes the corners' offsets (v − o) the same for every lane; only
// the shear differs. Lanes whose edge function is exactly zero (a ray through an edge: the
// ownership rule) are left to the scalar test, as are rays whose dominant axes differ.
#pragma once

#include <immintrin.h>

#include "bvh8.hpp"
#include "math.hpp"
#include "shapes.hpp"

namespace phong {

// Rays tested together by intersect_triangle_lanes.
constexpr int kTriangleLanes = 4;

// The WatertightRays of four rays with the same axes (kx, ky, kz), their shears in lanes.
struct WatertightLanes {
    int kx, ky, kz;
    __m256d sx, sy, sz;
};

// A hit of intersect_triangle_lanes' lane i: what intersect_triangle would return in t_hit and
// bary (the weights divided out only for the lanes that hit).
struct TriangleLaneHits {
    alignas(32) double t[kTriangleLanes];
    alignas(32) double u[kTriangleLanes], v[kTriangleLanes], w[kTriangleLanes], det[kTriangleLanes];
    Barycentric bary(int i) const { return {u[i] / det[i], v[i] / det[i], w[i] / det[i]}; }
};

// Bit i of the result set when intersect_triangle(tri, Ray{origin, direction i}, that ray's
// WatertightRay, t_min, t_max lane i, ...) would return true; hits then holds its t and weights.
// Bit i of `scalar` set when lane i met an edge function of exactly zero: its answer is the
// scalar test's to give (its bit in the result is clear).
PHONG_AVX2 inline int intersect_triangle_lanes(const TriangleShape& tri, const Vec3& origin, const WatertightLanes& wr,
                                               double t_min, __m256d t_max, TriangleLaneHits& hits, int& scalar) {
    const double a[3] = {tri.v0.x - origin.x, tri.v0.y - origin.y, tri.v0.z - origin.z};
    const double b[3] = {tri.v1.x - origin.x, tri.v1.y - origin.y, tri.v1.z - origin.z};
    const double c[3] = {tri.v2.x - origin.x, tri.v2.y - origin.y, tri.v2.z - origin.z};
    // The shear into each ray's frame: a[kx] − sx · a[kz], as the scalar test.
    auto shear = [](double along, __m256d s, double dominant) PHONG_AVX2 {
        return _mm256_sub_pd(_mm256_set1_pd(along), _mm256_mul_pd(s, _mm256_set1_pd(dominant)));
    };
    const __m256d ax = shear(a[wr.kx], wr.sx, a[wr.kz]), ay = shear(a[wr.ky], wr.sy, a[wr.kz]);
    const __m256d bx = shear(b[wr.kx], wr.sx, b[wr.kz]), by = shear(b[wr.ky], wr.sy, b[wr.kz]);
    const __m256d cx = shear(c[wr.kx], wr.sx, c[wr.kz]), cy = shear(c[wr.ky], wr.sy, c[wr.kz]);
    const __m256d u = _mm256_sub_pd(_mm256_mul_pd(cx, by), _mm256_mul_pd(cy, bx));
    const __m256d v = _mm256_sub_pd(_mm256_mul_pd(ax, cy), _mm256_mul_pd(ay, cx));
    const __m256d w = _mm256_sub_pd(_mm256_mul_pd(bx, ay), _mm256_mul_pd(by, ax));
    const __m256d zero = _mm256_setzero_pd();
    const __m256d negative =
        _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_LT_OQ), _mm256_cmp_pd(v, zero, _CMP_LT_OQ)),
                     _mm256_cmp_pd(w, zero, _CMP_LT_OQ));
    const __m256d positive =
        _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_GT_OQ), _mm256_cmp_pd(v, zero, _CMP_GT_OQ)),
                     _mm256_cmp_pd(w, zero, _CMP_GT_OQ));
    const __m256d det = _mm256_add_pd(_mm256_add_pd(u, v), w);
    // Lanes still in the test after the signs and det = 0 (the scalar test's first two returns).
    const __m256d open =
        _mm256_andnot_pd(_mm256_or_pd(_mm256_and_pd(negative, positive), _mm256_cmp_pd(det, zero, _CMP_EQ_OQ)),
                         _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
    const __m256d on_edge =
        _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_EQ_OQ), _mm256_cmp_pd(v, zero, _CMP_EQ_OQ)),
                     _mm256_cmp_pd(w, zero, _CMP_EQ_OQ));
    scalar = _mm256_movemask_pd(_mm256_and_pd(open, on_edge));
    int lanes = _mm256_movemask_pd(open) & ~scalar;
    if (lanes == 0) return 0;
    const __m256d az = _mm256_mul_pd(wr.sz, _mm256_set1_pd(a[wr.kz])),
                  bz = _mm256_mul_pd(wr.sz, _mm256_set1_pd(b[wr.kz])),
                  cz = _mm256_mul_pd(wr.sz, _mm256_set1_pd(c[wr.kz]));
    const __m256d t_scaled =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(u, az), _mm256_mul_pd(v, bz)), _mm256_mul_pd(w, cz));
    const __m256d t = _mm256_div_pd(t_scaled, det);
    const __m256d in_range =
        _mm256_and_pd(_mm256_cmp_pd(t, _mm256_set1_pd(t_min), _CMP_GT_OQ), _mm256_cmp_pd(t, t_max, _CMP_LT_OQ));
    lanes &= _mm256_movemask_pd(in_range);
    if (lanes == 0) return 0;
    _mm256_store_pd(hits.t, t);
    _mm256_store_pd(hits.u, u);
    _mm256_store_pd(hits.v, v);
    _mm256_store_pd(hits.w, w);
    _mm256_store_pd(hits.det, det);
    return lanes;
}

}  // namespace phong
