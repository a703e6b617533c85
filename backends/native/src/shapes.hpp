// SPDX-License-Identifier: Apache-2.0
// Shapes: analytic spheres under any affine transform (stable quadratic, pbrt-v4 §6.8.2 /
// Ray Tracing Gems ch. 7) and triangles (watertight test of Woop, Benthin and Wald, JCGT 2013,
// with a consistent tie-breaking rule for rays that pass exactly through an edge or vertex).
#pragma once

#include <emmintrin.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>

#include "math.hpp"

namespace phong {

// A 3x4 affine matrix (column-vector convention: p' = M p + t), row-major.
struct Affine {
    double m[12];

    Vec3 point(const Vec3& p) const {
        return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
    }
    Vec3 vector(const Vec3& v) const {
        return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                m[8] * v.x + m[9] * v.y + m[10] * v.z};
    }
    // point() and vector() when the linear part is diagonal (axis_aligned() below): the same
    // numbers but for the sign of a zero coordinate. A zero off-diagonal term adds ±0, which
    // changes no sum except a zero one (x + ±0 = x for x != 0), so a coordinate can differ only
    // when its diagonal product and its translation are both zero, and then only in sign.
    Vec3 axis_aligned_point(const Vec3& p) const { return {m[0] * p.x + m[3], m[5] * p.y + m[7], m[10] * p.z + m[11]}; }
    Vec3 axis_aligned_vector(const Vec3& v) const { return {m[0] * v.x, m[5] * v.y, m[10] * v.z}; }
    bool axis_aligned() const {
        return m[1] == 0.0 && m[2] == 0.0 && m[4] == 0.0 && m[6] == 0.0 && m[8] == 0.0 && m[9] == 0.0;
    }

    // The linear part transposed times v: maps an object-space normal to world space when
    // this matrix is object_from_world.
    Vec3 transposed_vector(const Vec3& v) const {
        return {m[0] * v.x + m[4] * v.y + m[8] * v.z, m[1] * v.x + m[5] * v.y + m[9] * v.z,
                m[2] * v.x + m[6] * v.y + m[10] * v.z};
    }
};

// The unit sphere at the origin of object space.
struct SphereShape {
    Affine object_from_world;
    Vec3 bounds_lo, bounds_hi;  // exact world AABB
    int32_t material;
    bool axis_aligned = false;  // object_from_world.axis_aligned(): a scaled and translated sphere
};

// A ray origin in a sphere's object space, with c = |o|^2 - 1: the part of the sphere test that
// rays from one point share (shadow-ray bundles compute it once).
struct SphereOrigin {
    Vec3 o;
    double c;
};

inline SphereOrigin sphere_origin(const SphereShape& s, const Vec3& origin) {
    const Vec3 o = s.object_from_world.point(origin);
    return {o, dot(o, o) - 1.0};
}

// The sure-miss test ahead of the sphere test's roots (sphere_misses below) rejects a ray only
// where g = a·c − b², exactly a (|f|² − 1) with f the closest-approach vector, exceeds
// kSphereMissMargin · a (|o|² + 1). Rounding moves the test's computed |f| from the exact one on
// the computed o and d by at most ~12 ε|o| (ε = 2^-53: the ratio b/a, the products d·(b/a) and
// the norm; |d||b|/a <= |o|), and the computed g from its exact value by at most ~20 ε a (|o|² +
// 1) (b² <= a|o|²); a computed |f| <= 1 therefore needs g <= ~34 ε a (|o|² + 1). 1e-12 is
// ~9000 ε: a ray it rejects passes the sphere at more than 1e-12 of its radius times |o| outside,
// where the test's discriminant is negative for certain, and its answer is unchanged.
constexpr double kSphereMissMargin = 1e-12;
// Below this a = |d|² the test's discriminant a (1 − |f|)(1 + |f|) may underflow to −0, which
// passes as zero (a tangent ray); the sure-miss test leaves such rays (spheres > 2^450 times the
// direction's length) to it. Rays with an overflowing g (|o| beyond ~2^500) are left to it too.
constexpr double kSphereMissMinA = 0x1p-900;

