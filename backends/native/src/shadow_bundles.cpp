// SPDX-License-Identifier: Apache-2.0
// Shadow-ray bundles: the occluder candidates a bundle of shadow rays (an area light's grid seen
// from one shaded point) can hit, and the tests of every ray of the bundle against them. Kept
// apart from the scene's construction and single-ray BVH queries (scene.cpp).
#include "scene.hpp"

#include <emmintrin.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace phong {

namespace {
// A linear scan of a bundle's candidates beats one BVH traversal per ray only while the list
// is about as short as the nodes and primitives such a traversal visits (a few dozen); beyond
// that, wide bundles through dense meshes go back to occluded().
constexpr size_t kMaxBundleCandidates = 32;
}  // namespace

bool Scene::shadow_candidates(const Vec3* hull, int hull_count, double t_min,
                              std::vector<BundleCandidate>& candidates) const {
    candidates.clear();
    if (!instances_empty()) return false;  // instances are not candidates: each ray asks occluded()
    if (bvh4_.empty() && bvh8_.empty()) return true;
    // Candidate separating axes: x, y, z, the parallelogram's normal and the four side faces of
    // the pyramid (apex hull[0]). Any vector is a valid axis: the hull's extent along it is
    // computed from the points, not assumed.
    // The five side axes are set up only when a box is not separated along x, y, z nor below
    // the window (most bundles of an open scene end before that): set_up_side_axes().
    constexpr int kAxes = 8;
    Vec3 axes[kAxes] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    int axis_count = 3;
    // Comparisons, not max_abs_component's std::fmax (a libm call): the same maximum of numbers.
    double scale = magnitude;
    for (int i = 0; i < hull_count; ++i)
        for (const double x : {hull[i].x, hull[i].y, hull[i].z}) scale = std::max(scale, std::fabs(x));
    double lo[kAxes], hi[kAxes];
    auto extent = [&](int a) {
        const Vec3& n = axes[a];
        // Along x, y, z the projection is the coordinate itself (the dot product's other terms
        // are ±0, which change no value that a comparison below sees).
        auto project = [&](const Vec3& q) { return a == 0 ? q.x : a == 1 ? q.y : a == 2 ? q.z : dot(n, q); };
        lo[a] = hi[a] = project(hull[0]);
        for (int i = 1; i < hull_count; ++i) {
            const double x = project(hull[i]);
            lo[a] = std::min(lo[a], x);
            hi[a] = std::max(hi[a], x);
        }
        const double slack = kShadowBundleSlack * (std::fabs(n.x) + std::fabs(n.y) + std::fabs(n.z)) * scale;
        lo[a] -= slack;
        hi[a] += slack;
    };
    for (int a = 0; a < 3; ++a) extent(a);
    // Rays count hits only at t > t_min, i.e. beyond the apex p by t_min along their unit
    // direction. Along a coordinate direction e that every ray of the bundle climbs
    // (e·dir >= rise > 0 for all of them; the minimum over the parallelogram is at a corner, as
    // e·(x−p)/|x−p| is quasi-concave), a hit lies at e·(x−p) >= t_min·rise, so a box below that
    // level cannot hold one: the shaded surface itself (a floor under the point) drops out.
    // Skipped when a corner is closer than t_min (then the directions' rounding is not small).
    const Vec3& apex = hull[0];
    double rise[3][2] = {};         // [axis][0: +e, 1: −e], 0 = not climbing
    double corner_distance[kAxes];  // |hull[i] − apex|, once per corner rather than per use
    bool corners_far = hull_count > 1;
    for (int i = 1; i < hull_count; ++i) {
        corner_distance[i] = length(hull[i] - apex);
        corners_far = corners_far && corner_distance[i] >= t_min;
    }
    if (corners_far) {
        for (int k = 0; k < 3; ++k) {
            double lowest[2] = {HUGE_VAL, HUGE_VAL};
            for (int i = 1; i < hull_count; ++i) {
                const Vec3 v = hull[i] - apex;
                const double c = v[k] / corner_distance[i];
                lowest[0] = std::min(lowest[0], c);
                lowest[1] = std::min(lowest[1], -c);
            }
            for (int s = 0; s < 2; ++s) rise[k][s] = std::max(0.0, lowest[s] - kShadowBundleSlack);
        }
    }
    // The levels, once per bundle: a box whose top lies below level[k][0] (or bottom above
    // level[k][1]) cannot hold a hit; ±inf where the bundle does not climb that way.
    double level[3][2];
    for (int k = 0; k < 3; ++k) {
        const double slack = kShadowBundleSlack * scale;
        level[k][0] = rise[k][0] > 0.0 ? apex[k] + t_min * rise[k][0] - slack : -HUGE_VAL;
        level[k][1] = rise[k][1] > 0.0 ? apex[k] - t_min * rise[k][1] + slack : HUGE_VAL;
    }
    // Valid for any box (a node's or a primitive's): no ray of the bundle has a hit inside it.
    auto below_the_window = [&](const float (&box_lo)[3], const float (&box_hi)[3]) {
        for (int k = 0; k < 3; ++k)
            if (double(box_hi[k]) < level[k][0] || double(box_lo[k]) > level[k][1]) return true;
        return false;
    };
    // A box's extent along axis a, [Σ n_k·(the bound that minimises), Σ n_k·(the one that
    // maximises)]: the bounds picked once per axis by the sign of n_k (n_k > 0: lo for the
    // minimum), not by comparing both products per box. The same products as comparing them,
    // so the same decisions: for n_k > 0 (< 0) rounding is monotone, so n_k·lo <= n_k·hi
    // (>=), and where the two round equal only a zero's sign can differ, which no comparison
    // below sees; n_k = 0 picks what the comparison picked (hi for the minimum, lo for the
    // maximum). The coordinate axes x, y, z need no products: their extent is [lo_k, hi_k]
    // (the other terms are ±0), and the hull's along them is its coordinates'.
    bool min_takes_lo[kAxes][3];
    bool side_axes_ready = false;
    auto set_up_side_axes = [&] {
        side_axes_ready = true;
        if (hull_count != 5) return;
        axes[axis_count++] = cross(hull[2] - hull[1], hull[4] - hull[1]);
        for (int k = 1; k <= 4; ++k) axes[axis_count++] = cross(hull[k % 4 + 1] - hull[k], hull[k] - hull[0]);
        for (int a = 3; a < axis_count; ++a) {
            extent(a);
            for (int k = 0; k < 3; ++k) min_takes_lo[a][k] = axes[a][k] > 0.0;
        }
    };
    auto separated = [&](const float (&box_lo)[3], const float (&box_hi)[3]) {
        for (int k = 0; k < 3; ++k)
            if (double(box_lo[k]) > hi[k] || double(box_hi[k]) < lo[k]) return true;
        if (!side_axes_ready) set_up_side_axes();
        for (int a = 3; a < axis_count; ++a) {
            const double n[3] = {axes[a].x, axes[a].y, axes[a].z};
            double min = 0.0, max = 0.0;
            for (int k = 0; k < 3; ++k) {
                const bool take_lo = min_takes_lo[a][k];
                min += n[k] * double(take_lo ? box_lo[k] : box_hi[k]);
                max += n[k] * double(take_lo ? box_hi[k] : box_lo[k]);
            }
            if (min > hi[a] || max < lo[a]) return true;
        }
        return false;
    };
    auto add_leaf = [&](int32_t first, int count) {
        for (int i = 0; i < count; ++i) {
            const int32_t ref = refs_[size_t(first + i)];
            Bounds b;
            if (ref >= 0) {
                const TriangleShape& tri = triangles[size_t(ref)];
                b.grow(tri.v0);
                b.grow(tri.v1);
                b.grow(tri.v2);
            } else if (is_round(ref)) {
                SphereShape scratch;
                const SphereShape& s = round_shape(ref, scratch);
                b.lo = s.bounds_lo;
                b.hi = s.bounds_hi;
            } else {
                b.lo = intrinsic(ref).bounds_lo;
                b.hi = intrinsic(ref).bounds_hi;
            }
            BundleCandidate box{{round_down(b.lo.x), round_down(b.lo.y), round_down(b.lo.z)},
                                {round_up(b.hi.x), round_up(b.hi.y), round_up(b.hi.z)},
                                ref,
                                {}};
            if (below_the_window(box.lo, box.hi) || separated(box.lo, box.hi)) continue;  // the cheaper test first
            if (candidates.size() == kMaxBundleCandidates) return false;
            // An intrinsic part (intrinsics.hpp) has no bundle test: the rays go one by one
            // through occluded(), which tests every kind.
            if (ref < 0 && !is_round(ref)) return false;
            if (ref < 0) {
                SphereShape scratch;
                box.sphere_origin = sphere_origin(round_shape(ref, scratch), apex);
            }
            candidates.push_back(box);
        }
        return true;
    };
    // The same walk over either tree: a leaf's box is culled exactly when every box holding it
    // would be (separation and the window are monotone in the box), so the candidates are the
    // same set on both paths, only their order differs, which no any-hit answer depends on.
    auto walk = [&](const auto& nodes, auto& stack) {
        constexpr int width = int(sizeof(nodes[0].child) / sizeof(nodes[0].child[0]));
        int sp = 0;
        int32_t index = 0;
        while (true) {
            const auto& node = nodes[size_t(index)];
            for (int i = 0; i < width; ++i) {
                if (node.child[i] < 0) continue;  // empty slot
                const ChildBox box(node, i);
                // A child below the window holds only primitives below it, which add_leaf() drops.
                if (below_the_window(box.lo, box.hi) || separated(box.lo, box.hi)) continue;
                if (node.count[i] == 0) {
                    stack[sp++] = node.child[i];
                } else if (!add_leaf(node.child[i], node.count[i])) {
                    return false;
                }
            }
            if (sp == 0) return true;
            index = stack[--sp];
        }
    };
    if (!bvh8_.empty()) {
        int32_t stack[kMaxBvh8Stack];
        return walk(bvh8_, stack);
    }
    int32_t stack[kMaxBvh4Stack];
    return walk(bvh4_, stack);
}

