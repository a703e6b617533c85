// SPDX-License-Identifier: Apache-2.0
// Scene construction from flat geometry arrays, materials and lights, and the BVH queries.
#include "scene.hpp"

#include <emmintrin.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <future>
#include <limits>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <variant>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace phong {

namespace {

Vec3 row3(const double* p) { return {p[0], p[1], p[2]}; }

void check_index(int64_t i, size_t count, const char* what) {
    if (i < 0 || size_t(i) >= count)
        throw std::invalid_argument(std::string(what) + " index " + std::to_string(i) + " out of range [0, " +
                                    std::to_string(count) + ")");
}

// An area light's grid weighs its samples by 1/(samples − 1) per axis (lights.hpp).
void check_area_light_samples(const Light& light) {
    std::visit(
        [](const auto& L) {
            using T = std::decay_t<decltype(L)>;
            if constexpr (std::is_same_v<T, RectAreaLight> || std::is_same_v<T, SphereAreaLight>)
                if (L.samples < 2) throw std::invalid_argument("area light samples must be >= 2");
        },
        light);
}

// Runs fn(begin, end) over [0, n) in one chunk per hardware thread when n is large enough to
// pay for the threads (1M triangles: ~0.1 s of serial copying per pass), else in one piece. The
// first exception in chunk order is rethrown once every chunk has finished, so errors are the
// same as a serial loop's.
constexpr size_t kParallelCopyMinItems = size_t(1) << 16;

template <class Fn>
void for_chunks(size_t n, Fn&& fn) {
    const size_t chunks = n >= kParallelCopyMinItems ? std::max(1u, std::thread::hardware_concurrency()) : 1;
    std::vector<std::future<void>> rest;
    for (size_t c = 1; c < chunks; ++c)
        rest.push_back(std::async(std::launch::async, [&fn, c, chunks, n] { fn(n * c / chunks, n * (c + 1) / chunks); }));
    std::exception_ptr error;
    try {
        fn(size_t(0), n / chunks);
    } catch (...) {
        error = std::current_exception();
    }
    for (std::future<void>& f : rest) {
        try {
            f.get();
        } catch (...) {
            if (!error) error = std::current_exception();
        }
    }
    if (error) std::rethrow_exception(error);
}

// std::nextafter(x, +inf) without the libm call (one per primary hit): the next double above x
// by one step of its bit pattern (up in magnitude when positive, down when negative; ±0 go to
// the smallest subnormal, +inf and NaN stay).
inline double next_up(double x) {
    if (!(x < HUGE_VAL)) return x;
    if (x == 0.0) return std::numeric_limits<double>::denorm_min();
    uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    bits = x > 0.0 ? bits + 1 : bits - 1;
    std::memcpy(&x, &bits, sizeof x);
    return x;
}

}  // namespace