namespace detail {
// True only where sphere_roots(o, c, d, a, b, ...) would find the discriminant negative (see
// kSphereMissMargin), from products alone: it skips the test's division and two square roots,
// whose latency sets a shadow ray's time, for the rays that pass a sphere's box and miss it.
inline bool sphere_misses(double c, double a, double b) {
    const double g = a * c - b * b;
    return g > kSphereMissMargin * a * (c + 2.0) && g <= std::numeric_limits<double>::max() && a >= kSphereMissMinA;
}

// True only where sphere_roots(o, c, d, a, b, t_min, ...) finds no root above t_min >= 0 on a
// ray moving away from the centre (b > 0): q = −(b + sqrt(disc)) <= −b < 0, so t0 = q/a < 0,
// and t1 = c/q <= 0 for c >= 0 (an origin outside). For an origin inside (c < 0; then |c| >=
// 2^-53, as c = |o|² − 1), disc = b² − ac >= b², so |q| >= 2b and t1 <= |c|/(2b) to a few
// roundings: at most t_min wherever |c| <= b·t_min, with a factor 2 to spare
// (kLeavingMargin keeps the product's roundings on the safe side besides). This is a shadow
// ray's test of the sphere it leaves, whose origin lies within rounding of the surface, and of
// a sphere behind a ray.
constexpr double kLeavingMargin = 1.0 - ulps(4);
inline bool sphere_leaves(double c, double b, double t_min) { return b > 0.0 && -c <= b * t_min * kLeavingMargin; }

// The roots' part of the sphere test, from the object-space origin o, c = |o|^2 - 1, direction
// d, a = |d|^2 and b = o·d: |o + t d|^2 = 1, i.e. a t^2 + 2 b t + c = 0.
inline bool sphere_roots(const Vec3& o, double c, const Vec3& d, double a, double b, double t_min, double t_max,
                         double& t_hit) {
    // A ray leaving the sphere (b > 0) from a point outside it or within t_min of its surface:
    // both roots are at most t_min (see sphere_leaves), so the answer is no hit.
    assert(t_min >= 0.0);
    if (sphere_leaves(c, b, t_min)) return false;
    if (sphere_misses(c, a, b)) return false;
    // Discriminant b^2 - a c = a (1 - |f|^2), f = the closest-approach vector: no cancellation
    // between b^2 and a c for rays far from the sphere (pbrt-v4's form).
    const Vec3 f = o - d * (b / a);
    const double len_f = length(f);
    const double disc = a * (1.0 - len_f) * (1.0 + len_f);
    if (!(disc >= 0.0)) return false;
    // Stable roots: q has no cancellation; t0 = q/a, t1 = c/q.
    const double q = -(b + std::copysign(std::sqrt(disc), b));
    double t0, t1;
    if (q == 0.0) {  // origin on the sphere moving tangentially: the double root is t = 0
        t0 = t1 = 0.0;
    } else {
        t0 = q / a;
        t1 = c / q;
        if (t0 > t1) std::swap(t0, t1);
    }
    if (t0 > t_min && t0 < t_max) {
        t_hit = t0;
        return true;
    }
    if (t1 > t_min && t1 < t_max) {
        t_hit = t1;
        return true;
    }
    return false;
}
}  // namespace detail

// Closest root of the sphere in (t_min, t_max) along world direction `dir` from `origin`, or false.
inline bool intersect_sphere(const SphereShape& s, const SphereOrigin& origin, const Vec3& dir, double t_min,
                             double t_max, double& t_hit) {
    const Vec3& o = origin.o;
    Vec3 d = s.axis_aligned ? s.object_from_world.axis_aligned_vector(dir) : s.object_from_world.vector(dir);
    double b = dot(o, d);
    // The axis-aligned d differs from vector()'s at most in the sign of a zero coordinate, which
    // reaches only a, c and |f| squared and b; b only when b is zero (a sum changes only when all its
    // terms are zero): then b's sign, which picks the root formula, is taken from vector()'s d.
    if (b == 0.0 && s.axis_aligned) {
        d = s.object_from_world.vector(dir);
        b = dot(o, d);
    }
    return detail::sphere_roots(o, origin.c, d, dot(d, d), b, t_min, t_max, t_hit);
}

namespace detail {
inline __m128d select(__m128d mask, __m128d if_set, __m128d if_clear) {
    return _mm_or_pd(_mm_and_pd(mask, if_set), _mm_andnot_pd(mask, if_clear));
}
}  // namespace detail

