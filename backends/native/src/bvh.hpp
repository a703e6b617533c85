// SPDX-License-Identifier: Apache-2.0
// Bounding volume hierarchy over every primitive (spheres and triangles): binned SAH build
// (Wald 2007), flattened depth-first into 32-byte nodes with conservatively rounded float
// bounds; closest-hit traversal front to back, and any-hit traversal for shadow rays.
#pragma once

#include <emmintrin.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "math.hpp"
#include "uninitialised.hpp"

namespace phong {

// Plain comparisons, not std::fmin/fmax: those are libm calls without -ffast-math (their NaN
// rules have no single x86 instruction), and a validated scene has no NaN.
inline double min_of(double a, double b) { return b < a ? b : a; }
inline double max_of(double a, double b) { return b > a ? b : a; }

// Inline: the scene build grows a box by every corner of every triangle (S2's pass over its
// 1M triangles took 0.040 s with these as calls into bvh.cpp, 0.015 s inlined, one thread).
struct Bounds {
    Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL};
    Vec3 hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};

    void grow(const Vec3& p) {
        lo = {min_of(lo.x, p.x), min_of(lo.y, p.y), min_of(lo.z, p.z)};
        hi = {max_of(hi.x, p.x), max_of(hi.y, p.y), max_of(hi.z, p.z)};
    }
    // Corner-wise, so that an empty b (lo = +inf, hi = -inf) changes nothing. (Growing by b.lo
    // and b.hi as points made an empty bin's union infinite, which priced every split beside
    // an empty bin at an infinite SAH cost: a 1M-triangle torus over a ground quad kept the
    // quad's 100 x 100 box on every level of half the tree.)
    void grow(const Bounds& b) {
        lo = {min_of(lo.x, b.lo.x), min_of(lo.y, b.lo.y), min_of(lo.z, b.lo.z)};
        hi = {max_of(hi.x, b.hi.x), max_of(hi.y, b.hi.y), max_of(hi.z, b.hi.z)};
    }
    // Half the surface area (the SAH only needs ratios).
    double half_area() const {
        if (empty()) return 0.0;
        const Vec3 e = hi - lo;
        return e.x * e.y + e.y * e.z + e.z * e.x;
    }
    bool empty() const { return lo.x > hi.x; }
};

// The float nearest to x on the side away from the box's interior (boxes are stored in float
// and must contain their double bounds; rays round their origin with these, FloatSlabRay in
// bvh4.hpp). Branch-free, without std::nextafter (a libm call): when the nearest float f lies on
// the wrong side of x, one step of f's bit pattern moves it by one float, up or down by its sign
// bit (so −0 steps down to −(the smallest subnormal), +0 up to +(it); ±inf steps to ±FLT_MAX;
// NaN compares false and stays NaN).
inline float round_down(double x) {
    float f = static_cast<float>(x);
    uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    const uint32_t step = double(f) > x ? 1u : 0u;
    bits += (bits >> 31) ? step : 0u - step;  // down: away from 0 when negative, toward it when positive
    std::memcpy(&f, &bits, sizeof f);
    return f;
}
inline float round_up(double x) {
    float f = static_cast<float>(x);
    uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    const uint32_t step = double(f) < x ? 1u : 0u;
    bits += (bits >> 31) ? 0u - step : step;
    std::memcpy(&f, &bits, sizeof f);
    return f;
}

// round_down and round_up of a point's three coordinates in SSE2 lanes (x, y, z, 0), the same
// operations lane by lane: cvtpd2ps rounds to nearest as the scalar conversion does (NaN stays
// NaN), the comparisons in double, then one step of the bit pattern: down by −1 − 2s where
// f > x, up by 1 + 2s where f < x, s = −1 for a negative f (its sign bit) and 0 else. (A use of
// only one of down() and up() leaves the other's work to the optimiser to drop.)
struct OutwardFloats {
    __m128i bits, above, below;  // the nearest floats; lanes where they lie above / below the double

