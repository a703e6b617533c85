// SPDX-License-Identifier: Apache-2.0
// The Phong material and shade_phong(): the one shading equation, in the symbols of the seed
// (Suffern, lecture 10), in both specular conventions (README.md, "The shading model and the two
// POV-Ray mappings", states them for users).
//
//   L = ka·cd·La + Σ_j light_j                                     (ambient_term + shade_phong)
//   seed:            light_j = [kd·cd/π + ks·cs·max(0, r_j·wo)^e] · Lj · (n·l_j)
//   povray-classic:  light_j = kd·cd/π·(n·l_j)·Lj + ks·(r·l_j)^e·Lj   (r·l_j > 0)
//
// r_j = 2(n·l_j)n − l_j for the seed; POV-Ray reflects the view instead, r = d − 2(d·n)n with
// d = −wo, and dots it with l (the same number in exact arithmetic; computed POV's way here so
// the classic convention follows POV-Ray's rounding). Both are evaluated only where
// n·l_j >= kMinCosineToLight and the light is not (fully) shadowed; n faces the viewer.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "math.hpp"

namespace phong {

struct Material {
    double ka, kd, ks, exponent;
    RGB diffuse_color;              // cd
    RGB specular_color;             // cs
    int32_t diffuse_texture = -1;   // index into Scene::textures replacing cd, or -1
    int32_t specular_texture = -1;  // ... replacing cs, or -1
    int32_t normal_texture = -1;    // ... a tangent-space normal map perturbing n (normal_maps.hpp), or -1
    // A cut-out mask (UsdPreviewSurface's masked mode): where this texture's first channel is
    // below opacity_threshold the surface is not there (render.cpp: cut_out), or -1.
    int32_t opacity_texture = -1;
    double opacity_threshold = 0.0;
    bool textured() const {
        return diffuse_texture >= 0 || specular_texture >= 0 || normal_texture >= 0 || opacity_texture >= 0;
    }
    int32_t last_texture() const {
        return std::max(std::max(diffuse_texture, specular_texture), std::max(normal_texture, opacity_texture));
    }
    RGB emission{};  // Le, added where the surface is seen (0: none; x + 0 is exact)
    // Mirror reflection (Suffern ch. 24, PerfectSpecular): kr·cr times the radiance traced along
    // the mirror direction is added to the Phong terms (render.cpp); kr = 0 traces no ray.
    double kr = 0.0;
    RGB reflective_color{1.0, 1.0, 1.0};  // cr
    // Transparency (Suffern ch. 27, transmission.hpp): kt times the radiance along the refracted
    // direction, into an interior of index `ior` (relative to the outside); kt = 0 traces no ray.
    double kt = 0.0;
    double ior = 1.0;
    // The dielectric (Suffern ch. 28): the mirror weight kr·cr becomes F·kr·cr and kt becomes
    // (1 − F)·kt, F the Fresnel reflectance of the crossing (transmission.hpp).
    bool fresnel = false;
    // Beer-Lambert (Suffern ch. 28's cf_in): the fraction of each channel a ray keeps per unit
    // distance inside the interior, (0, 1]; white filters nothing.
    RGB interior_filter{1.0, 1.0, 1.0};
    // The book's Checker3D (checker_colour below): cells of size checker_size > 0 alternate
    // diffuse_color and checker_color; 0: no checker.
    double checker_size = 0.0;
    RGB checker_color{0.5, 0.5, 0.5};
    // The book's PlaneChecker instead (plane_checker_colour below): x–z cells and an outline.
    bool checker_plane = false;
    double checker_outline_width = 0.0;
    RGB checker_outline_color{0.0, 0.0, 0.0};
    // cd is the instance's colour on an instance's hit (InstanceLayer::color_of; phongscene's
    // PhongMaterial.instance_color), diffuse_color elsewhere.
    bool instance_color = false;

