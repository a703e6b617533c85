// SPDX-License-Identifier: Apache-2.0
// The native "adaptive" anti-aliasing estimator: an error-driven quadtree over a lattice shared by
// a whole tile. Each pixel starts as one cell (its 4 corners); a cell of side s (pixels) whose
// corners spread by D (sum over channels of max - min, linear colour) is split into 4 while
// D * s^kAdaptiveSideExponent >= the threshold, down to 1/finest of a pixel; a leaf's value is
// the mean of its 4 corners, a pixel's the area-weighted mean of its leaves. Every lattice point
// (spacing 1/finest pixel) is traced at most once per tile, so the samples on a pixel's border
// and the corners of neighbouring cells serve both sides (POV-Ray's +AM2 traces them per pixel).
// At threshold 0 every cell is split: the trapezoid rule on the (finest + 1)^2 lattice.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "math.hpp"

namespace phong {

// The split rule weighs a cell's corner spread by its side s^p. A leaf of side s whose corners
// disagree by D is off by up to ~D/2 over its area s², and along an edge about 1/s such leaves
// err with random signs: the pixel's error from that edge is ~D·s²·sqrt(1/s) = D·s^1.5. Splitting
// where D·s^1.5 >= t spends rays where they reduce the RMS error most (p = 0 is +AM2's rule:
// the same D at every depth). Measured at 320x180, 2 threads, CPU s to RMS ~4e-4 on S1 (n 8):
// p = 0 0.054 s, p = 1 0.038 s, p = 1.5 0.052 s, p = 2 0.046 s; to ~1.4e-4 (n 16): p = 0 0.67 s,
// p = 1 0.206 s, p = 1.5 0.119 s, p = 2 0.175 s; on the mesh scene M p = 1.5 reached 4.2e-4 and
// 2.7e-4 at 0.40 / 0.46 s, p = 2 4.7e-4 / 3.9e-4 at 0.34 / 0.35 s (benchmarks/README.md).
constexpr double kAdaptiveSideExponent = 1.5;

// Renders the pixels [x0, x1) x [y0, y1) of one tile. `trace(sx, sy)` is the colour of the primary
// ray through image point (sx, sy) (pixels, row 0 at the top); `store(i, j, colour)` writes a pixel.
// The lattice lives per thread and is reused tile after tile (stamps, not clearing, say which
// points this tile traced).
template <class Trace, class Store>
void render_adaptive_tile(int x0, int y0, int x1, int y1, int finest, double threshold, Trace&& trace, Store&& store) {
    const int side = (std::max(x1 - x0, y1 - y0)) * finest + 1;
    thread_local std::vector<RGB> value;
    thread_local std::vector<uint32_t> stamp;
    thread_local uint32_t generation = 0;
    if (stamp.size() < size_t(side) * size_t(side)) {
        value.assign(size_t(side) * size_t(side), RGB());
        stamp.assign(size_t(side) * size_t(side), 0);
        generation = 0;
    }
    if (++generation == 0) {  // wrapped: no stamp may match a tile of the past
        std::fill(stamp.begin(), stamp.end(), 0);
        generation = 1;
    }
    const double inv_finest = 1.0 / finest;
    auto at = [&](int X, int Y) -> const RGB& {
        const size_t k = size_t(Y) * size_t(side) + size_t(X);
        if (stamp[k] != generation) {
            value[k] = trace(x0 + X * inv_finest, y0 + Y * inv_finest);
            stamp[k] = generation;
        }
        return value[k];
    };
    // weight[level]: (side of a cell at that depth, in pixels)^p, level 0 = the whole pixel.
    double weight[32];
    int levels = 0;
    for (int s = finest; s >= 1; s /= 2) weight[levels++] = std::pow(double(s) * inv_finest, kAdaptiveSideExponent);
    auto spread = [](const RGB& a, const RGB& b, const RGB& c, const RGB& d) {
        return (std::max({a.x, b.x, c.x, d.x}) - std::min({a.x, b.x, c.x, d.x})) +
               (std::max({a.y, b.y, c.y, d.y}) - std::min({a.y, b.y, c.y, d.y})) +
               (std::max({a.z, b.z, c.z, d.z}) - std::min({a.z, b.z, c.z, d.z}));
    };
    auto cell = [&](auto&& self, int X, int Y, int s, int level) -> RGB {
        const RGB &c00 = at(X, Y), &c10 = at(X + s, Y), &c01 = at(X, Y + s), &c11 = at(X + s, Y + s);
        if (s > 1 && spread(c00, c10, c01, c11) * weight[level] >= threshold) {
            const int h = s / 2;
            return (self(self, X, Y, h, level + 1) + self(self, X + h, Y, h, level + 1) +
                    self(self, X, Y + h, h, level + 1) + self(self, X + h, Y + h, h, level + 1)) *
                   0.25;
        }
        return (c00 + c10 + c01 + c11) * 0.25;
    };
    for (int j = y0; j < y1; ++j)
        for (int i = x0; i < x1; ++i) store(i, j, cell(cell, (i - x0) * finest, (j - y0) * finest, finest, 0));
}

}  // namespace phong