    explicit OutwardFloats(const Vec3& v) {
        const __m128d xy = _mm_set_pd(v.y, v.x), z = _mm_set_sd(v.z);
        const __m128 f = _mm_movelh_ps(_mm_cvtpd_ps(xy), _mm_cvtpd_ps(z));  // fx, fy, fz, 0
        const __m128d f_xy = _mm_cvtps_pd(f), f_z = _mm_cvtps_pd(_mm_movehl_ps(f, f));
        // The 64-bit comparison masks narrowed to 32-bit lanes x, y, z, 0.
        auto narrow = [](__m128d m_xy, __m128d m_z) {
            return _mm_castps_si128(_mm_shuffle_ps(_mm_castpd_ps(m_xy), _mm_castpd_ps(m_z), _MM_SHUFFLE(2, 0, 2, 0)));
        };
        above = narrow(_mm_cmpgt_pd(f_xy, xy), _mm_cmpgt_pd(f_z, z));
        below = narrow(_mm_cmplt_pd(f_xy, xy), _mm_cmplt_pd(f_z, z));
        bits = _mm_castps_si128(f);
    }
    __m128 down() const {
        const __m128i twice_sign = _mm_add_epi32(_mm_srai_epi32(bits, 31), _mm_srai_epi32(bits, 31));
        const __m128i step = _mm_and_si128(_mm_sub_epi32(_mm_set1_epi32(-1), twice_sign), above);
        return _mm_castsi128_ps(_mm_add_epi32(bits, step));
    }
    __m128 up() const {
        const __m128i twice_sign = _mm_add_epi32(_mm_srai_epi32(bits, 31), _mm_srai_epi32(bits, 31));
        const __m128i step = _mm_and_si128(_mm_add_epi32(_mm_set1_epi32(1), twice_sign), below);
        return _mm_castsi128_ps(_mm_add_epi32(bits, step));
    }
};

// Traversal stack size: the build keeps the depth below 44 + log2(N) (bvh.cpp), i.e. < 76 for
// 4e9 primitives.
constexpr int kMaxTraversalDepth = 96;

struct BvhNode {
    float lo[3], hi[3];  // rounded outward from the double bounds
    int32_t offset;      // leaf: first primitive ref; interior: index of the second child
    int16_t count;       // leaf: number of primitives; interior: 0 (the first child follows)
    int16_t axis;        // interior: split axis, to visit the near child first
};

// A primitive as the build sees it: its bounds rounded outward to float (round_down /
// round_up of its double bounds, so every node's box is the same as if it were rounded from
// the union of double bounds: rounding outward is monotone) and its index. 32 bytes, so the
// build reads and partitions one sequential array rather than chasing indices into double
// bounds and centroids (76 bytes a primitive).
struct alignas(16) PrimRef {
    float lo[3];
    uint32_t id;
    float hi[3];
    uint32_t unused;

    PrimRef() = default;  // trivial, so that PrimRefs sizes without writing
    // round_down(b.lo), round_up(b.hi) in lanes (OutwardFloats): the scalar functions cost S2's
    // primitive pass ~110 instructions a triangle more.
    PrimRef(const Bounds& b, uint32_t index) {
        const __m128i keep_xyz = _mm_set_epi32(0, -1, -1, -1);
        _mm_store_si128(reinterpret_cast<__m128i*>(lo),
                        _mm_or_si128(_mm_and_si128(_mm_castps_si128(OutwardFloats(b.lo).down()), keep_xyz),
                                     _mm_set_epi32(int32_t(index), 0, 0, 0)));
        _mm_store_si128(reinterpret_cast<__m128i*>(hi), _mm_castps_si128(OutwardFloats(b.hi).up()));  // unused: 0
    }
};

// The build's input, sized without writing: the scene's parallel pass over its primitives
// writes every box, and faults the pages in on its threads (value-initialising 32 MiB took S2's
// build 2.1 ms on one thread first).
using PrimRefs = UninitialisedVector<PrimRef>;
static_assert(std::is_trivially_default_constructible_v<PrimRef>, "PrimRefs sizes without writing");

// The binary tree's nodes: 2n - 1 slots for n primitives, the ones a build uses written
// (subtrees built on other threads start at fixed slots: bvh.cpp), the rest never touched.
using BvhNodes = UninitialisedVector<BvhNode>;

// The most primitives one tree holds: its 2n - 1 node slots are numbered in int32.
constexpr size_t kMaxBvhPrimitives = size_t(1) << 30;

