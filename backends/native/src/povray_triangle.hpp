// SPDX-License-Identifier: Apache-2.0
// POV-Ray 3.7's mesh2 triangle test, reproduced for the POV-Ray numerics (diff).
//
// POV-Ray stores a mesh2's vertices as float32 in the mesh's own frame (the compiler writes
// local coordinates and a translate) and precomputes per triangle, in float64 from those
// vertices: the unit plane normal n = normalize((P3 − P1) × (P2 − P1)) and d = −n·P1, the
// dominant axis of n, and an order of P1, P2 that makes the projected triangle's winding
// positive. Only then are n and d stored, both as float32 (mesh.h: SNGL_VECT, SNGL). A ray (in mesh space, direction
// renormalised) hits at depth −(d + n·O)/(n·D) when |n·D| ≥ 1e-10 and depth ≥ 1e-6 (DEPTH_TOLERANCE) and ≤ 1e7, if the
// point, projected along the dominant axis, is on the inner side of all three edges. The rounded plane is slightly off
// the vertices' plane, so the depth, and with it the projected point, moves by up to ~1e-7 relative / cos: at grazing
// angles two triangles sharing an edge can both miss a ray near it, or both hit it (the test is not watertight).
// Blender's Suzanne lit one area-light sample through such a crack. The
// native watertight test (shapes.hpp) stays the default; this one replaces it for triangles
// when the scene is built in POV-Ray's numerics.
#pragma once

#include <cmath>

#include "math.hpp"
#include "shapes.hpp"
#include "triangle_store.hpp"