bool Scene::occluded_by(std::vector<BundleCandidate>& candidates, const Ray& ray, double t_min, double t_max) const {
    const Vec3 inv{1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z};
    std::optional<WatertightRay> wr;  // only when a triangle is tested
    for (size_t k = 0; k < candidates.size(); ++k) {
        const BundleCandidate& box = candidates[k];
        double t_entry;
        if (!hit_node(box, ray.origin, inv, t_min, kAnyHitBoxLimit, t_entry)) continue;
        double t;
        bool hit;
        if (box.ref >= 0) {
            Barycentric bary;
            hit = hit_triangle(box.ref, ray, wr, t_min, t_max, t, bary);
        } else {
            // ray.origin is the bundle's apex, whose object-space form the candidate holds.
            SphereShape scratch;
            hit = intersect_sphere(round_shape(box.ref, scratch), box.sphere_origin, ray.dir, t_min, t_max, t);
        }
        if (hit) {
            std::swap(candidates[0], candidates[k]);
            return true;
        }
    }
    return false;
}

namespace {
// All-ones in the lanes whose sign bit is set (hit_node's std::signbit, −0 and −inf included).
inline __m128d sign_mask(__m128d x) {
    return _mm_castsi128_pd(_mm_shuffle_epi32(_mm_srai_epi32(_mm_castpd_si128(x), 31), _MM_SHUFFLE(3, 3, 1, 1)));
}
using detail::select;  // shapes.hpp
}  // namespace

