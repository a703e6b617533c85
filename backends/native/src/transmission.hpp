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
// `cos_t` receives cos θt.
inline bool refract_direction(const Vec3& d, const Vec3& n, double eta, Vec3& t, double& cos_t) {
    const double cos_i = -dot(d, n);
    const double cos_t_squared = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta);
    if (cos_t_squared < 0.0) return false;
    cos_t = std::sqrt(cos_t_squared);
    t = d / eta - n * (cos_t - cos_i / eta);
    return true;
}

// The unpolarised Fresnel reflectance of a dielectric boundary (the mean of the s and p
// reflectances; Suffern ch. 28, POV-Ray's `fresnel on`, ref §18) for a ray meeting it at cos_i
// (> 0) into a medium η times denser, refracted at cos_t. 1 under total internal reflection.
inline double fresnel_reflectance(double cos_i, double cos_t, double eta) {
    const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

}  // namespace phong