Scene::Scene(const GeometryArrays& in, std::vector<Material> scene_materials, std::vector<Light> scene_lights,
             const RGB& ambient_light)
    : materials(std::move(scene_materials)), lights(std::move(scene_lights)), ambient(ambient_light) {
    for (const Light& light : lights) check_area_light_samples(light);
    // Triangles and normals are numbered across the meshes in order: mesh m's start at
    // first_triangle[m] and first_normal[m].
    const size_t n_meshes = in.meshes.size();
    std::vector<size_t> first_triangle(n_meshes + 1, 0), first_normal(n_meshes + 1, 0);
    for (size_t m = 0; m < n_meshes; ++m) {
        const MeshArrays& mesh = in.meshes[m];
        check_index(mesh.material, materials.size(), "mesh material");
        first_triangle[m + 1] = first_triangle[m] + mesh.triangle_count;
        first_normal[m + 1] = first_normal[m] + mesh.normal_count;
    }
    std::vector<std::pair<const double*, size_t>> mesh_normals;
    for (const MeshArrays& mesh : in.meshes) mesh_normals.emplace_back(mesh.normals, mesh.normal_count);
    normals.assign(mesh_normals);
    // The mesh of triangle i (global number): looked up once per chunk (then stepped) in the
    // pass below, per triangle in the leaf-order pass.
    auto mesh_of = [&](size_t i) {
        return size_t(std::upper_bound(first_triangle.begin() + 1, first_triangle.end(), i) - first_triangle.begin() - 1);
    };

    const size_t n_spheres = in.sphere_count, n_triangles = first_triangle[n_meshes];
    std::vector<PrimRef> prims(n_spheres + n_triangles);
    spheres.resize(n_spheres);
    for (size_t i = 0; i < n_spheres; ++i) {
        const double* w = in.sphere_world_from_object + 16 * i;
        const double* o = in.sphere_object_from_world + 16 * i;
        SphereShape& s = spheres[i];
        for (int k = 0; k < 12; ++k) s.object_from_world.m[k] = o[k];
        s.axis_aligned = s.object_from_world.axis_aligned();
        check_index(in.sphere_material[i], materials.size(), "sphere material");
        s.material = in.sphere_material[i];
        // Exact AABB of an affine image of the unit sphere: centre ± the row norms.
        const Vec3 c{w[3], w[7], w[11]};
        const Vec3 r{length(row3(w)), length(row3(w + 4)), length(row3(w + 8))};
        s.bounds_lo = c - r;
        s.bounds_hi = c + r;
        Bounds b;
        b.lo = s.bounds_lo;
        b.hi = s.bounds_hi;
        bounds.grow(b);
        prims[i] = PrimRef(b, uint32_t(i));
    }
    std::mutex bounds_mutex;  // each chunk's union of double bounds joins `bounds` (min/max: any order)
    for_chunks(n_triangles, [&](size_t begin, size_t end) {
        Bounds chunk_bounds;
        size_t m = begin < end ? mesh_of(begin) : 0;
        for (size_t i = begin; i < end; ++i) {
            while (i >= first_triangle[m + 1]) ++m;
            const MeshArrays& mesh = in.meshes[m];
            const size_t local = i - first_triangle[m];
            const int32_t* t = mesh.triangles + 3 * local;
            Bounds b;
            for (int k = 0; k < 3; ++k) {
                check_index(t[k], mesh.point_count, "triangle vertex");
                b.grow(row3(mesh.points + 3 * size_t(t[k])));
            }
            chunk_bounds.grow(b);
            prims[n_spheres + i] = PrimRef(b, uint32_t(n_spheres + i));
            if (mesh.normal_indices) {
                const int32_t* n = mesh.normal_indices + 3 * local;
                if (n[0] >= 0 || n[1] >= 0 || n[2] >= 0)
                    for (int k = 0; k < 3; ++k) check_index(n[k], mesh.normal_count, "normal");
            }
        }
        const std::lock_guard<std::mutex> lock(bounds_mutex);
        bounds.grow(chunk_bounds);
    });
    magnitude = bounds.empty() ? 0.0 : std::fmax(max_abs_component(bounds.lo), max_abs_component(bounds.hi));
    // The build consumes (and frees) the primitive boxes before the leaf-order copies below are
    // allocated.
    bvh_.build(std::move(prims));
#if defined(__GLIBC__)
    // The freed primitive boxes (30 MiB at 1M triangles) stay resident in glibc's heap, under
    // the collapse and the copies below, unless handed back: S2's peak 300 -> 286 MiB
    // (benchmarks/memory_stages.py; benchmarks/README.md).
    malloc_trim(0);
#endif
    // The rays walk the 4-wide tree; the binary one's nodes are freed once it is collapsed.
    bvh4_ = collapse_to_bvh4(bvh_.nodes);
    std::vector<BvhNode>().swap(bvh_.nodes);

    // Primitive refs and triangle data in leaf order, so leaves read memory sequentially.
    // Leaf position k holds triangle slot k − (spheres before k).
    const std::vector<uint32_t>& order = bvh_.order;
    std::vector<uint32_t> sphere_positions;
    for (size_t k = 0; k < order.size(); ++k)
        if (order[k] < n_spheres) sphere_positions.push_back(uint32_t(k));
    refs_.resize(order.size());
    // Float corners when every vertex is a float (triangle_store.hpp): the same doubles.
    bool every_vertex_float = true;
    for (const MeshArrays& mesh : in.meshes)
        for (size_t i = 0; i < 3 * mesh.point_count && every_vertex_float; ++i)
            every_vertex_float = float_exact(mesh.points[i]);
    triangles.resize(n_triangles, every_vertex_float);
    triangle_shading.resize(n_triangles);
    triangle_source.resize(n_triangles);
    if (in.povray_triangles) povray_triangles.resize(n_triangles);
    for_chunks(order.size(), [&](size_t begin, size_t end) {
        size_t spheres_before = size_t(
            std::lower_bound(sphere_positions.begin(), sphere_positions.end(), uint32_t(begin)) -
            sphere_positions.begin());
        for (size_t k = begin; k < end; ++k) {
            const uint32_t id = order[k];
            if (id < n_spheres) {
                refs_[k] = ~int32_t(id);
                ++spheres_before;
                continue;
            }
            const size_t i = id - n_spheres, slot = k - spheres_before;
            const size_t m = n_meshes == 1 ? 0 : mesh_of(i);
            const MeshArrays& mesh = in.meshes[m];
            const size_t local = i - first_triangle[m];
            const int32_t* t = mesh.triangles + 3 * local;
            refs_[k] = int32_t(slot);
            const TriangleShape corners{row3(mesh.points + 3 * size_t(t[0])), row3(mesh.points + 3 * size_t(t[1])),
                                        row3(mesh.points + 3 * size_t(t[2]))};
            triangles.set(slot, corners);
            TriangleShading sh{-1, -1, -1, mesh.material};
            if (mesh.normal_indices && mesh.normal_indices[3 * local] >= 0) {
                const int32_t* n = mesh.normal_indices + 3 * local;
                const int32_t offset = int32_t(first_normal[m]);
                sh.n0 = n[0] + offset;
                sh.n1 = n[1] + offset;
                sh.n2 = n[2] + offset;
            }
            triangle_shading[slot] = sh;
            triangle_source[slot] = uint32_t(i);
            if (in.povray_triangles) povray_triangles[slot] = make_povray_triangle(corners, mesh.origin);
        }
    });
    bvh_.order.clear();
    bvh_.order.shrink_to_fit();
    first_triangle_ = std::move(first_triangle);
}

