// SPDX-License-Identifier: Apache-2.0
// A conservative float prefilter for a BVH leaf's triangles on the AVX2 path: the sheared edge
// functions of the watertight test (shapes.hpp: intersect_triangle) for eight triangles at once
// in float, and a triangle rejected only where the double test certainly rejects it too, by
// its "signs differ" rule. The exact double test then runs on the few triangles left, so hits,
// and images, are bit for bit those of the double test alone (benchmarks/README.md, issue 25).
//
// The error bound. Notation: u = 2^-24 (float's unit roundoff), u_d = 2^-53 (double's); a
// vertex coordinate V is a float (the store is single precision: float_exact), |V| <= M, the
// scene's magnitude; the ray origin O is a double with |O_i| <= Om; E = M + Om >= |V − O|;
// sx, sy are WatertightRay's doubles, |sx|, |sy| <= 1 (z is the dominant axis: checked below).
// Let e = V − O and ax* = e_kx − sx·e_kz exactly (real numbers), likewise ay*.
// 1. The double test: a = fl(V − O) = e(1+θ), p = fl(sx·a_kz), ax = fl(a_kx − p), |θ| <= u_d:
//    |ax − ax*| <= u_d(2+u_d)|e_kx| + u_d(3+3u_d+u_d²)|e_kz| <= 5.01 u_d E.
// 2. The float test: O rounded to float (|O_f − O| <= u|O|), A = fl(V − O_f), sx rounded to
//    float (|sx_f − sx| <= u, |sx_f| <= 1), P = fl(sx_f·A_kz), AX = fl(A_kx − P):
//    |A − e| <= u(|e| + (1+u)|O|) =: α <= u(1+u)(E + Om), and
//    |AX − ax*| <= 2α + u(4+u)(E + α) <= 6.01 u E + 2.01 u Om.
//    So |AX − ax| <= δ := 6.02 u E + 2.01 u Om <= 8.03 u (M + Om); likewise |AY − ay|.
// 3. The edge function u = fl(fl(cx·by) − fl(cy·bx)) (v and w alike) against U, its float
//    counterpart from (AX, AY) etc. With S_j = |X_j| + |Y_j| the float sheared size of corner j
//    and S their maximum over the three corners (|cx| <= S + δ ...):
//    - float rounding of U:        u(2+u)·(|CX·BY| + |CY·BX|) <= u(2+u) S²  (+ 2·2^-150 underflow)
//    - coordinates off by <= δ:    |CX·BY − cx·by| <= δ(|CX| + |BY|) + δ², so 2δS + 2δ² for both
//    - double rounding of u:       u_d(2+u_d)(S + 2δ)²  (+ 2·2^-1075 underflow)
//    in all |U − u| <= 2.0001 u S² + 2.0001 δS + 2.0001 δ² + 2^-148.
// The margin is m = S·(kEdgeProductError·S + 2Δ) + 3Δ², Δ = kShearedError·(M + Om) >= δ, with
// room above that bound for its own float evaluation (five roundings, each by a factor
// (1 − u) at worst: 1 − 3e-7 in all) and for 2^-148 (Δ² >= 2^-102 where the prefilter applies).
// Then U < −m implies u < 0 and U > m implies u > 0: a lane with one edge function below −m and
// another above +m has signs that differ in the double test too, which rejects the triangle.
// Where the bound is not guaranteed the prefilter does not apply (TrianglePrefilter8::set_up):
// non-finite or huge numbers (products must not overflow: E <= kMaxPrefilterScale), tiny ones
// (Δ² must stay a normal float: E >= kMinPrefilterScale), double storage, POV-Ray numerics.
// Underflow: a rounding whose result is below float's normal range errs by <= 2^-150 absolutely
// rather than relatively (sx_f, O_f, the products); with E >= 2^-30 that is inside the slack of
// each coefficient above (subtractions with such results are exact). In that range every lane's
// numbers are finite (no NaN reaches the min/max of the edge functions).
#pragma once

#include <immintrin.h>

#include <cmath>
#include <cstdint>
#include <optional>

#include "bvh8.hpp"
#include "math.hpp"
#include "shapes.hpp"
#include "triangle_store.hpp"