// The primitives (ids [begin, end)) whose leaves the walk tests eight to one AVX pass: the
// triangles, where the float prefilter runs (triangle_prefilter.hpp). A leaf of them alone costs
// about one pass whatever its size, which sets what such a leaf costs the SAH (bvh.cpp); a leaf
// holding any other primitive is tested a primitive at a time. Empty: every leaf is.
struct LaneIds {
    uint32_t begin = 0, end = 0;
};

struct Bvh {
    BvhNodes nodes;
    UninitialisedVector<uint32_t> order;  // leaf order: positions index the primitives' ids (sized unwritten)

    // Builds over the primitives (consumed: the build reorders them in place and frees them).
    // Centroids are the float boxes' centres.
    void build(PrimRefs prims, LaneIds lanes = {});
};

// Slab test against a node (or any box with float lo[3], hi[3]), in double precision with
// precomputed reciprocal direction. Each axis's near plane is the lower bound where the
// reciprocal's sign bit is clear, else the upper one (by the sign bit, so that a direction
// component −0, reciprocal −inf, counts as negative). NaN from 0·inf (origin on a slab plane,
// direction parallel to it) is ignored, which keeps the box (conservative): with the planes
// chosen by sign, every other 0-direction case gives ±inf of the right sign. (Choosing the near
// distance as the smaller of the two, as before, took +inf for a −0 component with the origin on
// the upper plane: such a ray missed the box and what was inside it.) t_far is widened by
// kSlabFarWidening so a rounding error in the box test never culls a hit that the exact
// primitive test would report, and so is the t_max it is capped by: a primitive hit at
// t_h < t_max has a computed entry distance up to t_h·(1 + γ(3)), which a cap of t_max itself
// could cut off (a shadow ray whose occluder lies within an ulp or two of its end; a flat box, as
// a plane of triangles has, enters where its triangles are hit). fl(t_max·(1 + 4ε)) >=
// t_max·(1 + 3.4ε) > t_max·(1 + γ(3)) keeps it.
//
// Branch-free (compare-and-select, which compiles to minsd/maxsd with the operand order that
// keeps these NaN rules): the early exit on an empty interval after each axis only decides
// sooner what the final t0 <= t1 decides, since t0 only grows and t1 only shrinks, and its
// mispredicted branches cost more than the arithmetic they skip.
// Each slab distance (bound − o)·inv takes three roundings of ≤ ε/2 (the subtraction, the
// reciprocal, the product), so it errs by γ(3) ≈ 1.5ε relative; Ize 2013 ("Robust BVH Ray
// Traversal") widens t_far by 1 + 2γ(3) ≈ 1 + 3ε to cover the errors of t_near and t_far
// together; ulps(4) is the smallest whole number of ε above 2γ(3) = 3ε / (1 − 1.5ε).
constexpr double kSlabFarWidening = 1.0 + ulps(4);

// The limit an any-hit query (a shadow ray) gives hit_node instead of its t_max: none. The cap
// t_max·kSlabFarWidening takes a primitive's computed distance for the exact one, and the
// watertight test's can fall short of it by far more than 4ε: by ~(triangle size / t)·ε, 2–14e-15
// relative for a ground quad 40 times the length of a shadow ray (tests/native/
// test_native_small_scene.py), so a shadow ray whose window ended one double past such a hit had
// the triangle's box culled and the hit missed. Uncapped, a box beyond the window is entered and
// its primitives' own tests, with the window, decide. (A closest-hit walk keeps its cap: it
// culls by the best hit so far, with ClosestSearch's margin.)
constexpr double kAnyHitBoxLimit = HUGE_VAL;

template <class Box>
inline bool hit_node(const Box& n, const Vec3& o, const Vec3& inv, double t_min, double t_max, double& t_entry) {
    double t0 = t_min, t1 = t_max * kSlabFarWidening;
    const double os[3] = {o.x, o.y, o.z}, is[3] = {inv.x, inv.y, inv.z};
    for (int k = 0; k < 3; ++k) {
        const bool negative = std::signbit(is[k]);
        const double near = (double(negative ? n.hi[k] : n.lo[k]) - os[k]) * is[k];
        const double far = (double(negative ? n.lo[k] : n.hi[k]) - os[k]) * is[k] * kSlabFarWidening;
        t0 = near > t0 ? near : t0;  // NaN ignored
        t1 = far < t1 ? far : t1;
    }
    t_entry = t0;
    return t0 <= t1;
}

}  // namespace phong
