// SPDX-License-Identifier: Apache-2.0
// Vectors, rays and every tolerance of the native tracer. Geometry is double precision
// throughout (as in POV-Ray); colours are doubles too and are rounded to float32 only when a
// pixel is stored.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

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
inline Vec3& operator+=(Vec3& a, const Vec3& b) {
    a.x += b.x;
    a.y += b.y;
    a.z += b.z;
    return a;
}
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

// n units of machine epsilon ε = 2^-52, the spacing of doubles just above 1 (one correctly
// rounded operation errs by at most u = ε/2 relative). Every floating-point error margin of the
// tracer is written as ulps(n), with n argued where it is used. The margins are error bounds
// with slack, so pbrt-v4's exact bound gamma(k) = k·u / (1 − k·u) would only move them by a
// relative 1e-15; plain n·ε is exact (n ≤ 2^52), so ulps(n) is the very double its users
// compare against.
constexpr double ulps(int n) { return n * std::numeric_limits<double>::epsilon(); }

// std::nextafter(x, +inf) without the libm call (one per primary hit): the next double above x
// by one step of its bit pattern (up in magnitude when positive, down when negative; ±0 go to
// the smallest subnormal, +inf and NaN stay).
inline double next_up(double x) {
    if (!(x < HUGE_VAL)) return x;
    if (x == 0.0) return std::numeric_limits<double>::denorm_min();
    uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    bits = x > 0.0 ? bits + 1 : bits - 1;
    std::memcpy(&x, &bits, sizeof x);
    return x;
}

// ---------------------------------------------------------------------------------------------
// Tolerances. POV-Ray's are absolute (primary t >= 1e-4, shadow 1e-3 < t < dist - 1e-3), which
// makes its images wrong below ~1e-3 and beyond ~1e6 scene units. Ours play two roles, each
// with its own measure of the scene (computed once per render, ray_tolerances() below):
//  * matching POV-Ray at ordinary scales, relative to the scene's extent E = half the largest
//    side of the bounding box of the geometry and the camera (its size, which neither uniform
//    scaling nor translation changes relative to the features: an image's shadows are decided
//    the same way wherever the scene sits);
//  * floating-point safety (no self-hit "acne"), relative to the magnitude M = the largest
//    absolute coordinate of that box (the scale of every coordinate's rounding).
// The shadow window is the larger of the two. For a scene around the origin E ~ M and the first
// one rules; a small scene far from the origin (extent 100 at 1e6) keeps POV-Ray's window,
// where a window relative to M alone would be 15 units and lose every contact shadow.

// Shadow rays start exactly at the hit point (as in POV-Ray) and an occluder counts only for
// window < t < distance - window, window = max(kShadowWindow·E, kSelfHitWindow·M). 1.9e-5 is
// POV-Ray's SHADOW_TOLERANCE (1e-3) relative to E = 52.8, the extent of the calibration scenes
// (unit-sized objects on a ground quad of about ±40…60 units, tests/support/calibration.py; the
// benchmark scenes, E = 50, get 0.95e-3): there the window is 1.003e-3, so the images match POV-Ray even
// where its tolerance decides a pixel (an area-light sample just below a sphere's horizon, whose
// chord through the sphere is < 1e-3; a smooth mesh's terminator). Features thinner than
// ~2e-5·E cannot cast shadows (POV-Ray: thinner than 1e-3 units).
constexpr double kShadowWindow = 1.9e-5;

// A primary hit needs t >= kPrimaryNear·E: POV-Ray's MIN_ISECT_DEPTH (1e-4) relative to the same
// extent (the ratio of the two POV-Ray tolerances is kept). Camera rays start on no surface, so
// they need no floating-point term.
constexpr double kPrimaryNear = 1.9e-6;

// A shadow ray leaving p along l re-hits p's own surface, if at all, at t_self <= δ/|n·l| with n
// the geometric normal and δ the distance of the computed p from the exact surface plus the
// rounding of the re-intersection. Both are a few ulps of M: p = o + t·d rounds by <= ε/2 per
// operation on coordinates <= M (t itself comes from differences of coordinates <= M, to a few
// ε relative), and the sphere and watertight triangle tests start by subtracting the origin
// p from the centre or vertices (<= ε/2·M each). Measured: t_self·|n·l| <= 2.1ε·M over 2·10^5
// self-hits of rays leaving spheres, ellipsoids and triangles at scales 1e-6…1 and translations
// 0…1e6, cosines 1e-12…1. kSelfHitError = 8ε keeps a 4x margin. (A sphere's curvature also
// caps t_self at ~sqrt(2rδ), whatever the cosine.)
constexpr double kSelfHitError = ulps(8);