namespace phong {

// Float's unit roundoff, 2^-24.
constexpr double kFloatUnitRoundoff = 0x1p-24;
// Δ per unit of M + Om: the bound above is 8.03 u; 9 u leaves > 10% for the rounding of Δ and
// of the margin itself.
constexpr double kShearedError = 9.0 * kFloatUnitRoundoff;
// The S² coefficient of the margin: the bound is 2.0001 u; 3 u leaves a third for the margin's
// rounding.
constexpr float kEdgeProductError = float(3.0 * kFloatUnitRoundoff);
// The prefilter's range of M + Om: below it Δ² could leave float's normal range (Δ >= 9u·2^-30 >
// 2^-51, so Δ² > 2^-102); above it S² could overflow (S <= 4.1 (M + Om) < 2^53, S² < 2^106).
constexpr double kMinPrefilterScale = 0x1p-30;
constexpr double kMaxPrefilterScale = 0x1p50;

// The smallest leaf worth the prefilter: its ~100 instructions a leaf cost about as much as
// three rejections by the double test. S2-100k's render under callgrind (benchmarks/README.md,
// issue 25), against 170.5M without the prefilter: from 1 triangle 169.3M, from 2 168.8M, from
// 3 165.5M, from 4 168.1M instructions.
constexpr int kMinPrefilterLeaf = 3;

// One ray's prefilter: the float sheared frame of its WatertightRay and its margin constants.
struct TrianglePrefilter8 {
    const float* lanes;    // the store's coordinate arrays: coordinates(0, 0)
    const size_t* offset;  // [3 * corner + (0: kx, 1: ky, 2: kz)]: where each array lies from `lanes`
    float origin[3];       // O rounded to float, in kx, ky, kz order
    float sx, sy;          // WatertightRay's shear rounded to float
    float twice_delta;     // 2Δ
    float delta_squared;   // 3Δ²

    // Sets up the prefilter for `ray`, or returns false where the bound above is not guaranteed
    // (the caller then tests every triangle in double).
    PHONG_AVX2 bool set_up(const TriangleStore& store, const Ray& ray, const WatertightRay& wr, double magnitude) {
        const double o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
        // Om as the sum |O_x| + |O_y| + |O_z| (a rounded sum of non-negative numbers is still >= each
        // term; NaN and inf carry through), and E = M + Om (its rounding by <= u_d is in Δ's slack).
        const double om = std::fabs(o[0]) + std::fabs(o[1]) + std::fabs(o[2]);
        const double scale = magnitude + om;  // NaN or inf fails the test below
        if (!(scale >= kMinPrefilterScale && scale <= kMaxPrefilterScale)) return false;
        if (!(std::fabs(wr.sx) <= 1.0 && std::fabs(wr.sy) <= 1.0)) return false;  // also NaN
        const int axis[3] = {wr.kx, wr.ky, wr.kz};
        lanes = store.coordinates(0, 0);
        offset = store.lane_offsets(wr.kx, wr.ky);
        for (int i = 0; i < 3; ++i) origin[i] = float(o[axis[i]]);
        sx = float(wr.sx);
        sy = float(wr.sy);
        const double delta = kShearedError * scale;
        twice_delta = float(2.0 * delta);
        delta_squared = float(3.0 * delta * delta);
        return true;
    }

    // The offsets V − O of the corners of the triangles at slot, slot + 1, ... slot + 7, along
    // the frame's axes kx, ky, kz: what every ray leaving this origin with these axes shares.
    struct CornerOffsets {
        __m256 x[3], y[3], z[3];  // corner c's along kx, ky, kz
    };
    PHONG_AVX2 CornerOffsets offsets(size_t slot) const {
        const __m256 ox = _mm256_set1_ps(origin[0]), oy = _mm256_set1_ps(origin[1]), oz = _mm256_set1_ps(origin[2]);
        CornerOffsets a;
        const float* at = lanes + slot;
        for (int c = 0; c < 3; ++c) {
            a.x[c] = _mm256_sub_ps(_mm256_loadu_ps(at + offset[3 * c]), ox);
            a.y[c] = _mm256_sub_ps(_mm256_loadu_ps(at + offset[3 * c + 1]), oy);
            a.z[c] = _mm256_sub_ps(_mm256_loadu_ps(at + offset[3 * c + 2]), oz);
        }
        return a;
    }

    // Bit j set where the triangle at slot + j (j < count <= 8) may pass the double test's sign
    // rule; clear where that test certainly rejects it.
    PHONG_AVX2 unsigned candidates(size_t slot, int count) const { return kept(offsets(slot), sx, sy, count); }

