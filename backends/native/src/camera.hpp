// SPDX-License-Identifier: Apache-2.0
// The camera: primary rays exactly as POV-Ray 3.7 builds them (its source, tracepixel.cpp:
// CreateCameraRay), from the model's Camera (position, forward, up, horizontal FOV or ortho
// width) set up like POV-Ray's `right -x*W/H up y angle HFOV` for a right-handed world.
#pragma once

#include <cmath>

#include "math.hpp"

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
};

}  // namespace phong
