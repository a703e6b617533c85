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

// x as the nearest half float (IEEE binary16 bits; ties to even), as numpy's astype(float16)
// rounds it, and POV-Ray holds a texel it reads from a half-float EXR. Beyond the largest half
// (65504, up to the midpoint 65520) it is infinite; NaN stays NaN (Python validates texels
// finite and within the half range).
inline uint16_t to_half(float x) {
    uint32_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    const uint16_t sign = uint16_t((bits >> 16) & 0x8000u);
    const uint32_t magnitude = bits & 0x7fffffffu;
    if (magnitude > 0x7f800000u) return uint16_t(sign | 0x7e00u);   // NaN
    if (magnitude >= 0x477ff000u) return uint16_t(sign | 0x7c00u);  // >= 65520 (and inf): inf
    if (magnitude < 0x38800000u) {
        // Below 2^-14, halves are the multiples of 2^-24: scaling by 2^24 is exact, and
        // nearbyint rounds to the nearest integer, ties to even (the default rounding mode).
        return uint16_t(sign | uint16_t(std::nearbyint(std::fabs(x) * 0x1p24f)));
    }
    // A normal half keeps 10 of float's 23 fraction bits: round away the low 13, ties to even
    // (a carry into the exponent is the right result), then rebias the exponent (127 -> 15).
    const uint32_t rounded = (magnitude + 0x0fffu + ((magnitude >> 13) & 1u)) & ~0x1fffu;
    return uint16_t(sign | ((rounded >> 13) - (112u << 10)));
}

// The float of half-float bits h: exact (every half is a float).
inline float from_half(uint16_t h) {
    const uint32_t sign = uint32_t(h & 0x8000u) << 16, magnitude = h & 0x7fffu;
    uint32_t bits;
    float f;
    if (magnitude >= 0x7c00u) {
        bits = sign | 0x7f800000u | ((magnitude & 0x3ffu) << 13);  // inf, NaN
        std::memcpy(&f, &bits, sizeof f);
        return f;
    }
    // The half's bits placed in a float's exponent and fraction, scaled by 2^(127 - 15): exact
    // for normal and subnormal halves alike.
    bits = magnitude << 13;
    std::memcpy(&f, &bits, sizeof f);
    f *= 0x1p112f;
    std::memcpy(&bits, &f, sizeof bits);
    bits |= sign;
    std::memcpy(&f, &bits, sizeof f);
    return f;
}

inline float round_to_half(float x) { return from_half(to_half(x)); }

struct Texture {
    int width = 0, height = 0;
    // (height, width, 3), row 0 at the top (v = 1), in one of two forms: `texels`, the caller's
    // float array, held by `owner` as long as the texture lives (not copied: a scene's textures
    // can be gigabytes, the chess set's 2048² maps among them); or `halves`, the texture's own
    // copy in half floats (POV-Ray's numerics: what it reads from a half-float EXR), in `owner`.
    const float* texels = nullptr;
    const uint16_t* halves = nullptr;
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
        const size_t k = 3 * (size_t(y) * size_t(width) + size_t(x));
        if (halves) return RGB{from_half(halves[k]), from_half(halves[k + 1]), from_half(halves[k + 2])};
        return RGB{texels[k], texels[k + 1], texels[k + 2]};
    }

    // The colour at texture coordinates (u, v).
    RGB lookup(double u, double v) const {
        assert(width > 0 && height > 0 && (texels != nullptr) != (halves != nullptr));
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