int32_t Scene::triangle_mesh(size_t slot) const {
    const size_t i = triangle_source[slot];
    return int32_t(std::upper_bound(first_triangle_.begin() + 1, first_triangle_.end(), i) - first_triangle_.begin() - 1);
}

int64_t Scene::primitive_id(int32_t ref) const {
    if (ref < 0) return int64_t(~ref);
    return int64_t(spheres.size()) + triangle_source[size_t(ref)];
}

bool Scene::closest_hit(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max, Hit& hit) const {
    // Exact ties (coincident surfaces hit at the same t) go to the lower primitive id, so the
    // hit does not depend on the BVH's shape or visiting order: once a hit is found, primitives
    // are tested up to and including t_best, and boxes up to a little beyond it: a box's entry
    // distance in the double test errs by < 2ε relative (three roundings of ≤ ε/2, as in
    // hit_node), and kTieCullMargin = 8ε keeps a 4x margin over it, like kSelfHitError (the float
    // test widens its limit further by itself: FloatSlabRay).
    constexpr double kTieCullMargin = ulps(8);
    std::optional<WatertightRay> wr;  // set up when the first triangle is tested
    bool found = false;
    double t_best = t_max, t_test = t_max, t_cull = t_max;
    traverse_bvh4<true>(bvh4_, magnitude, ray, origin, t_min, t_cull, [&](int32_t first, int count, double& cull) {
        for (int k = 0; k < count; ++k) {
            const int32_t ref = refs_[size_t(first + k)];
            double t;
            Barycentric bary{};
            bool hit_here;
            if (ref >= 0) {
                hit_here = hit_triangle(ref, ray, wr, t_min, t_test, t, bary);
            } else {
                hit_here = intersect_sphere(spheres[size_t(~ref)], ray, t_min, t_test, t);
            }
            if (!hit_here) continue;
            if (found && !(t < t_best || primitive_id(ref) < primitive_id(hit.ref))) continue;
            found = true;
            t_best = t;
            hit = {t, ref, bary};
            t_test = next_up(t_best);
            cull = t_best + std::fabs(t_best) * kTieCullMargin;
        }
        return false;
    });
    return found;
}

