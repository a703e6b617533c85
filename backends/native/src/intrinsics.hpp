// SPDX-License-Identifier: Apache-2.0
// UsdGeom's intrinsic prims as exact surfaces: the parts the Python wrapper cuts each of them
// into (a Cylinder is a side and two caps, a Capsule a side and two spheres), each a canonical
// shape in its own object space under an affine map, as spheres are (shapes.hpp):
//   box      the cube [-1, 1]^3                                         (UsdGeom.Cube)
//   frustum  the side x^2 + y^2 = r(z)^2, |z| <= 1, r linear from r0 at z = -1 to r1 at z = +1
//            (a cylinder r0 = r1; a cone r1 = 0)                       (Cylinder, Cone, *_1)
//   disk     x^2 + y^2 <= r0^2 at z = z0                                (their caps)
//   square   |x|, |y| <= 1 at z = 0                                     (UsdGeom.Plane)
//   plane    z = 0, unbounded: kept out of the BVH and the scene bounds (Scene::planes)
//   sphere   the unit sphere                                            (a Capsule's ends)
// Object-space ray o + t d with d = M^-1 dir unnormalised, so t is the world distance along a
// unit world ray, as for spheres.
#pragma once

#include <cmath>
#include <cstdint>

#include "math.hpp"
#include "shapes.hpp"

