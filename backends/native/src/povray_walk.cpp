// SPDX-License-Identifier: Apache-2.0
// POV-Ray 3.7's shadow test against a mesh, reproduced for the POV-Ray numerics (diff).
//
// POV-Ray's mesh object (backend/shape/mesh.cpp, intersect_bbox_tree) visits the boxes of its
// own hierarchy in order of their entry distance e and records every triangle hit with
// t >= DEPTH_TOLERANCE (1e-6), but it stops at the first box with e > Best, where Best is the t
// of the last hit found. The shadow test afterwards ignores hits with t <= 1e-3 (the shadow
// window). So a shadow ray that first hits its own surface a little away from its origin
// (t in [1e-6, 1e-3], common on the faceted side of a smooth terminator) sets Best to that
// tiny t, and an occluder of the same mesh farther along (an ear shadowing a head) is never
// visited: POV-Ray lights the point. Blender's Suzanne shows it on 5 of 19 200 pixels.
//
// Boxes of inner nodes contain their children's, so they are entered no later; the walk thus
// visits the hit triangles in the order of their own boxes' entry distances, and its outcome
// depends on those alone (not on the shape of POV-Ray's hierarchy): walking the sorted hits,
// stop at the first e > Best, else Best = t. Ties in e, and two triangles hit at exactly the
// same t (only the lower id is enumerated), are where this can differ from POV-Ray.
//
// The walk finds the closest hit always (its e <= t <= Best), so it can differ from a plain
// any-hit test only when a hit lies in [1e-6, t_min]; without one, occluded()'s answer stands.
//
// A filtered shadow ray (through glass, ref §18) is searched segment by segment from each
// crossing, and each segment's search walks every mesh again: a crossing a few microns from
// an opaque mesh (a glass ball seated in a pawn's socket) hides that whole mesh from the rest
// of the ray, so POV-Ray lights a point the mesh shadows (OpenChessSet's Pawn: 21 pixels).
#include <algorithm>
#include <cmath>
#include <vector>

#include "scene.hpp"

namespace phong {

namespace {

// POV-Ray's DEPTH_TOLERANCE in mesh.cpp: triangle hits closer than this are not recorded. The
// compiler writes mesh2 in a translated local frame, so mesh-space and world t agree.
constexpr double kPovrayMeshDepthTolerance = 1e-6;
// A ray crosses at most this many surfaces before the walk gives up and keeps occluded()'s
// answer (hundreds of layers would be a scene where the difference cannot be seen anyway).
constexpr int kMaxWalkHits = 1024;

struct WalkHit {
    int32_t mesh;
    double entry;  // entry distance of the triangle's box
    Hit hit;
};

double box_entry(const TriangleShape& tri, const Ray& ray) {
    double entry = -HUGE_VAL;
    const double o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
    const double d[3] = {ray.dir.x, ray.dir.y, ray.dir.z};
    const Vec3* v[3] = {&tri.v0, &tri.v1, &tri.v2};
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0.0) continue;  // the ray hit the triangle, so it lies inside this slab
        double lo = HUGE_VAL, hi = -HUGE_VAL;
        for (const Vec3* p : v) {
            const double c = k == 0 ? p->x : k == 1 ? p->y : p->z;
            lo = std::fmin(lo, c);
            hi = std::fmax(hi, c);
        }
        const double t0 = (lo - o[k]) / d[k], t1 = (hi - o[k]) / d[k];
        entry = std::fmax(entry, std::fmin(t0, t1));
    }
    return entry;
}

}  // namespace

namespace {

// The hits POV-Ray's search reports along `ray`, each passed to visit(hit) until it returns
// true (then so does this); past kMaxWalkHits it gives up (gave_up, and false). A sphere, an instance and an intrinsic
// part report every hit, and so does a mesh with an inside: the compiler writes inside_vector for a transmissive
// material's mesh, and POV-Ray's walk does not stop early for such a mesh (mesh.cpp:
// `if (!OldStyle && Depth > Best) break`, OldStyle = has_inside_vector). Any other mesh
// reports the hits its walk visits (the file comment).
template <class Visit>
bool each_reported_hit(const Scene& scene, const Ray& ray, bool& gave_up, Visit visit) {
    std::vector<WalkHit> hits;
    Hit hit;
    double from = kPovrayMeshDepthTolerance;
    while (scene.closest_hit(ray, from, HUGE_VAL, hit)) {
        if (int(hits.size()) == kMaxWalkHits) {
            gave_up = true;
            return false;
        }
        const bool walked = hit.ref >= 0 && hit.instance < 0 &&
                            !(scene.materials[size_t(scene.triangle_material(size_t(hit.ref)))].kt > 0.0);
        if (!walked) {
            if (visit(hit)) return true;
        } else {
            const size_t slot = size_t(hit.ref);
            hits.push_back({scene.triangle_mesh(slot), box_entry(scene.triangles[slot], ray), hit});
        }
        from = hit.t;
    }
    std::sort(hits.begin(), hits.end(), [](const WalkHit& a, const WalkHit& b) {
        return a.mesh != b.mesh ? a.mesh < b.mesh : a.entry < b.entry;
    });
    for (size_t i = 0; i < hits.size();) {
        double best = HUGE_VAL;
        size_t j = i;
        for (; j < hits.size() && hits[j].mesh == hits[i].mesh; ++j) {
            if (hits[j].entry > best) break;
            best = hits[j].hit.t;
            if (visit(hits[j].hit)) return true;
        }
        while (j < hits.size() && hits[j].mesh == hits[i].mesh) ++j;
        i = j;
    }
    return false;
}

}  // namespace

bool Scene::occluded_povray_walk(const Ray& ray, double t_min, double t_max) const {
    Hit hit;
    if (!closest_hit(ray, kPovrayMeshDepthTolerance, t_min, hit)) return true;  // nothing to stop the walk
    bool gave_up = false;
    const bool found = each_reported_hit(*this, ray, gave_up, [&](const Hit& h) { return h.t > t_min && h.t < t_max; });
    return found || gave_up;  // beyond kMaxWalkHits occluded()'s answer stands
}

bool Scene::closest_hit_povray_walk(const Ray& ray, double t_min, double t_max, Hit& hit) const {
    // The closest hit is always visited (its box is entered no later than it, and the walk's
    // Best is some hit's t, never below it): only a hit in [1e-6, t_min] can change the answer.
    Hit near;
    if (!closest_hit(ray, kPovrayMeshDepthTolerance, t_min, near)) return closest_hit(ray, t_min, t_max, hit);
    bool found = false, gave_up = false;
    Hit best{};
    each_reported_hit(*this, ray, gave_up, [&](const Hit& h) {
        if (h.t > t_min && h.t < t_max && (!found || h.t < best.t)) {
            best = h;
            found = true;
        }
        return false;
    });
    if (gave_up) return closest_hit(ray, t_min, t_max, hit);
    if (found) hit = best;
    return found;
}

}  // namespace phong
