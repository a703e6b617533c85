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

// Shadow rays start exactly at the hit point (as in POV-Ray) and an occluder counts only for
// kShadowWindow·M < t < distance − kShadowWindow·M. 1.5e-5 is POV-Ray's SHADOW_TOLERANCE (1e-3)
// expressed relative to M ≈ 67, the magnitude of a typical scene (unit-sized objects on a ground
// quad of ±40…60 units, as in tests/calibration.py with M = 63.7 and the benchmarks): there the
// window is 0.96e-3, so the images match POV-Ray even where its tolerance decides a pixel (an
// area-light sample just below a sphere's horizon, whose chord through the sphere is < 1e-3; a
// smooth mesh's terminator). It is also robust: a self-hit's computed distance is at most
// ~1e-16·M/(n·l) <= 1e-6·M at the n·l >= 1e-10 gate, 15x below the window, so no acne at any
// scale. Features thinner than ~1e-5·M cannot cast shadows (POV-Ray: thinner than 1e-3 units).
constexpr double kShadowWindow = 1.5e-5;

// A primary hit needs t >= kPrimaryNear·M: POV-Ray's MIN_ISECT_DEPTH (1e-4) relative to the same
// typical magnitude (the ratio of the two POV-Ray tolerances is kept).
constexpr double kPrimaryNear = 1.5e-6;

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

// Separating-axis slack of a shadow-ray bundle's culling (Scene::shadow_candidates), relative to
// |axis|_1 times the largest coordinate S involved: a leaf is dropped only when its box is
// farther than this from the bundle's hull. The projections round by < 3 ulps (~7e-16·S) and a
// ray of the bundle (origin on the hull's apex, direction rounded, target rounded) strays from
// the exact hull by a few ulps of S, i.e. < 1e-14·S: 1e-9 is 1e5x above that, and far below
// any feature that could be culled usefully (6e-8 units in the benchmark scenes).
constexpr double kShadowBundleSlack = 1e-9;

constexpr double kPi = 3.14159265358979323846;

}  // namespace phong