void Scene::occluded_by_each(const std::vector<BundleCandidate>& candidates, const Vec3& origin, const double* x,
                             const double* y, const double* z, const double* distance, size_t count, double t_min,
                             unsigned char* blocked) const {
    std::fill(blocked, blocked + count, 0);
    if (candidates.empty() || count == 0) return;
    // Rays in pairs, for the sphere test (intersect_sphere_pair) and hit_node()'s box test in the
    // two lanes of SSE2 doubles: per lane the same operations in the same order (IEEE products
    // and differences, maxpd/minpd with hit_node's operand order, so NaN is ignored as there),
    // hence the same decisions. The directions come in lanes (an odd count pads the last ray,
    // whose result is dropped); per ray, once: t_max and, for triangles, the reciprocal
    // direction, and the watertight set-up when a triangle is tested that way (occluded_by()
    // makes the same ones, per ray).
    const size_t pairs = (count + 1) / 2, padded = 2 * pairs;
    const double* const dir[3] = {x, y, z};
    thread_local std::vector<double> lanes;
    lanes.resize(4 * padded);
    double* const inverse[3] = {lanes.data(), lanes.data() + padded, lanes.data() + 2 * padded};
    double* const t_max = lanes.data() + 3 * padded;
    for (size_t k = 0; k < padded; ++k) t_max[k] = distance[k] - t_min;
    // The box tests' reciprocals, two at a time (IEEE division per lane), for triangles only.
    const bool any_triangle =
        std::any_of(candidates.begin(), candidates.end(), [](const BundleCandidate& c) { return c.ref >= 0; });
    const __m128d one = _mm_set1_pd(1.0);
    if (any_triangle)
        for (size_t k = 0; k < padded; k += 2)
            for (int a = 0; a < 3; ++a) _mm_storeu_pd(inverse[a] + k, _mm_div_pd(one, _mm_loadu_pd(dir[a] + k)));
    thread_local std::vector<WatertightRay> sheared;
    const bool watertight = povray_triangles.empty() && any_triangle;
    if (watertight) {
        sheared.clear();
        for (size_t k = 0; k < count; ++k) sheared.emplace_back(Vec3{x[k], y[k], z[k]});
    }
    const __m128d widening = _mm_set1_pd(kSlabFarWidening), t_min_lanes = _mm_set1_pd(t_min);
    const double o[3] = {origin.x, origin.y, origin.z};
    size_t open = count;                        // rays not yet blocked: none left, no candidate need be tested
    auto block = [&](size_t first, int hits) {  // lanes of the pair at `first` that hit
        for (; hits != 0; hits &= hits - 1) {
            blocked[first + size_t(__builtin_ctz(unsigned(hits)))] = 1;
            if (--open == 0) return true;
        }
        return false;
    };
    for (const BundleCandidate& box : candidates) {
        if (box.ref < 0) {
            // A sphere: its own test on both lanes, without the box test first (in lanes the
            // box test cost more than the sphere tests it saved: S3's render 380.6M -> 333.4M
            // instructions with the reciprocals left out). origin is the bundle's apex, whose
            // object-space form the candidate holds.
            SphereShape scratch;
            const SphereShape& sphere = round_shape(box.ref, scratch);
            for (size_t first = 0; first < count; first += 2) {
                const int open_lanes = (blocked[first] ? 0 : 1) | (first + 1 < count && !blocked[first + 1] ? 2 : 0);
                if (open_lanes == 0) continue;
                const int hits =
                    open_lanes & intersect_sphere_pair(sphere, box.sphere_origin, _mm_loadu_pd(dir[0] + first),
                                                       _mm_loadu_pd(dir[1] + first), _mm_loadu_pd(dir[2] + first),
                                                       t_min, _mm_loadu_pd(t_max + first));
                if (block(first, hits)) return;
            }
            continue;
        }
        // A triangle: behind its box, tested in lanes (hit_node's (plane − o) is the same for
        // every ray of the bundle), then one ray at a time.
        __m128d to_lo[3], to_hi[3];
        for (int a = 0; a < 3; ++a) {
            to_lo[a] = _mm_set1_pd(double(box.lo[a]) - o[a]);
            to_hi[a] = _mm_set1_pd(double(box.hi[a]) - o[a]);
        }
        for (size_t first = 0; first < count; first += 2) {
            const int open_lanes = (blocked[first] ? 0 : 1) | (first + 1 < count && !blocked[first + 1] ? 2 : 0);
            if (open_lanes == 0) continue;
            __m128d t0 = t_min_lanes, t1 = _mm_set1_pd(kAnyHitBoxLimit);  // hit_node's, uncapped
            for (int a = 0; a < 3; ++a) {
                const __m128d r = _mm_loadu_pd(inverse[a] + first);
                const __m128d negative = sign_mask(r);
                const __m128d from_lo = _mm_mul_pd(to_lo[a], r), from_hi = _mm_mul_pd(to_hi[a], r);
                t0 = _mm_max_pd(select(negative, from_hi, from_lo), t0);
                t1 = _mm_min_pd(_mm_mul_pd(select(negative, from_lo, from_hi), widening), t1);
            }
            int hits = 0;
            for (int lanes = _mm_movemask_pd(_mm_cmple_pd(t0, t1)) & open_lanes; lanes != 0; lanes &= lanes - 1) {
                const int lane = __builtin_ctz(unsigned(lanes));
                const size_t k = first + size_t(lane);
                const Ray ray{origin, Vec3{x[k], y[k], z[k]}};
                double t;
                Barycentric bary;
                const bool hit =
                    watertight
                        ? intersect_triangle(triangles[size_t(box.ref)], ray, sheared[k], t_min, t_max[k], t, bary)
                        : intersect_povray_triangle(povray_triangles[size_t(box.ref)], triangles.local(size_t(box.ref)),
                                                    triangles.origin(size_t(box.ref)), ray, t_min, t_max[k], t, bary);
                if (hit) hits |= 1 << lane;
            }
            if (block(first, hits)) return;
        }
    }
}

}  // namespace phong
