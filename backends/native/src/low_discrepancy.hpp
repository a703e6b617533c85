// SPDX-License-Identifier: Apache-2.0
// The 2-D Sobol' sequence, a (0,2)-sequence in base 2 (its first 4^k points put one point in every
// elementary interval of area 4^-k: every 2^a x 2^b cell grid with a + b = 2k), and the hash that
// shifts it digitally per pixel or per light cell (a digital shift keeps that stratification and
// makes each point uniform over the square; it decorrelates neighbouring patterns). Used by the
// native stratified pixel estimator (render.cpp) and the area lights' cells (area_cells.hpp).
#pragma once

#include <cstdint>

namespace phong {

// Sobol's first dimension: the bits of i reversed (van der Corput in base 2).
inline uint32_t reverse_bits(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}
// Sobol's second dimension: direction numbers v_1 = 2^31, v_k = v_(k-1) ^ (v_(k-1) >> 1).
inline uint32_t sobol_second(uint32_t i) {
    uint32_t y = 0;
    for (uint32_t v = 1u << 31; i != 0; i >>= 1, v ^= v >> 1)
        if (i & 1u) y ^= v;
    return y;
}
// A 32-bit integer hash (Wellons' lowbias32): the digital shifts.
inline uint32_t hash32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}
constexpr double kTwoToMinus32 = 1.0 / 4294967296.0;

}  // namespace phong
