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
#include <vector>

#include "math.hpp"

namespace phong {

enum class Wrap { kRepeat, kClamp, kMirror, kBlack };

// Texel coordinates beyond this are not sampled (black): int64 holds them, and far below 2^53 a
// double still has a fraction. Only a degenerate uv (validated finite, but huge) reaches it.
constexpr double kMaxTexelCoordinate = 1e15;

struct Texture {
    int width = 0, height = 0;
    std::vector<float> texels;  // (height, width, 3), row 0 at the top (v = 1)
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
        const float* p = texels.data() + 3 * (size_t(y) * size_t(width) + size_t(x));
        return RGB{p[0], p[1], p[2]};
    }

    // The colour at texture coordinates (u, v).
    RGB lookup(double u, double v) const {
        assert(width > 0 && height > 0 && texels.size() == size_t(width) * size_t(height) * 3);
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
