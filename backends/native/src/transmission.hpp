// SPDX-License-Identifier: Apache-2.0
// Transparency (Suffern ch. 27, PerfectTransmitter): the refracted direction by Snell's law, total
// internal reflection, and the two conventions for the radiance a refracted ray carries.
//
//   book:   L += kt/η² · L(p, t)   (η = the index ratio across the surface in the ray's direction:
//                                  ior entering, 1/ior leaving; radiance scales with 1/η²)
//   povray: L += kt · L(p, t)      (POV-Ray applies no η² factor, ref §18)
//
// Under total internal reflection both add the mirror ray's radiance at full weight and no kr
// term (the book's Transparent::shade; POV-Ray measured the same, ref §18).
#pragma once

#include <cmath>

#include "math.hpp"

namespace phong {

enum class TransmissionConvention { kBook, kPovray };

// The refracted unit direction of a ray of unit direction d through a surface whose unit normal n
// faces the ray's side (n·d < 0), from a medium into one whose index is η times larger. Returns
// false under total internal reflection (sin θt > 1).
inline bool refract_direction(const Vec3& d, const Vec3& n, double eta, Vec3& t) {
    const double cos_i = -dot(d, n);
    const double cos_t_squared = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta);
    if (cos_t_squared < 0.0) return false;
    t = d / eta - n * (std::sqrt(cos_t_squared) - cos_i / eta);
    return true;
}

}  // namespace phong