namespace phong {

// POV-Ray's EPSILON (parallel-ray cut), the mesh's DEPTH_TOLERANCE and MAX_DISTANCE.
constexpr double kPovrayParallelCosine = 1e-10;
constexpr double kPovrayMeshMinDepth = 1e-6;
constexpr double kPovrayMaxDistance = 1e7;

// x rounded to float32, as a double. Through a volatile: GCC 12.2 at -O2/-O3 vectorises
// `double(float(x))` of neighbouring fields into a packed double division with the two
// conversions dropped (seen here: the x and y of a normal kept unrounded, z rounded).
inline double round_to_float(double x) {
    volatile float f = float(x);
    return f;
}

// Held per triangle beside its corners, which the TriangleStore holds in the mesh's frame
// (LocalTriangle, 40 bytes): 20 bytes, the float32 values in floats, exactly, and read back as
// doubles. (In doubles, with its own corners and origin, it took 144; with float corners and a
// double origin 80, beside 72 of world corners.)
struct PovrayTriangle {
    float normal[3];  // float32-rounded unit plane normal
    float distance;   // float32-rounded −n·P1, with the unrounded normal
    int8_t a, b;      // the two axes other than the dominant one, in POV-Ray's order
    bool swapped;     // P1 and P2 exchanged (to map barycentrics back to v0, v1, v2)
    bool degenerate;  // zero normal: POV-Ray drops the triangle
};

static_assert(sizeof(PovrayTriangle) == 20, "PovrayTriangle's layout: 20 bytes a triangle");

// POV-Ray's P1, P2, P3 as doubles (exact: each is a float32 value): the mesh-space corners,
// P1 and P2 exchanged where POV-Ray swapped them.
inline void povray_corners(const PovrayTriangle& tri, const LocalTriangle& local, double (&P)[3][3]) {
    const int first = tri.swapped ? 1 : 0;
    for (int k = 0; k < 3; ++k) {
        P[0][k] = local.v[3 * first + k];
        P[1][k] = local.v[3 * (1 - first) + k];
        P[2][k] = local.v[6 + k];
    }
}

// One coordinate in its mesh's frame as POV-Ray holds it: x − o rounded to float32.
inline float mesh_coordinate(double x, double o) { return float(round_to_float(x - o)); }

// Whether a world point is its mesh-frame float plus the origin, double(float(x − o)) + o == x
// per coordinate (a NaN coordinate counts when it comes back NaN).
inline bool recovered_from_mesh_frame(const double* point, const Vec3& origin) {
    const double o[3] = {origin.x, origin.y, origin.z};
    for (int k = 0; k < 3; ++k) {
        const double back = double(mesh_coordinate(point[k], o[k])) + o[k];
        if (!(back == point[k] || (std::isnan(back) && std::isnan(point[k])))) return false;
    }
    return true;
}

// `world` in the frame of mesh number `mesh`, at `origin`: world holds float32 mesh-space
// vertices plus the origin (rounded to float64); subtracting the origin and rounding to float32
// recovers them exactly (the error is far below a float32 ulp).
inline LocalTriangle to_mesh_frame(const TriangleShape& world, const Vec3& origin, uint32_t mesh) {
    LocalTriangle t{};
    const Vec3* v[3] = {&world.v0, &world.v1, &world.v2};
    for (int i = 0; i < 3; ++i) {
        t.v[3 * i] = mesh_coordinate(v[i]->x, origin.x);
        t.v[3 * i + 1] = mesh_coordinate(v[i]->y, origin.y);
        t.v[3 * i + 2] = mesh_coordinate(v[i]->z, origin.z);
    }
    t.mesh = mesh;
    return t;
}

// POV-Ray's plane, dominant axis and P1/P2 order of the triangle with mesh-space corners `local`.
inline PovrayTriangle make_povray_triangle(const LocalTriangle& local) {
    PovrayTriangle t{};
    double P[3][3];
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) P[i][k] = local.v[3 * i + k];
    const Vec3 p1{P[0][0], P[0][1], P[0][2]}, p2{P[1][0], P[1][1], P[1][2]}, p3{P[2][0], P[2][1], P[2][2]};
    Vec3 n = cross(p3 - p1, p2 - p1);
    const double len = length(n);
    if (len == 0.0) {
        t.degenerate = true;
        return t;
    }
    n = n / len;
    t.distance = float(round_to_float(-dot(n, p1)));
    const double x = std::fabs(n.x), y = std::fabs(n.y), z = std::fabs(n.z);
    const int dominant = x > y ? (x > z ? 0 : 2) : (y > z ? 1 : 2);
    t.a = int8_t(dominant == 0 ? 1 : 0);
    t.b = int8_t(dominant == 2 ? 1 : 2);
    const int a = t.a, b = t.b;
    t.swapped = (P[1][a] - P[2][a]) * (P[1][b] - P[0][b]) < (P[1][b] - P[2][b]) * (P[1][a] - P[0][a]);
    t.normal[0] = float(round_to_float(n.x));
    t.normal[1] = float(round_to_float(n.y));
    t.normal[2] = float(round_to_float(n.z));
    return t;
}