// intersect_sphere(s, origin, dir, t_min, t_max, t) for two directions at once (SSE2 double
// lanes: (dx, dy, dz) and t_max per lane): bit i of the result is lane i's answer. Per lane the
// same IEEE operations in the same order as the scalar test (no FMA in the x86-64 baseline),
// branches replaced by selects of both sides, so the same answers; a lane whose b is zero under
// the axis-aligned transform takes the scalar test (its sign rule, above).
inline int intersect_sphere_pair(const SphereShape& s, const SphereOrigin& origin, __m128d dx, __m128d dy, __m128d dz,
                                 double t_min, __m128d t_max) {
    const double* m = s.object_from_world.m;
    __m128d d[3];
    if (s.axis_aligned) {
        d[0] = _mm_mul_pd(_mm_set1_pd(m[0]), dx);
        d[1] = _mm_mul_pd(_mm_set1_pd(m[5]), dy);
        d[2] = _mm_mul_pd(_mm_set1_pd(m[10]), dz);
    } else {
        for (int r = 0; r < 3; ++r)
            d[r] =
                _mm_add_pd(_mm_add_pd(_mm_mul_pd(_mm_set1_pd(m[4 * r]), dx), _mm_mul_pd(_mm_set1_pd(m[4 * r + 1]), dy)),
                           _mm_mul_pd(_mm_set1_pd(m[4 * r + 2]), dz));
    }
    auto dot = [](const __m128d(&u)[3], const __m128d(&v)[3]) {
        return _mm_add_pd(_mm_add_pd(_mm_mul_pd(u[0], v[0]), _mm_mul_pd(u[1], v[1])), _mm_mul_pd(u[2], v[2]));
    };
    const __m128d o[3] = {_mm_set1_pd(origin.o.x), _mm_set1_pd(origin.o.y), _mm_set1_pd(origin.o.z)};
    const __m128d b = dot(o, d), a = dot(d, d);
    // sphere_leaves per lane: both rays leave the sphere (a bundle's test of the sphere its apex
    // lies on), so neither can hit it; the chain of divisions and square roots is skipped.
    const __m128d leaving =
        _mm_and_pd(_mm_cmpgt_pd(b, _mm_setzero_pd()),
                   _mm_cmple_pd(_mm_set1_pd(-origin.c),
                                _mm_mul_pd(_mm_mul_pd(b, _mm_set1_pd(t_min)), _mm_set1_pd(detail::kLeavingMargin))));
    if (_mm_movemask_pd(leaving) == 3) return 0;
    const int scalar_lanes = s.axis_aligned ? _mm_movemask_pd(_mm_cmpeq_pd(b, _mm_setzero_pd())) : 0;
    const __m128d ratio = _mm_div_pd(b, a);
    const __m128d f[3] = {_mm_sub_pd(o[0], _mm_mul_pd(d[0], ratio)), _mm_sub_pd(o[1], _mm_mul_pd(d[1], ratio)),
                          _mm_sub_pd(o[2], _mm_mul_pd(d[2], ratio))};
    const __m128d len_f = _mm_sqrt_pd(dot(f, f)), one = _mm_set1_pd(1.0);
    const __m128d disc = _mm_mul_pd(_mm_mul_pd(a, _mm_sub_pd(one, len_f)), _mm_add_pd(one, len_f));
    int hits = _mm_movemask_pd(_mm_cmpge_pd(disc, _mm_setzero_pd()));
    if (hits & ~scalar_lanes) {
        const __m128d sign = _mm_set1_pd(-0.0);
        const __m128d root = _mm_sqrt_pd(disc);
        const __m128d q = _mm_xor_pd(_mm_add_pd(b, _mm_or_pd(_mm_andnot_pd(sign, root), _mm_and_pd(sign, b))), sign);
        const __m128d tangent = _mm_cmpeq_pd(q, _mm_setzero_pd());
        const __m128d t0 = _mm_andnot_pd(tangent, _mm_div_pd(q, a));
        const __m128d t1 = _mm_andnot_pd(tangent, _mm_div_pd(_mm_set1_pd(origin.c), q));
        const __m128d swap = _mm_cmpgt_pd(t0, t1);
        const __m128d near = detail::select(swap, t1, t0), far = detail::select(swap, t0, t1);
        const __m128d lo = _mm_set1_pd(t_min);
        const __m128d in_range = _mm_or_pd(_mm_and_pd(_mm_cmpgt_pd(near, lo), _mm_cmplt_pd(near, t_max)),
                                           _mm_and_pd(_mm_cmpgt_pd(far, lo), _mm_cmplt_pd(far, t_max)));
        hits &= _mm_movemask_pd(in_range);
    }
    if (scalar_lanes) {
        alignas(16) double x[2], y[2], z[2], limit[2];
        _mm_store_pd(x, dx);
        _mm_store_pd(y, dy);
        _mm_store_pd(z, dz);
        _mm_store_pd(limit, t_max);
        for (int i = 0; i < 2; ++i) {
            if (!(scalar_lanes & (1 << i))) continue;
            double t;
            hits = intersect_sphere(s, origin, Vec3{x[i], y[i], z[i]}, t_min, limit[i], t) ? hits | (1 << i)
                                                                                           : hits & ~(1 << i);
        }
    }
    return hits;
}