namespace phong {

enum class IntrinsicKind : int32_t { kBox = 0, kFrustum = 1, kDisk = 2, kSquare = 3, kPlane = 4, kSphere = 5 };

struct IntrinsicShape {
    Affine object_from_world;
    IntrinsicKind kind = IntrinsicKind::kBox;
    double r0 = 1.0, r1 = 1.0;  // frustum: radii at z = -1, +1; disk: r0
    double z0 = 0.0;            // disk: its height
    Vec3 bounds_lo, bounds_hi;  // world AABB of the object-space box (exact for a box)
    int32_t material = 0;
    int32_t object = 0;  // the model node it is part of (LightLinking's numbering, after spheres and meshes)
};

namespace detail {

// Roots of A t^2 + 2 B t + C = 0 in (t_min, t_max), the nearer first, given the discriminant
// B^2 - A C as computed without cancellation by the caller (disc) and C factored likewise:
// q = -(B + sign(B) sqrt(disc)) has no cancellation; the roots are q/A and C/q (the small root
// from C/q keeps its relative precision: a shadow ray leaving the surface sees its own t ~ 0
// as ~0, not as the rounding error of a large number). Degenerate A (a ray along the cone's
// generator) is the linear case -C / 2B.
inline bool stable_roots(double A, double B, double C, double disc, double& t_near, double& t_far) {
    double t0, t1;
    if (A == 0.0) {
        if (B == 0.0) return false;
        t0 = t1 = -C / (2.0 * B);
    } else {
        if (!(disc >= 0.0)) return false;
        const double q = -(B + std::copysign(std::sqrt(disc), B));
        if (q == 0.0) {
            t0 = t1 = 0.0;
        } else {
            t0 = q / A;
            t1 = C / q;
            if (t0 > t1) std::swap(t0, t1);
        }
    }
    t_near = t0;
    t_far = t1;
    return true;
}

// The frustum side: F(p) = x^2 + y^2 - (a + b z)^2 with a = (r0 + r1)/2, b = (r1 - r0)/2.
// C = F(o) is factored as (rho - r)(rho + r) with rho = |o_xy| (no cancellation between two
// large squares for a far origin); disc = B^2 - A C is computed as -A F(f), f the origin moved to
// the quadratic's vertex (the closest approach, as pbrt's sphere test), factored the same way.
inline bool frustum_hit(const IntrinsicShape& s, const Vec3& o, const Vec3& d, double t_min, double t_max,
                        double& t_hit) {
    const double a = 0.5 * (s.r0 + s.r1), b = 0.5 * (s.r1 - s.r0);
    auto f_of = [&](const Vec3& p) {
        const double rho = std::sqrt(p.x * p.x + p.y * p.y), r = a + b * p.z;
        return (rho - r) * (rho + r);
    };
    const double A = d.x * d.x + d.y * d.y - b * b * d.z * d.z;
    const double B = o.x * d.x + o.y * d.y - b * d.z * (a + b * o.z);
    const double C = f_of(o);
    double disc = 0.0;
    if (A != 0.0) {
        const Vec3 f = o - d * (B / A);
        disc = -A * f_of(f);
    }
    double t0, t1;
    if (!stable_roots(A, B, C, disc, t0, t1)) return false;
    for (const double t : {t0, t1}) {
        if (!(t > t_min && t < t_max)) continue;
        const double z = o.z + t * d.z;
        // Within the side's height, and on the nappe of non-negative radius (the quadric is a
        // double cone; a cone's mirror image above its apex is not the prim).
        if (z >= -1.0 && z <= 1.0 && a + b * z >= 0.0) {
            t_hit = t;
            return true;
        }
    }
    return false;
}

inline bool box_hit(const Vec3& o, const Vec3& d, double t_min, double t_max, double& t_hit) {
    double near = -HUGE_VAL, far = HUGE_VAL;
    for (int k = 0; k < 3; ++k) {
        const double inv = 1.0 / d[k];
        double t0 = (-1.0 - o[k]) * inv, t1 = (1.0 - o[k]) * inv;
        if (t0 > t1) std::swap(t0, t1);
        // NaN (an origin on a face's plane, parallel to it: 0 · inf) leaves the interval as it is.
        near = std::fmax(near, t0);
        far = std::fmin(far, t1);
    }
    if (!(near <= far)) return false;
    if (near > t_min && near < t_max) {
        t_hit = near;
        return true;
    }
    if (far > t_min && far < t_max) {
        t_hit = far;
        return true;
    }
    return false;
}

// The planar parts: z = z0 within their outline.
inline bool planar_hit(const IntrinsicShape& s, const Vec3& o, const Vec3& d, double t_min, double t_max,
                       double& t_hit) {
    if (d.z == 0.0) return false;
    const double t = (s.z0 - o.z) / d.z;
    if (!(t > t_min && t < t_max)) return false;
    const double x = o.x + t * d.x, y = o.y + t * d.y;
    if (s.kind == IntrinsicKind::kDisk && !(x * x + y * y <= s.r0 * s.r0)) return false;
    if (s.kind == IntrinsicKind::kSquare && !(std::fabs(x) <= 1.0 && std::fabs(y) <= 1.0)) return false;
    t_hit = t;
    return true;
}

}  // namespace detail

// The nearest hit of the part in (t_min, t_max) along the unit world ray, or false.
inline bool intersect_intrinsic(const IntrinsicShape& s, const Ray& ray, double t_min, double t_max, double& t_hit) {
    const Vec3 o = s.object_from_world.point(ray.origin), d = s.object_from_world.vector(ray.dir);
    switch (s.kind) {
        case IntrinsicKind::kBox:
            return detail::box_hit(o, d, t_min, t_max, t_hit);
        case IntrinsicKind::kFrustum:
            return detail::frustum_hit(s, o, d, t_min, t_max, t_hit);
        case IntrinsicKind::kSphere:
            return detail::sphere_roots(o, dot(o, o) - 1.0, d, dot(d, d), dot(o, d), t_min, t_max, t_hit);
        default:
            return detail::planar_hit(s, o, d, t_min, t_max, t_hit);
    }
}

// The unit world normal (not yet facing the viewer) at world point p of the part.
inline Vec3 intrinsic_normal(const IntrinsicShape& s, const Vec3& p) {
    const Vec3 q = s.object_from_world.point(p);
    Vec3 n;
    switch (s.kind) {
        case IntrinsicKind::kBox: {
            // The face whose coordinate is the largest in magnitude.
            const double ax = std::fabs(q.x), ay = std::fabs(q.y), az = std::fabs(q.z);
            if (ax >= ay && ax >= az)
                n = {std::copysign(1.0, q.x), 0, 0};
            else if (ay >= az)
                n = {0, std::copysign(1.0, q.y), 0};
            else
                n = {0, 0, std::copysign(1.0, q.z)};
            break;
        }
        case IntrinsicKind::kFrustum: {
            const double a = 0.5 * (s.r0 + s.r1), b = 0.5 * (s.r1 - s.r0);
            n = {q.x, q.y, -b * (a + b * q.z)};
            break;
        }
        case IntrinsicKind::kSphere:
            n = q;
            break;
        default:
            n = {0, 0, 1};
            break;
    }
    return normalize(s.object_from_world.transposed_vector(n));
}

}  // namespace phong
