// SPDX-License-Identifier: Apache-2.0
// The environment at infinity (a textured UsdLux DomeLight): the radiance a ray that hits nothing
// sees along its direction, looked up in a lat-long map in the OpenEXR layout UsdLux specifies
// (longitude 0 along +Z, +π/2 along +X, the top row +Y; phongscene/scene.py: Environment).
// POV-Ray numerics reproduce POV-Ray 3.7's `sky_sphere { pigment { image_map { map_type 1
// interpolate 2 } } }` (docs/povray-3.7-semantics.md §19, measured), which differs only within
// half a texel of the poles, where POV-Ray's lookup repeats the image vertically (the top row
// blends with the bottom one) while the default clamps to the pole row.
#pragma once

#include <cassert>
#include <cmath>
#include <cstdint>

#include "math.hpp"
#include "textures.hpp"

namespace phong {

struct Environment {
    // Width 0: no environment (the background colour). Wraps: repeat along u, clamp along v.
    Texture texture;
    RGB scale{1.0, 1.0, 1.0};
    // Row-major 3x3: the dome's frame from world space (orthogonal; Python validates it).
    double dome_from_world[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

    bool present() const { return texture.width > 0; }

    Vec3 to_dome(const Vec3& d) const {
        const double* m = dome_from_world;
        return {m[0] * d.x + m[1] * d.y + m[2] * d.z, m[3] * d.x + m[4] * d.y + m[5] * d.z,
                m[6] * d.x + m[7] * d.y + m[8] * d.z};
    }

    // The radiance along world direction `dir` (any length > 0).
    RGB lookup(const Vec3& dir, bool povray) const {
        assert(present());
        const Vec3 d = to_dome(dir);
        return hadamard(povray ? povray_texel(d) : latlong_texel(d), scale);
    }

    // The bilinear lookup at u = ½ − atan2(x, z)/2π, v = ½ + asin(y)/π, the image repeating
    // around the longitude and clamped at the poles (Texture::lookup's texel centres).
    RGB latlong_texel(const Vec3& d) const {
        const Vec3 n = normalize(d);
        const double u = 0.5 - std::atan2(n.x, n.z) / (2.0 * kPi);
        // |n.y| can round past 1 by an ulp: asin would be NaN there.
        const double v = 0.5 + std::asin(std::fmax(-1.0, std::fmin(1.0, n.y))) / kPi;
        assert(texture.wrap_s == Wrap::kRepeat && texture.wrap_t == Wrap::kClamp);
        return texture.lookup(u, v);
    }

    // POV-Ray's spherical image map (imageutil.cpp: spherical_image_map, map_pos, Interp with
    // bilinear factors) on the direction the compiler's sky_sphere matrix maps d_dome to,
    // (−z, y, x): there POV-Ray's u, its longitude from +X towards +Z over 2π, is the lat-long
    // map's u (UsdLux's column 0, along −Z, lands on POV-Ray's, along +X).
    RGB povray_texel(const Vec3& d_dome) const {
        Vec3 p{-d_dome.z, d_dome.y, d_dome.x};
        p = p / length(p);
        const double phi = 0.5 + std::asin(p.y) / kPi;
        const double ring = std::sqrt(p.x * p.x + p.z * p.z);
        double theta = 0.0;  // at a pole any longitude does
        if (ring != 0.0) {
            if (p.z == 0.0) {
                theta = p.x > 0 ? 0.0 : kPi;
            } else {
                theta = std::acos(p.x / ring);
                if (p.z < 0.0) theta = 2.0 * kPi - theta;
            }
            theta /= 2.0 * kPi;
        }
        const double width = texture.width, height = texture.height;
        // map_pos: POV-Ray's EPSILON nudge, then both axes wrapped (y counts rows from the top).
        const double x = povray_wrap(theta * width + kPovrayImageEpsilon, width);
        const double y = povray_wrap(-(phi * height + kPovrayImageEpsilon), height);
        // Interp: the four texels around (x, y) + ½, bilinear in its fractions; every index wraps.
        const double xs = x + 0.5, ys = y + 0.5;
        const int64_t ix = int64_t(xs), iy = int64_t(ys);
        const double p_ = xs - double(ix), q = ys - double(iy);
        // Indices wrapped here (repeat on both axes), so the texture's own wraps do not enter.
        const int64_t w = texture.width, h = texture.height;
        const int64_t x1 = Texture::wrap_index(ix, w, Wrap::kRepeat),
                      x0 = Texture::wrap_index(ix - 1, w, Wrap::kRepeat);
        const int64_t y1 = Texture::wrap_index(iy, h, Wrap::kRepeat),
                      y0 = Texture::wrap_index(iy - 1, h, Wrap::kRepeat);
        return texture.texel(x1, y1) * (p_ * q) + texture.texel(x0, y1) * ((1 - p_) * q) +
               texture.texel(x1, y0) * (p_ * (1 - q)) + texture.texel(x0, y0) * ((1 - p_) * (1 - q));
    }

    // POV-Ray's EPSILON (configbackend.h), added to both image coordinates in map_pos.
    static constexpr double kPovrayImageEpsilon = 1e-10;

    // POV-Ray's wrap() (base/types.h): fmod into [0, limit), limit itself wrapping to 0.
    static double povray_wrap(double value, double limit) {
        double r = std::fmod(value, limit);
        if (r < 0.0) r += limit;
        if (r >= limit) r = 0.0;
        return r;
    }
};

}  // namespace phong
