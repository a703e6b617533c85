// SPDX-License-Identifier: Apache-2.0
// Tangent-space normal maps (UsdPreviewSurface `normal`, MaterialX `normalmap`): the texel is the
// shading normal in the frame (T, B, N) of the surface point, T and B along the directions of
// increasing u and v, N the interpolated normal. The tangents are the triangle's partial
// derivatives dP/du and dP/dv (constant over a triangle, as pbrt's triangles take them), made
// orthonormal to N by Gram-Schmidt; B is not N × T, so a mirrored uv layout keeps its handedness.
// Python validates the texels (finite); a degenerate uv layout leaves the normal as it is.
#pragma once

#include <cmath>

#include "math.hpp"
#include "textures.hpp"

namespace phong {

// A triangle's uv Jacobian determinant below this fraction of its terms' size is degenerate
// (the corners' uvs on a line, or equal): its tangents would be noise, so the map is not applied.
// 1e-9 is far above the cancellation error of the determinant's two products (~1e-16 relative).
constexpr double kDegenerateUvJacobian = 1e-9;

// dP/du and dP/dv of the triangle (p0, p1, p2) with corner uvs `uv` (u0 v0 u1 v1 u2 v2); false
// where the uvs do not span a triangle.
inline bool uv_tangents(const Vec3& p0, const Vec3& p1, const Vec3& p2, const double* uv, Vec3& dpdu, Vec3& dpdv) {
    const double du02 = uv[0] - uv[4], dv02 = uv[1] - uv[5];
    const double du12 = uv[2] - uv[4], dv12 = uv[3] - uv[5];
    const double det = du02 * dv12 - dv02 * du12;
    const double size = std::fabs(du02 * dv12) + std::fabs(dv02 * du12);
    if (!(std::fabs(det) > kDegenerateUvJacobian * size)) return false;  // also NaN
    const Vec3 dp02 = p0 - p2, dp12 = p1 - p2;
    dpdu = (dp02 * dv12 - dp12 * dv02) * (1.0 / det);
    dpdv = (dp12 * du02 - dp02 * du12) * (1.0 / det);
    return true;
}

// The unit normal `n` (facing out of the surface) perturbed by the tangent-space normal `t` of
// the map at the point, in the frame of the tangents `dpdu`, `dpdv`; `n` itself where the frame
// or the perturbed normal degenerates (a tangent along n, a zero texel).
inline Vec3 perturbed_normal(const Vec3& n, const Vec3& dpdu, const Vec3& dpdv, const RGB& t) {
    Vec3 tangent = dpdu - n * dot(n, dpdu);
    const double tangent_length = length(tangent);
    if (!(tangent_length > 0.0)) return n;
    tangent = tangent * (1.0 / tangent_length);
    Vec3 bitangent = dpdv - n * dot(n, dpdv) - tangent * dot(tangent, dpdv);
    const double bitangent_length = length(bitangent);
    if (!(bitangent_length > 0.0)) return n;
    bitangent = bitangent * (1.0 / bitangent_length);
    const Vec3 mapped = tangent * t.x + bitangent * t.y + n * t.z;
    const double mapped_length = length(mapped);
    if (!(mapped_length > 0.0) || !std::isfinite(mapped_length)) return n;
    return mapped * (1.0 / mapped_length);
}

}  // namespace phong
