// SPDX-License-Identifier: Apache-2.0
// The camera: primary rays exactly as POV-Ray 3.7 builds them (its source, tracepixel.cpp:
// CreateCameraRay), from the model's Camera (position, forward, up, horizontal FOV or ortho
// width) set up like POV-Ray's `right -x*W/H up y angle HFOV` for a right-handed world.
#pragma once

#include <cmath>

#include "math.hpp"

namespace phong {

struct Camera {
    Vec3 position;
    Vec3 right;      // R: spans the image width (u in [-1/2, 1/2])
    Vec3 up;         // U: spans the image height
    Vec3 direction;  // D: from the eye to the image plane's centre
    bool orthographic = false;

    // forward and up are unit and orthogonal; right = forward x up (right-handed world).
    static Camera make(const Vec3& position, const Vec3& forward, const Vec3& up, bool orthographic,
                       double horizontal_fov_deg, double ortho_width, int width, int height) {
        const double aspect = double(width) / double(height);
        const Vec3 right = cross(forward, up);
        Camera c;
        c.position = position;
        c.orthographic = orthographic;
        if (orthographic) {
            // POV-Ray with explicit right/up and no angle: the view is exactly |R| x |U|.
            c.right = right * ortho_width;
            c.up = up * (ortho_width / aspect);
            c.direction = forward;
        } else {
            // POV-Ray: |D| = |R| / (2 tan(angle/2)) with |R| = W/H and |U| = 1.
            const double half_angle = horizontal_fov_deg * (kPi / 180.0) / 2.0;
            c.right = right * aspect;
            c.up = up;
            c.direction = forward * (aspect / (2.0 * std::tan(half_angle)));
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
};

}  // namespace phong