    bool filters() const { return interior_filter.x != 1.0 || interior_filter.y != 1.0 || interior_filter.z != 1.0; }
};

// The book's Checker3D shift ε (phongscene.scene.CHECKER_SHIFT, which says why): added to every
// coordinate before the floor.
constexpr double kCheckerShift = -0.000187453738;

// cd of a checkered material at world-space point p (Suffern's Checker3D::get_color): diffuse_color
// where floor((x + ε)/s) + floor((y + ε)/s) + floor((z + ε)/s) is even, checker_color where odd.
// The sum is a 32-bit integer, as POV-Ray's checker pattern casts it (pattern.cpp), and a sum out
// of its range is INT_MIN (even), as that cast gives on x86: cells beyond 2^31 sizes from the
// origin (a ground plane's far horizon) alternate no more, in both backends alike.
inline RGB checker_colour(const Material& m, const Vec3& p) {
    const double s = m.checker_size;
    const double sum = std::floor((p.x + kCheckerShift) / s) + std::floor((p.y + kCheckerShift) / s) +
                       std::floor((p.z + kCheckerShift) / s);
    const int32_t cells = std::fabs(sum) < 2147483648.0 ? int32_t(sum) : INT32_MIN;
    return (cells & 1) != 0 ? m.checker_color : m.diffuse_color;
}

// cd of a PlaneChecker material at world-space point p (Suffern's PlaneChecker::get_color):
// checker_outline_color where x/s − floor(x/s) or z/s − floor(z/s) is below w or above 1 − w,
// w = ½·outline/s; else diffuse_color where floor(x/s) + floor(z/s) is even, checker_color where
// odd. `book_float`: the book's arithmetic, x, z, x/s, the fractions and w in float (its code
// stores them as float; its 1 − w is a double); otherwise double throughout, as POV-Ray's
// function pigment computes it. The parity is that of the floors' sum (the book's int cast is
// undefined beyond 2^31 cells; the true parity is taken there).
inline RGB plane_checker_colour(const Material& m, const Vec3& p, bool book_float) {
    double qx, qz, fx, fz, w;
    if (book_float) {
        const float s = float(m.checker_size);
        const float x = float(p.x), z = float(p.z);
        const float ix = std::floor(x / s), iz = std::floor(z / s);
        qx = ix;
        qz = iz;
        fx = float(x / s - ix);
        fz = float(z / s - iz);
        w = float(0.5 * double(float(m.checker_outline_width)) / s);
    } else {
        const double s = m.checker_size;
        qx = std::floor(p.x / s);
        qz = std::floor(p.z / s);
        fx = p.x / s - qx;
        fz = p.z / s - qz;
        w = 0.5 * m.checker_outline_width / s;
    }
    if (fx < w || fx > 1.0 - w || fz < w || fz > 1.0 - w) return m.checker_outline_color;
    return std::fmod(qx + qz, 2.0) != 0.0 ? m.checker_color : m.diffuse_color;
}

// What a ray keeps of its radiance over `distance` inside `medium` (nullptr: outside every
// interior): interior_filter^distance per channel.
inline RGB medium_transmittance(const Material* medium, double distance) {
    if (medium == nullptr || !medium->filters()) return RGB{1.0, 1.0, 1.0};
    const RGB& f = medium->interior_filter;
    return {std::pow(f.x, distance), std::pow(f.y, distance), std::pow(f.z, distance)};
}

enum class SpecularConvention { kSeed, kPovrayClassic };

inline RGB ambient_term(const Material& m, const RGB& ambient_light) {
    return hadamard(m.diffuse_color, ambient_light) * m.ka;
}

// The contribution of one light of (shadow-attenuated) colour `light` arriving from unit
// direction l, at a point with viewer-facing unit normal n seen from unit direction wo; the
// light's diffuse and specular terms scaled by its multipliers (x · 1 is exact: with both 1
// the result is bit for bit the seed's).
inline RGB shade_phong(const Material& m, SpecularConvention convention, const Vec3& n, const Vec3& wo, const Vec3& l,
                       double n_dot_l, const RGB& light, double diffuse_scale = 1.0, double specular_scale = 1.0) {
    const RGB diffuse = m.diffuse_color * (m.kd / kPi) * diffuse_scale;
    if (convention == SpecularConvention::kSeed) {
        const Vec3 r = n * (2.0 * n_dot_l) - l;
        const double r_dot_wo = dot(r, wo);
        // GlossySpecular: zero when r·wo <= 0, also for e = 0.
        const RGB specular =
            r_dot_wo > 0.0 ? m.specular_color * (m.ks * std::pow(r_dot_wo, m.exponent)) * specular_scale : RGB{};
        return hadamard(diffuse + specular, light) * n_dot_l;
    }
    RGB out = hadamard(diffuse, light) * n_dot_l;
    const Vec3 d = -wo;
    const Vec3 r = d - n * (2.0 * dot(d, n));
    const double r_dot_l = dot(r, l);
    if (m.ks > 0.0 && r_dot_l > 0.0) {
        const bool cut = m.exponent >= kClassicPhongCutoffExponent && r_dot_l <= kClassicPhongCutoffCosine;
        if (!cut) out += light * (m.ks * std::pow(r_dot_l, m.exponent) * specular_scale);
    }
    return out;
}

// The mirror direction of a ray of unit direction d at a surface of unit normal n (either side):
// d − 2(d·n)n, unit by construction (up to rounding), as POV-Ray reflects it.
inline Vec3 mirror_direction(const Vec3& d, const Vec3& n) { return d - n * (2.0 * dot(d, n)); }

}  // namespace phong