bool Scene::occluded(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max) const {
    std::optional<WatertightRay> wr;  // set up when the first triangle is tested
    bool blocked = false;
    double t_limit = t_max;
    traverse_bvh4<false>(bvh4_, magnitude, ray, origin, t_min, t_limit, [&](int32_t first, int count, double& t_best) {
        for (int k = 0; k < count; ++k) {
            const int32_t ref = refs_[size_t(first + k)];
            double t;
            bool hit;
            if (ref >= 0) {
                Barycentric bary;
                hit = hit_triangle(ref, ray, wr, t_min, t_best, t, bary);
            } else {
                hit = intersect_sphere(spheres[size_t(~ref)], ray, t_min, t_best, t);
            }
            if (hit) {
                blocked = true;
                return true;  // shadow rays stop at the first hit
            }
        }
        return false;
    });
    return blocked;
}

namespace {
// A linear scan of a bundle's candidates beats one BVH traversal per ray only while the list
// is about as short as the nodes and primitives such a traversal visits (a few dozen); beyond
// that, wide bundles through dense meshes go back to occluded().
constexpr size_t kMaxBundleCandidates = 32;
}  // namespace

bool Scene::shadow_candidates(const Vec3* hull, int hull_count, double t_min,
                              std::vector<BundleCandidate>& candidates) const {
    candidates.clear();
    if (bvh4_.empty()) return true;
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
    double rise[3][2] = {};  // [axis][0: +e, 1: −e], 0 = not climbing
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
            } else {
                b.lo = spheres[size_t(~ref)].bounds_lo;
                b.hi = spheres[size_t(~ref)].bounds_hi;
            }
            BundleCandidate box{{round_down(b.lo.x), round_down(b.lo.y), round_down(b.lo.z)},
                                {round_up(b.hi.x), round_up(b.hi.y), round_up(b.hi.z)},
                                ref,
                                {}};
            if (below_the_window(box.lo, box.hi) || separated(box.lo, box.hi)) continue;  // the cheaper test first
            if (candidates.size() == kMaxBundleCandidates) return false;
            if (ref < 0) box.sphere_origin = sphere_origin(spheres[size_t(~ref)], apex);
            candidates.push_back(box);
        }
        return true;
    };
    int32_t stack[kMaxBvh4Stack];
    int sp = 0;
    int32_t index = 0;
    while (true) {
        const Bvh4Node& node = bvh4_[size_t(index)];
        for (int i = 0; i < 4; ++i) {
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
}

bool Scene::occluded_by(std::vector<BundleCandidate>& candidates, const Ray& ray, double t_min, double t_max) const {
    const Vec3 inv{1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z};
    std::optional<WatertightRay> wr;  // only when a triangle is tested
    for (size_t k = 0; k < candidates.size(); ++k) {
        const BundleCandidate& box = candidates[k];
        double t_entry;
        if (!hit_node(box, ray.origin, inv, t_min, t_max, t_entry)) continue;
        double t;
        bool hit;
        if (box.ref >= 0) {
            Barycentric bary;
            hit = hit_triangle(box.ref, ray, wr, t_min, t_max, t, bary);
        } else {
            // ray.origin is the bundle's apex, whose object-space form the candidate holds.
            hit = intersect_sphere(spheres[size_t(~box.ref)], box.sphere_origin, ray.dir, t_min, t_max, t);
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

void Scene::occluded_by_each(const std::vector<BundleCandidate>& candidates, const Vec3& origin, const Vec3* dirs,
                             const double* distances, size_t count, double t_min, unsigned char* blocked) const {
    std::fill(blocked, blocked + count, 0);
    if (candidates.empty() || count == 0) return;
    // Rays in pairs, for the sphere test (intersect_sphere_pair) and hit_node()'s box test in the
    // two lanes of SSE2 doubles: per lane the same operations in the same order (IEEE products
    // and differences, maxpd/minpd with hit_node's operand order, so NaN is ignored as there),
    // hence the same decisions. Per ray,
    // once: the reciprocal direction and t_max, in lanes (an odd count repeats the last ray in
    // a lane whose result is dropped); and the watertight set-up when a triangle is tested that
    // way (occluded_by() makes the same ones, per ray).
    const size_t pairs = (count + 1) / 2, padded = 2 * pairs;
    thread_local std::vector<double> lanes;
    lanes.resize(7 * padded);
    double* const inverse[3] = {lanes.data(), lanes.data() + padded, lanes.data() + 2 * padded};
    double* const t_max = lanes.data() + 3 * padded;
    double* const dir[3] = {lanes.data() + 4 * padded, lanes.data() + 5 * padded, lanes.data() + 6 * padded};
    for (size_t k = 0; k < padded; ++k) {
        const size_t ray = k < count ? k : count - 1;
        t_max[k] = distances[ray] - t_min;
        dir[0][k] = dirs[ray].x;
        dir[1][k] = dirs[ray].y;
        dir[2][k] = dirs[ray].z;
    }
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
        for (size_t k = 0; k < count; ++k) sheared.emplace_back(dirs[k]);
    }
    const __m128d widening = _mm_set1_pd(kSlabFarWidening), t_min_lanes = _mm_set1_pd(t_min);
    const double o[3] = {origin.x, origin.y, origin.z};
    size_t open = count;  // rays not yet blocked: none left, no candidate need be tested
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
            const SphereShape& sphere = spheres[size_t(~box.ref)];
            for (size_t first = 0; first < count; first += 2) {
                const int open_lanes = (blocked[first] ? 0 : 1) | (first + 1 < count && !blocked[first + 1] ? 2 : 0);
                if (open_lanes == 0) continue;
                const int hits = open_lanes & intersect_sphere_pair(sphere, box.sphere_origin, _mm_loadu_pd(dir[0] + first),
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
            __m128d t0 = t_min_lanes, t1 = _mm_loadu_pd(t_max + first);
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
                const Ray ray{origin, dirs[k]};
                double t;
                Barycentric bary;
                const bool hit = watertight
                                     ? intersect_triangle(triangles[size_t(box.ref)], ray, sheared[k], t_min, t_max[k], t, bary)
                                     : intersect_povray_triangle(povray_triangles[size_t(box.ref)], ray, t_min, t_max[k], t, bary);
                if (hit) hits |= 1 << lane;
            }
            if (block(first, hits)) return;
        }
    }
}

int Scene::count_hits(const Ray& ray, double t_min, double t_max, double& t_closest) const {
    const WatertightRay wr(ray.dir);
    int count = 0;
    t_closest = HUGE_VAL;
    for (const SphereShape& s : spheres) {
        double t;
        if (intersect_sphere(s, ray, t_min, t_max, t)) { ++count; t_closest = std::fmin(t_closest, t); }
    }
    for (size_t k = 0; k < triangles.size(); ++k) {
        double t;
        Barycentric bary;
        if (intersect_triangle(triangles[k], ray, wr, t_min, t_max, t, bary)) { ++count; t_closest = std::fmin(t_closest, t); }
    }
    return count;
}

}  // namespace phong