inline bool intersect_sphere(const SphereShape& s, const Ray& ray, double t_min, double t_max, double& t_hit) {
    if (!s.axis_aligned) return intersect_sphere(s, sphere_origin(s, ray.origin), ray.dir, t_min, t_max, t_hit);
    // As intersect_sphere(s, sphere_origin(s, ray.origin), ...) but with both transforms
    // axis-aligned: o and d may differ from the full ones in the sign of a zero coordinate, so
    // b = o·d is the same unless it is zero, and a, c and |f| are squares (see above).
    Vec3 o = s.object_from_world.axis_aligned_point(ray.origin);
    Vec3 d = s.object_from_world.axis_aligned_vector(ray.dir);
    double b = dot(o, d);
    if (b == 0.0) {
        o = s.object_from_world.point(ray.origin);
        d = s.object_from_world.vector(ray.dir);
        b = dot(o, d);
    }
    return detail::sphere_roots(o, dot(o, o) - 1.0, d, dot(d, d), b, t_min, t_max, t_hit);
}

// World-space unit normal of the sphere at world point p (outward).
inline Vec3 sphere_normal(const SphereShape& s, const Vec3& p) {
    return normalize(s.object_from_world.transposed_vector(s.object_from_world.point(p)));
}

// A sphere of a Points set (model: phongscene.scene.Points): 32 bytes, where a SphereShape holds
// its matrix and bounds in 152. It is traced as the SphereShape of Sphere.at(center, radius)
// (ball_sphere below), with the same numbers: numpy's inverse of that matrix (LAPACK's
// triangular solve multiplies by the reciprocal of the diagonal) is s = 1/r on the diagonal,
// zeros (+0) off it, and the translation t = 0 − c·s (+0 where c·s is ±0), which is what
// ball_object_from_world computes; tests/native/test_native_points.py renders a Points set and
// the same Spheres to identical images.
struct BallShape {
    Vec3 center;
    double radius;
};

inline Affine ball_object_from_world(const BallShape& b) {
    const double s = 1.0 / b.radius;
    return {{s, 0.0, 0.0, 0.0 - b.center.x * s, 0.0, s, 0.0, 0.0 - b.center.y * s, 0.0, 0.0, s, 0.0 - b.center.z * s}};
}

// The SphereShape the ball stands for (for the less travelled paths: shading, shadow bundles).
inline SphereShape ball_sphere(const BallShape& b, int32_t material) {
    SphereShape s;
    s.object_from_world = ball_object_from_world(b);
    // Sphere bounds as the Scene computes them (centre ± the row norms, here sqrt(r²) = r).
    s.bounds_lo = {b.center.x - b.radius, b.center.y - b.radius, b.center.z - b.radius};
    s.bounds_hi = {b.center.x + b.radius, b.center.y + b.radius, b.center.z + b.radius};
    s.material = material;
    s.axis_aligned = true;
    return s;
}

// intersect_sphere(ball_sphere(b), ray, ...) without building the matrix: the axis-aligned
// path's operations (axis_aligned_point/vector: m[0]·x + m[3]) on the same numbers, and for b
// = o·d = 0 the full path (its sign rule).
inline bool intersect_ball(const BallShape& ball, const Ray& ray, double t_min, double t_max, double& t_hit) {
    const double s = 1.0 / ball.radius;
    const Vec3 t{0.0 - ball.center.x * s, 0.0 - ball.center.y * s, 0.0 - ball.center.z * s};
    const Vec3 o{s * ray.origin.x + t.x, s * ray.origin.y + t.y, s * ray.origin.z + t.z};
    const Vec3 d{s * ray.dir.x, s * ray.dir.y, s * ray.dir.z};
    const double b = dot(o, d);
    if (b == 0.0) return intersect_sphere(ball_sphere(ball, 0), ray, t_min, t_max, t_hit);
    return detail::sphere_roots(o, dot(o, o) - 1.0, d, dot(d, d), b, t_min, t_max, t_hit);
}

// Triangle corners, stored in BVH leaf order for the hot loop.
struct TriangleShape {
    Vec3 v0, v1, v2;
};

// A flat-shaded triangle's unit normal: the one expression for both a hit's (render.cpp) and a
// kept one (Scene::flat_normal), so the two are the same number.
inline Vec3 flat_triangle_normal(const TriangleShape& t) { return normalize(cross(t.v1 - t.v0, t.v2 - t.v0)); }