// Whether the world ray hits in (t_min, t_max), as POV-Ray finds it, the triangle of plane `tri`
// and mesh-space corners `local` (its mesh at `origin`); barycentrics of v0, v1, v2.
inline bool intersect_povray_triangle(const PovrayTriangle& tri, const LocalTriangle& local, const Vec3& origin,
                                      const Ray& ray, double t_min, double t_max, double& t_hit, Barycentric& bary) {
    if (tri.degenerate) return false;
    // The ray in mesh space: translated, direction renormalised (POV-Ray's MInvTransRay).
    const double len = length(ray.dir);
    const double o[3] = {ray.origin.x - origin.x, ray.origin.y - origin.y, ray.origin.z - origin.z};
    const double d[3] = {ray.dir.x / len, ray.dir.y / len, ray.dir.z / len};
    const double n[3] = {tri.normal[0], tri.normal[1], tri.normal[2]};
    const double n_dot_d = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    if (std::fabs(n_dot_d) < kPovrayParallelCosine) return false;
    const double n_dot_o = n[0] * o[0] + n[1] * o[1] + n[2] * o[2];
    const double depth = -(double(tri.distance) + n_dot_o) / n_dot_d;
    if (depth < kPovrayMeshMinDepth || depth > kPovrayMaxDistance) return false;
    const int a = tri.a, b = tri.b;
    const double s = o[a] + depth * d[a], u = o[b] + depth * d[b];
    double P[3][3];
    povray_corners(tri, local, P);
    // Inner side of each edge P2→P1, P3→P2, P1→P3 (POV-Ray's order).
    for (int e = 0; e < 3; ++e) {
        const double* q = P[(e + 1) % 3];
        const double* r = P[e];
        if ((q[a] - s) * (q[b] - r[b]) < (q[b] - u) * (q[a] - r[a])) return false;
    }
    const double t = depth / len;
    if (!(t > t_min && t < t_max)) return false;
    // Barycentrics of the projected point (for smooth normals), in the caller's vertex order.
    const double* v0 = P[tri.swapped ? 1 : 0];
    const double* v1 = P[tri.swapped ? 0 : 1];
    const double* v2 = P[2];
    const double e1a = v1[a] - v0[a], e1b = v1[b] - v0[b], e2a = v2[a] - v0[a], e2b = v2[b] - v0[b];
    const double qa = s - v0[a], qb = u - v0[b];
    const double area = e1a * e2b - e1b * e2a;
    const double b1 = (qa * e2b - qb * e2a) / area, b2 = (e1a * qb - e1b * qa) / area;
    t_hit = t;
    bary = {1.0 - b1 - b2, b1, b2};
    return true;
}

// The (u, v) of a mesh2 hit as POV-Ray's Mesh::UVCoord computes it (issue 27.4): each corner's
// weight is 1 + (P − Pᵢ)·bᵢ/|bᵢ|², bᵢ the perpendicular from the opposite side's line to Pᵢ,
// in POV-Ray's vertex order (after its P1/P2 swap, which swaps the uvs with them), the sides
// differences of the float32 vertices taken in float32 (mesh.h stores them as SnglVector3d),
// P the hit in mesh space. Barycentrics of the same point differ from these weights by a few
// ulps, enough to move a lookup across a texel edge where the image jumps (issue 27: 1-19 of
// 25,600-409,600 pixels on public textured assets). `corner_uv` is (u, v) of v0, v1, v2.
inline void povray_mesh_uv(const PovrayTriangle& tri, const LocalTriangle& local, const Vec3& origin,
                           const Vec3& world_point, const double* corner_uv, double& u, double& v) {
    const double p[3] = {world_point.x - origin.x, world_point.y - origin.y, world_point.z - origin.z};
    double P[3][3];
    povray_corners(tri, local, P);
    // One weight: the vertex `at`, the side from `from` to `to` opposite it (POV-Ray's Side1), and
    // Side2 = to − at.
    auto weight = [&](int at, int from, int to) {
        double side1[3], side2[3], a[3];
        for (int k = 0; k < 3; ++k) {
            side1[k] = round_to_float(P[to][k] - P[from][k]);
            side2[k] = round_to_float(P[to][k] - P[at][k]);
            a[k] = p[k] - P[at][k];
        }
        const double s = (side2[0] * side1[0] + side2[1] * side1[1] + side2[2] * side1[2]) /
                         (side1[0] * side1[0] + side1[1] * side1[1] + side1[2] * side1[2]);
        double b[3];
        for (int k = 0; k < 3; ++k) b[k] = side1[k] * s - side2[k];
        return 1.0 + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    };
    const double w1 = weight(0, 1, 2), w2 = weight(1, 0, 2), w3 = weight(2, 0, 1);
    // POV-Ray's P1 is the caller's v1 when it swapped P1 and P2.
    const double* uv1 = corner_uv + (tri.swapped ? 2 : 0);
    const double* uv2 = corner_uv + (tri.swapped ? 0 : 2);
    const double* uv3 = corner_uv + 4;
    u = w1 * uv1[0] + w2 * uv2[0] + w3 * uv3[0];
    v = w1 * uv1[1] + w2 * uv2[1] + w3 * uv3[1];
}

}  // namespace phong
