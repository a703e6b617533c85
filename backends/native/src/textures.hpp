// SPDX-License-Identifier: Apache-2.0
// Image textures: the bilinear lookup of POV-Ray's `image_map { interpolate 2 }` on a
// `uv_mapping` mesh (docs/povray-3.7-semantics.md §16, measured): texel (i, j) (column i, row j
// from the top) is centred at u = (i + ½)/W, v = 1 − (j + ½)/H, and a point between four texel
// centres gets their bilinear blend. Outside the image, each axis wraps by its own rule (repeat,
// clamp to the edge texel, mirror, or black texels). Python validates textures (finite texels,
// sides >= 1); the asserts guard the invariants only.
#pragma once

#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "math.hpp"

namespace phong {

enum class Wrap { kRepeat, kClamp, kMirror, kBlack };

// Texel coordinates beyond this are not sampled (black): int64 holds them, and far below 2^53 a
// double still has a fraction. Only a degenerate uv (validated finite, but huge) reaches it.
constexpr double kMaxTexelCoordinate = 1e15;

// x rounded to the nearest half float (IEEE binary16, ties to even) and back: what numpy's
// astype(float16) keeps, and what POV-Ray holds of a texel it reads from a half-float EXR.
// Beyond the largest half (65504, up to the midpoint 65520) it is infinite; NaN and infinity
// stay as they are (Python validates texels finite).
inline float round_to_half(float x) {
    uint32_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    const uint32_t sign = bits & 0x80000000u, magnitude = bits & 0x7fffffffu;
    if (magnitude >= 0x7f800000u) return x;
    const float a = std::fabs(x);
    float r;
    if (a >= 65520.0f) {
        r = INFINITY;
    } else if (a < 0x1p-14f) {
        // Subnormal halves are multiples of 2^-24: scaling by 2^24 is exact, and nearbyint
        // rounds to the nearest integer, ties to even (the default rounding mode).
        r = std::nearbyint(a * 0x1p24f) * 0x1p-24f;
    } else {
        // A normal half keeps 10 of float's 23 fraction bits: round away the low 13, ties to
        // even (a carry into the exponent is the right result).
        uint32_t m = magnitude + 0x0fffu + ((magnitude >> 13) & 1u);
        m &= ~0x1fffu;
        std::memcpy(&r, &m, sizeof r);
    }
    uint32_t out;
    std::memcpy(&out, &r, sizeof out);
    out |= sign;
    std::memcpy(&r, &out, sizeof r);
    return r;
}

struct Texture {
    int width = 0, height = 0;
    // (height, width, 3), row 0 at the top (v = 1): the caller's array, held by `owner` as long
    // as the texture lives (not copied: a scene's textures can be gigabytes, the chess set's
    // 2048² maps among them), or the texture's own copy rounded to half floats.
    const float* texels = nullptr;
    std::shared_ptr<const void> owner;
    Wrap wrap_s = Wrap::kRepeat, wrap_t = Wrap::kRepeat;

    // The texel index `i` (any integer) maps to along an axis of n texels, or -1 for black.
    static int64_t wrap_index(int64_t i, int64_t n, Wrap wrap) {
        switch (wrap) {
            case Wrap::kRepeat: {
                const int64_t r = i % n;
                return r < 0 ? r + n : r;
            }
            case Wrap::kClamp:
                return i < 0 ? 0 : (i >= n ? n - 1 : i);
            case Wrap::kMirror: {
                // Period 2n: n texels forward, then the same n backward.
                int64_t r = i % (2 * n);
                if (r < 0) r += 2 * n;
                return r < n ? r : 2 * n - 1 - r;
            }
            case Wrap::kBlack:
                return (i < 0 || i >= n) ? -1 : i;
        }
        return -1;
    }

    RGB texel(int64_t i, int64_t j) const {
        const int64_t x = wrap_index(i, width, wrap_s), y = wrap_index(j, height, wrap_t);
        if (x < 0 || y < 0) return RGB{};
        const float* p = texels + 3 * (size_t(y) * size_t(width) + size_t(x));
        return RGB{p[0], p[1], p[2]};
    }

    // The colour at texture coordinates (u, v).
    RGB lookup(double u, double v) const {
        assert(width > 0 && height > 0 && texels != nullptr);
        // Continuous texel coordinates with texel centres at integers (rows count down from v = 1).
        const double x = u * width - 0.5, y = (1.0 - v) * height - 0.5;
        if (!(std::fabs(x) < kMaxTexelCoordinate && std::fabs(y) < kMaxTexelCoordinate)) return RGB{};
        const double fx0 = std::floor(x), fy0 = std::floor(y);
        const double fx = x - fx0, fy = y - fy0;
        const int64_t x0 = int64_t(fx0), y0 = int64_t(fy0);
        return (texel(x0, y0) * (1.0 - fx) + texel(x0 + 1, y0) * fx) * (1.0 - fy) +
               (texel(x0, y0 + 1) * (1.0 - fx) + texel(x0 + 1, y0 + 1) * fx) * fy;
    }
};

}  // namespace phong
