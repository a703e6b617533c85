// SPDX-License-Identifier: Apache-2.0
// One ray's search for its closest hit, primitive by primitive, as Scene::closest_hit runs it on
// its own walk and Scene::closest_hit_packet (ray_packets.cpp) on a packet's: the same state
// and the same tests either way, so a ray's hit does not depend on which walk reached its leaves.
#pragma once

#include <cmath>
#include <optional>

#include "scene.hpp"

namespace phong {

// Exact ties (coincident surfaces hit at the same t) go to the lower primitive id, so the hit
// does not depend on the BVH's shape or visiting order: once a hit is found, primitives are
// tested up to and including t_best, and boxes up to a little beyond it: a box's entry distance
// in the double test errs by < 2ε relative (three roundings of ≤ ε/2, as in hit_node), and
// kTieCullMargin = 8ε keeps a 4x margin over it, like kSelfHitError (the float test widens its
// limit further by itself: FloatSlabRay).
struct Scene::ClosestSearch {
    static constexpr double kTieCullMargin = ulps(8);

    const Scene* scene;
    const Ray* ray;
    Hit* hit;
    double t_min;
    std::optional<WatertightRay> wr;  // set up when the first triangle is tested
    bool found = false;
    double t_best, t_test;
    double t_cull;  // the walk's limit for boxes: t_best and the margin above

    ClosestSearch(const Scene& scene_, const Ray& ray_, double t_min_, double t_max, Hit& hit_)
        : scene(&scene_), ray(&ray_), hit(&hit_), t_min(t_min_), t_best(t_max), t_test(t_max), t_cull(t_max) {}

    // Tests primitive `ref`; a closer hit (or an exact tie with a lower id) replaces the best.
    __attribute__((always_inline)) void test(int32_t ref) {
        double t;
        Barycentric bary{};
        bool hit_here;
        if (ref >= 0) {
            hit_here = scene->hit_triangle(ref, *ray, wr, t_min, t_test, t, bary);
        } else {
            hit_here = scene->hit_solid(ref, *ray, t_min, t_test, t);
        }
        if (hit_here) offer(ref, t, bary);
    }

    // A hit of primitive `ref` at t in (t_min, t_test), as test() found it (or a test of the
    // same numbers: sphere_lanes.hpp): it replaces the best if closer, or an exact tie with a lower id.
    __attribute__((always_inline)) void offer(int32_t ref, double t, const Barycentric& bary) {
        if (found && !(t < t_best || scene->primitive_id(ref) < scene->primitive_id(hit->ref))) return;
        found = true;
        t_best = t;
        *hit = {t, ref, bary};
        t_test = next_up(t_best);
        t_cull = t_best + std::fabs(t_best) * kTieCullMargin;
    }

    // After the tree: the unbounded planes (outside it), with the same tie rule, then instances
    // (a copy wins only by being closer). Whether the ray hit anything.
    bool finish(double t_max) {
        double t_plane;
        int32_t plane;
        if (!scene->planes.empty() && scene->hit_planes(*ray, t_min, found ? next_up(t_best) : t_max, t_plane, plane)) {
            if (!found || t_plane < t_best || scene->primitive_id(plane) < scene->primitive_id(hit->ref)) {
                *hit = {t_plane, plane, Barycentric{}};
                t_best = t_plane;
                found = true;
            }
        }
        if (!scene->instances_empty()) {
            Hit instance_hit;
            if (scene->instances->closest_hit(*ray, t_min, t_best, instance_hit) &&
                (!found || instance_hit.t < t_best)) {
                *hit = instance_hit;
                found = true;
            }
        }
        return found;
    }
};

}  // namespace phong