    // candidates() from the corners' offsets, for a ray of shear (shear_x, shear_y) (its own
    // WatertightRay's, rounded to float) leaving this origin with these axes.
    PHONG_AVX2 unsigned kept(const CornerOffsets& a, float shear_x_f, float shear_y_f, int count) const {
        const __m256 sign = _mm256_set1_ps(-0.0f);
        const __m256 shear_x = _mm256_set1_ps(shear_x_f), shear_y = _mm256_set1_ps(shear_y_f);
        __m256 x[3], y[3], size[3];
        for (int c = 0; c < 3; ++c) {
            x[c] = _mm256_sub_ps(a.x[c], _mm256_mul_ps(shear_x, a.z[c]));
            y[c] = _mm256_sub_ps(a.y[c], _mm256_mul_ps(shear_y, a.z[c]));
            size[c] = _mm256_add_ps(_mm256_andnot_ps(sign, x[c]), _mm256_andnot_ps(sign, y[c]));
        }
        // The edge functions as intersect_triangle forms them.
        const __m256 u = _mm256_sub_ps(_mm256_mul_ps(x[2], y[1]), _mm256_mul_ps(y[2], x[1]));
        const __m256 v = _mm256_sub_ps(_mm256_mul_ps(x[0], y[2]), _mm256_mul_ps(y[0], x[2]));
        const __m256 w = _mm256_sub_ps(_mm256_mul_ps(x[1], y[0]), _mm256_mul_ps(y[1], x[0]));
        const __m256 s = _mm256_max_ps(size[0], _mm256_max_ps(size[1], size[2]));
        const __m256 m = _mm256_add_ps(
            _mm256_mul_ps(
                s, _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(kEdgeProductError), s), _mm256_set1_ps(twice_delta))),
            _mm256_set1_ps(delta_squared));
        // Some edge function below −m and another above +m: the lowest below −m, the highest above +m.
        const __m256 lowest = _mm256_min_ps(u, _mm256_min_ps(v, w)), highest = _mm256_max_ps(u, _mm256_max_ps(v, w));
        const __m256 below = _mm256_cmp_ps(lowest, _mm256_xor_ps(m, sign), _CMP_LT_OQ);
        const __m256 above = _mm256_cmp_ps(highest, m, _CMP_GT_OQ);
        const unsigned rejected = unsigned(_mm256_movemask_ps(_mm256_and_ps(below, above)));
        return ~rejected & ((1u << count) - 1u);
    }
};

// The candidates of one ray's leaves by leaf position (bit k: refs[k] must be tested): the
// prefilter's, set up at the ray's first leaf it takes; every bit for a leaf of fewer than
// kMinPrefilterLeaf triangles or with other primitives, and for a ray outside the bound's range.
// (Scene::prefilter_applies says where it is used at all: the AVX2 walk over float corners.)
class TriangleLeafFilter {
  public:
    // `mixed`: other primitives than triangles are among the tree's leaves (else every leaf is
    // one run of triangle slots, and its refs need no look).
    TriangleLeafFilter(const TriangleStore& store, double magnitude, bool mixed)
        : store_(store), magnitude_(magnitude), mixed_(mixed) {}

    // The leaf of `count` refs at `refs`, leaf position `first` (where, in a scene of triangles
    // alone, each ref is its position: Scene::leaf_ref, and refs is not read).
    PHONG_AVX2 unsigned operator()(const int32_t* refs, int32_t first, int count, const Ray& ray,
                                   std::optional<WatertightRay>& wr) {
        const unsigned all = (1u << count) - 1u;
        // Triangle slots ascend by one through a leaf (scene.cpp): a leaf of triangles only is
        // one run of slots, the 8-lane loads' layout.
        if (state_ == kOff || count < kMinPrefilterLeaf ||
            (mixed_ && (refs[0] < 0 || refs[count - 1] - refs[0] != count - 1)))
            return all;
        if (state_ == kUnset) {
            if (!wr) wr.emplace(ray.dir);
            state_ = prefilter_.set_up(store_, ray, *wr, magnitude_) ? kOn : kOff;
            if (state_ == kOff) return all;
        }
        return prefilter_.candidates(size_t(mixed_ ? refs[0] : first), count);
    }

  private:
    TrianglePrefilter8 prefilter_;
    const TriangleStore& store_;
    double magnitude_;
    bool mixed_;
    enum { kUnset, kOn, kOff } state_ = kUnset;
};

}  // namespace phong