// A smooth triangle's vertex-normal rows (-1: flat shading).
struct TriangleNormals {
    int32_t n0, n1, n2;
};

// The per-ray set-up of the watertight test: the axis along which the ray is most dominant
// becomes z, and a shear maps the ray onto +z.
struct WatertightRay {
    int kx, ky, kz;
    double sx, sy, sz;

    explicit WatertightRay(const Vec3& d) {
        const double ds[3] = {d.x, d.y, d.z};
        const double ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
        kz = (ax > ay) ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
        kx = kz == 2 ? 0 : kz + 1;
        ky = kx == 2 ? 0 : kx + 1;
        if (ds[kz] < 0.0) std::swap(kx, ky);  // keep the winding
        sx = ds[kx] / ds[kz];
        sy = ds[ky] / ds[kz];
        sz = 1.0 / ds[kz];
    }
};

// Barycentric weights of a triangle hit (of v0, v1, v2).
struct Barycentric {
    double b0, b1, b2;
};

namespace detail {
// Tie-breaking for an edge whose edge function is exactly zero (the ray passes through the
// edge in the sheared 2D frame). The edge P->Q belongs to the triangle that would contain the
// ray after an infinitesimal shift by (1, δ), δ << 1, in that frame: inside means E > 0 for
// det > 0 and E < 0 for det < 0, and E changes by (Qy-Py)·1 - (Qx-Px)·δ. The two triangles
// sharing an edge see it with opposite (sign-normalised) directions, so exactly one of them
// owns it; at a shared vertex exactly one triangle of a fan owns the shifted point. The
// sheared coordinates of a vertex are the same for every triangle using it, so this holds
// in floating point, not only in exact arithmetic.
inline bool owns_edge(double px, double py, double qx, double qy, double det) {
    double dx = qx - px, dy = qy - py;
    if (det < 0.0) {
        dx = -dx;
        dy = -dy;
    }
    return dy > 0.0 || (dy == 0.0 && dx < 0.0);
}
}  // namespace detail

// Watertight ray/triangle test: no ray passes between two triangles sharing an edge, and a
// ray through a shared edge or vertex hits exactly one of them.
inline bool intersect_triangle(const TriangleShape& tri, const Ray& ray, const WatertightRay& wr, double t_min,
                               double t_max, double& t_hit, Barycentric& bary) {
    // Arrays, not Vec3, so that the per-ray axis permutation below is an indexed load rather
    // than a chain of selects (Vec3::operator[]).
    const double a[3] = {tri.v0.x - ray.origin.x, tri.v0.y - ray.origin.y, tri.v0.z - ray.origin.z};
    const double b[3] = {tri.v1.x - ray.origin.x, tri.v1.y - ray.origin.y, tri.v1.z - ray.origin.z};
    const double c[3] = {tri.v2.x - ray.origin.x, tri.v2.y - ray.origin.y, tri.v2.z - ray.origin.z};
    // Shear and scale into the ray's frame (the ray is the +z axis through the origin).
    const double ax = a[wr.kx] - wr.sx * a[wr.kz], ay = a[wr.ky] - wr.sy * a[wr.kz];
    const double bx = b[wr.kx] - wr.sx * b[wr.kz], by = b[wr.ky] - wr.sy * b[wr.kz];
    const double cx = c[wr.kx] - wr.sx * c[wr.kz], cy = c[wr.ky] - wr.sy * c[wr.kz];
    // Edge functions (2D cross products); fl(p - q) = -fl(q - p), so neighbours agree on signs.
    const double u = cx * by - cy * bx;  // edge v1 -> v2
    const double v = ax * cy - ay * cx;  // edge v2 -> v0
    const double w = bx * ay - by * ax;  // edge v0 -> v1
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    const double det = u + v + w;
    if (det == 0.0) return false;  // degenerate, or seen exactly edge-on
    if (u == 0.0 && !detail::owns_edge(bx, by, cx, cy, det)) return false;
    if (v == 0.0 && !detail::owns_edge(cx, cy, ax, ay, det)) return false;
    if (w == 0.0 && !detail::owns_edge(ax, ay, bx, by, det)) return false;
    // Scaled hit distance, compared before the division.
    const double az = wr.sz * a[wr.kz], bz = wr.sz * b[wr.kz], cz = wr.sz * c[wr.kz];
    const double t_scaled = u * az + v * bz + w * cz;
    const double t = t_scaled / det;
    if (!(t > t_min && t < t_max)) return false;
    t_hit = t;
    bary = {u / det, v / det, w / det};
    return true;
}

}  // namespace phong