// Self-hits stay inside the window wherever |n·l| >= kSelfHitError·M / window, which is at most
// kAcneFreeCosine and, for a scene around the origin (window = 1.9e-5·E, M ~ E), ~1e-10, the
// n·l gate below, as before. A floating-point window that covered cosines down to the gate in
// every scene would be ~1.8e-5·M (15 units at 1e6), which swallows the contact shadows of a
// scene far from the origin; 1e-4 is the compromise: below it a point light's diffuse
// contribution is < 1e-4 of its value at normal incidence, and only scenes smaller than
// kSelfHitWindow / kShadowWindow ≈ 1e-6 of their distance from the origin are concerned.
constexpr double kAcneFreeCosine = 1e-4;

// The floating-point term of the shadow window, per unit of M: 1.8e-11·M, i.e. 1.8e-5 units at
// 1e6 from the origin (a radius-1e-3 sphere there still casts its contact shadow).
constexpr double kSelfHitWindow = kSelfHitError / kAcneFreeCosine;

struct RayTolerances {
    double primary_near;   // primary hits need t >= primary_near
    double shadow_window;  // occluders count for shadow_window < t < distance - shadow_window
    // Secondary (reflected) rays start at a hit point and need t >= secondary_near: POV-Ray's
    // MIN_ISECT_DEPTH relative to the extent like primary_near, but never below the
    // floating-point self-hit term (kSelfHitWindow·M, as for shadow rays), since they leave a surface.
    double secondary_near = 0.0;
};

// The tolerances of a render whose geometry and camera lie in `box_lo`…`box_hi`.
inline RayTolerances ray_tolerances(const Vec3& box_lo, const Vec3& box_hi) {
    const Vec3 side = box_hi - box_lo;
    double extent = 0.5 * std::fmax(side.x, std::fmax(side.y, side.z));
    double magnitude = std::fmax(max_abs_component(box_lo), max_abs_component(box_hi));
    // A box of one point (no geometry, or all of it at the camera): nothing to resolve, any
    // positive scale will do.
    if (!(magnitude > 0.0)) magnitude = 1.0;
    if (!(extent > 0.0)) extent = magnitude;
    return {kPrimaryNear * extent, std::fmax(kShadowWindow * extent, kSelfHitWindow * magnitude),
            std::fmax(kPrimaryNear * extent, kSelfHitWindow * magnitude)};
}

// POV-Ray's own absolute tolerances (its MIN_ISECT_DEPTH and SHADOW_TOLERANCE), for renders that
// must reproduce POV-Ray's images on scenes of any size (cross-validation): they make a scene's
// shadows depend on its units, as in POV-Ray.
constexpr double kPovrayPrimaryNear = 1e-4;
constexpr double kPovrayShadowWindow = 1e-3;
// POV-Ray's per-thread shadow cache retests a light's last occluder with t >= 1e-4 instead: a
// render with this window shows what a pixel becomes when the cache decides it.
constexpr double kPovrayShadowCacheWindow = 1e-4;

// A filtered shadow ray (render.cpp: shadow_filter) crosses at most this many transmissive
// surfaces before it counts as blocked: a guard against a loop, far beyond any real scene.
constexpr int kMaxShadowCrossings = 1024;
// A ray passes at most this many cut-out texels (render.cpp: past_cut_outs) before it counts as a
// miss: the same guard (a forest of masked leaves is far below it).
constexpr int kMaxCutOutCrossings = 1024;

enum class Numerics {
    kScaleInvariant,     // ray_tolerances() below
    kPovray,             // kPovrayPrimaryNear, kPovrayShadowWindow
    kPovrayShadowCache,  // kPovrayPrimaryNear, kPovrayShadowCacheWindow
};

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

// POV-Ray's `adaptive n` area lights (trace.cpp, TraceAreaLightSubsetShadowRay) subdivide a grid
// region when two adjacent corner samples' colours differ by more than 0.1 (|dr| + |dg| + |db|);
// reproduced exactly. kFullSubdivision marks a light without `adaptive` (POV-Ray's default level
// 100, deeper than any grid of at most 2^8 + 1 points per axis: every point is traced).
constexpr double kAdaptiveAreaLightThreshold = 0.1;
constexpr int kFullSubdivision = -1;

// Separating-axis slack of a shadow-ray bundle's culling (Scene::shadow_candidates), relative to
// |axis|_1 times the largest coordinate S involved: a leaf is dropped only when its box is
// farther than this from the bundle's hull. The projections round by < 3 ulps (~7e-16·S) and a
// ray of the bundle (origin on the hull's apex, direction rounded, target rounded) strays from
// the exact hull by a few ulps of S, i.e. < 1e-14·S: 1e-9 is 1e5x above that, and far below
// any feature that could be culled usefully (6e-8 units in the benchmark scenes).
constexpr double kShadowBundleSlack = 1e-9;

constexpr double kPi = 3.14159265358979323846;

}  // namespace phong
