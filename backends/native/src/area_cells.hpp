// SPDX-License-Identifier: Apache-2.0
// The native "cells" shadow estimator of an area light: its samples x samples grid cut into
// (samples - 1)^2 cells. Every grid point is traced once (the cells' corners; with POV-Ray's
// `adaptive n` only those its recursion reaches, lights.hpp); a cell whose 4 corners agree (all visible or all
// shadowed) counts as wholly so, and only a cell whose corners disagree, where the shadow is partial, traces
// cell_samples^2 points of the (0,2)-sequence inside it, digitally shifted per shaded point and cell (each point
// uniform over the cell). The fraction is the mean over the cells. Bias: none on the cells whose corners disagree (each
// one's estimate is unbiased for its visible area); a cell whose corners agree but whose inside
// is not uniform (an occluder edge that enters and leaves between two corners, or a small
// occluder inside it) is missed, as by POV-Ray's `adaptive` regions; the study measures it.
#pragma once

#include <cstdint>
#include <cstring>
#include <vector>

#include "low_discrepancy.hpp"
#include "math.hpp"

namespace phong {

// A key of the shaded point (its coordinates' bits): the per-point digital shifts, the same for
// every thread count.
inline uint32_t point_key(const Vec3& p) {
    uint64_t bits[3];
    std::memcpy(&bits[0], &p.x, 8);
    std::memcpy(&bits[1], &p.y, 8);
    std::memcpy(&bits[2], &p.z, 8);
    uint32_t key = 0x2545F491u;
    for (uint64_t b : bits) key = hash32(key ^ uint32_t(b) ^ hash32(uint32_t(b >> 32)));
    return key;
}

// The visible fraction of grid cell [a, a + 1] x [b, b + 1] of an n x n grid from cell_samples^2
// points inside it. `visible(fu, fv)`: whether the light point at parameters (fu, fv) in [0, 1]^2
// is visible (grid column a sits at fu = a / (n - 1)).
template <class Visible>
double partial_cell_fraction(int a, int b, int n, int cell_samples, uint32_t key, Visible& visible) {
    const uint32_t shift_u = hash32(key ^ (uint32_t(a * n + b) * 0x9E3779B1u));
    const uint32_t shift_v = hash32(shift_u ^ 0xA511E9B3u);
    const int points = cell_samples * cell_samples;
    const double step = 1.0 / (n - 1);
    int seen = 0;
    for (int i = 0; i < points; ++i) {
        const double u = double(reverse_bits(uint32_t(i)) ^ shift_u) * kTwoToMinus32;
        const double v = double(sobol_second(uint32_t(i)) ^ shift_v) * kTwoToMinus32;
        seen += visible((a + u) * step, (b + v) * step) ? 1 : 0;
    }
    return double(seen) / points;
}

// Every grid point traced (the full grid), then the cells. `grid` caches the n x n grid points
// (-1: not traced yet).
template <class Visible>
double cells_fraction(int n, int cell_samples, uint32_t key, std::vector<signed char>& grid, Visible& visible) {
    auto corner = [&](int a, int b) -> int {
        signed char& g = grid[size_t(a) * size_t(n) + size_t(b)];
        if (g < 0) g = visible(double(a) / (n - 1), double(b) / (n - 1)) ? 1 : 0;
        return g;
    };
    double sum = 0.0;
    for (int a = 0; a + 1 < n; ++a)
        for (int b = 0; b + 1 < n; ++b) {
            const int lit = corner(a, b) + corner(a + 1, b) + corner(a, b + 1) + corner(a + 1, b + 1);
            sum += lit == 4 ? 1.0 : lit == 0 ? 0.0 : partial_cell_fraction(a, b, n, cell_samples, key, visible);
        }
    return sum / (double(n - 1) * double(n - 1));
}

}  // namespace phong
