// SPDX-License-Identifier: Apache-2.0
// Vectors, rays and every tolerance of the native tracer. Geometry is double precision
// throughout (as in POV-Ray); colours are doubles too and are rounded to float32 only when a
// pixel is stored.
#pragma once

#include <cmath>
#include <cstdint>

namespace phong {

struct Vec3 {
    double x = 0, y = 0, z = 0;

    double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

using RGB = Vec3;  // linear RGB, same arithmetic as a vector

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(const Vec3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(double s, const Vec3& a) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator/(const Vec3& a, double s) { return {a.x / s, a.y / s, a.z / s}; }
inline Vec3& operator+=(Vec3& a, const Vec3& b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
// Per-channel product (colours).
inline Vec3 hadamard(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }

inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(const Vec3& a) { return a / length(a); }
inline double max_abs_component(const Vec3& a) {
    return std::fmax(std::fabs(a.x), std::fmax(std::fabs(a.y), std::fabs(a.z)));
}

struct Ray {
    Vec3 origin;
    Vec3 dir;  // unit length for camera and shadow rays
    Vec3 at(double t) const { return origin + dir * t; }
};

// ---------------------------------------------------------------------------------------------
// Tolerances. POV-Ray's are absolute (primary t >= 1e-4, shadow 1e-3 < t < dist - 1e-3), which
// makes its images wrong below ~1e-3 and beyond ~1e6 scene units. Ours are relative to the
// scene's magnitude M = the largest absolute coordinate of the geometry bounds and the camera
// position (computed once per render): a hit point p = o + t·d is computed to a few ulps of M
// (~1e-16·M), whatever the scene's scale, so a tolerance proportional to M is scale-invariant.

// A distance below kRelativeEpsilon·M counts as zero. 1e-9 is ~4.5e6 ulps of M, far above the
// rounding of any computed hit point, yet at ordinary scales (M <= 1e3) it is 1e-6 or less,
// 1000x finer than POV-Ray's smallest tolerance, so the images agree with POV-Ray wherever its
// own tolerances are not the thing being measured (nothing lies within 1e-3 of a surface).
// Used as: the primary ray's near limit; the offset of a shadow ray's origin along the
// geometric normal (toward the light), which puts the origin strictly on the light's side of
// the surface it starts on (and of any coplanar neighbour), so no self-hit can occur even at
// n·l = 1e-10, where an unoffset origin's self-hit distance error grows as ~1e-16·M/(n·l); and
// the margin kept before the light's position (a light sitting on a surface does not shadow).
constexpr double kRelativeEpsilon = 1e-9;

// POV-Ray's EPSILON gate: a light contributes only where n·l >= 1e-10 (also no shadow ray).
constexpr double kMinCosineToLight = 1e-10;

// POV-Ray's "ad hoc" phong cut-off (trace.cpp, ComputePhongColour): for phong_size >= 60 the
// highlight is zero unless r·l > 0.0008. Only the povray-classic convention applies it.
constexpr double kClassicPhongCutoffExponent = 60.0;
constexpr double kClassicPhongCutoffCosine = 0.0008;

// POV-Ray's `circular` area lights nudge every grid coordinate by +0.001 before mapping the
// square onto a disc (trace.cpp, TraceAreaLightSubsetShadowRay), so the centre sample is not
// 0/0. Reproduced exactly for sphere lights.
constexpr double kCircularAreaLightNudge = 0.001;

// POV-Ray's `orient` picks the helper axis z for the disc frame unless the light direction is
// within 0.01 of vertical in |l_z| (then y).
constexpr double kOrientVerticalTolerance = 0.01;

constexpr double kPi = 3.14159265358979323846;

}  // namespace phong
