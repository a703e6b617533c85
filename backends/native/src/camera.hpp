// SPDX-License-Identifier: Apache-2.0
// The camera: primary rays exactly as POV-Ray 3.7 builds them (its source, tracepixel.cpp:
// CreateCameraRay), from the model's Camera (position, forward, up, horizontal FOV or ortho
// width) set up like POV-Ray's `right -x*W/H up y angle HFOV` for a right-handed world.
#pragma once

#include <immintrin.h>

#include <algorithm>
#include <cmath>

#include "math.hpp"
#include "simd_dispatch.hpp"

namespace phong {

// The camera as the model describes it (phongscene.scene.Camera): the eye, a unit view
// direction and a unit up orthogonal to it, and the view's width as an angle (perspective) or a
// length (orthographic).
struct CameraDescription {
    Vec3 position, forward, up;
    bool orthographic;
    double horizontal_fov_deg;  // perspective only, full horizontal angle
    double ortho_width;         // orthographic only, world units
};

// The vectors of POV-Ray's camera, made from a description for an image of a given shape.
struct Camera {
    Vec3 position;
    Vec3 right;      // R: spans the image width (u in [-1/2, 1/2])
    Vec3 up;         // U: spans the image height
    Vec3 direction;  // D: from the eye to the image plane's centre
    bool orthographic = false;

    // right = forward x up (right-handed world).
    static Camera make(const CameraDescription& d, int width, int height) {
        const double aspect = double(width) / double(height);
        const Vec3 right = cross(d.forward, d.up);
        Camera c;
        c.position = d.position;
        c.orthographic = d.orthographic;
        if (d.orthographic) {
            // POV-Ray with explicit right/up and no angle: the view is exactly |R| x |U|.
            c.right = right * d.ortho_width;
            c.up = d.up * (d.ortho_width / aspect);
            c.direction = d.forward;
        } else {
            // POV-Ray: |D| = |R| / (2 tan(angle/2)) with |R| = W/H and |U| = 1.
            const double half_angle = d.horizontal_fov_deg * (kPi / 180.0) / 2.0;
            c.right = right * aspect;
            c.up = d.up;
            c.direction = d.forward * (aspect / (2.0 * std::tan(half_angle)));
        }
        return c;
    }

    // The ray through continuous image position (sx, sy): pixel (i, j) covers [i, i+1) x [j, j+1),
    // row 0 at the top; its centre is (i + 1/2, j + 1/2).
    Ray generate(double sx, double sy, int width, int height) const {
        const double u = sx / width - 0.5;
        const double v = 0.5 - sy / height;
        if (orthographic) return {position + right * u + up * v, normalize(direction)};
        return {position, normalize(direction + right * u + up * v)};
    }

    // generate()'s directions of `count` perspective rays, four at a time in AVX double
    // lanes with its IEEE operations in its order, so each is generate()'s to the bit: dirs[k]
    // through (sx[k], sy[k]). (Its five divisions and square root a ray were ~4 % of S1's
    // render as a scalar chain.) The AVX2 path only (simd_dispatch.hpp).
    PHONG_AVX2 void perspective_directions(const double* sx, const double* sy, int count, int width, int height,
                                           Vec3* dirs) const {
        constexpr int kChunk = 8;  // rays a pass: two groups of four lanes
        const __m256d w = _mm256_set1_pd(double(width)), h = _mm256_set1_pd(double(height));
        const __m256d half = _mm256_set1_pd(0.5);
        const double dxyz[3] = {direction.x, direction.y, direction.z}, rxyz[3] = {right.x, right.y, right.z},
                     uxyz[3] = {up.x, up.y, up.z};
        for (int at = 0; at < count; at += kChunk) {
            const int n = std::min(kChunk, count - at);
            alignas(32) double x[kChunk] = {}, y[kChunk] = {}, out[3][kChunk];
            for (int k = 0; k < n; ++k) x[k] = sx[at + k], y[k] = sy[at + k];
            for (int g = 0; g < n; g += 4) {
                const __m256d u = _mm256_sub_pd(_mm256_div_pd(_mm256_load_pd(x + g), w), half);
                const __m256d v = _mm256_sub_pd(half, _mm256_div_pd(_mm256_load_pd(y + g), h));
                __m256d a[3];
                for (int c = 0; c < 3; ++c)  // direction + right·u + up·v
                    a[c] =
                        _mm256_add_pd(_mm256_add_pd(_mm256_set1_pd(dxyz[c]), _mm256_mul_pd(_mm256_set1_pd(rxyz[c]), u)),
                                      _mm256_mul_pd(_mm256_set1_pd(uxyz[c]), v));
                const __m256d length = _mm256_sqrt_pd(_mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(a[0], a[0]), _mm256_mul_pd(a[1], a[1])), _mm256_mul_pd(a[2], a[2])));
                for (int c = 0; c < 3; ++c) _mm256_store_pd(out[c] + g, _mm256_div_pd(a[c], length));
            }
            for (int k = 0; k < n; ++k) dirs[at + k] = Vec3{out[0][k], out[1][k], out[2][k]};
        }
    }
};

}  // namespace phong
