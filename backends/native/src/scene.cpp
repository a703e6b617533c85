// SPDX-License-Identifier: Apache-2.0
// Scene construction from flat geometry arrays, materials and lights, and the single-ray BVH queries
// (shadow-ray bundles: shadow_bundles.cpp).
#include "scene.hpp"

#include "build_threads.hpp"
#include "bvh8_group.hpp"
#include "closest_search.hpp"
#include "huge_pages.hpp"
#include "simd_dispatch.hpp"
#include "triangle_prefilter.hpp"

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

[[noreturn]] __attribute__((noinline, cold)) void index_out_of_range(int64_t i, size_t count, const char* what) {
    throw std::invalid_argument(std::string(what) + " index " + std::to_string(i) + " out of range [0, " +
                                std::to_string(count) + ")");
}

// The test inline, the message out of line: it runs for every corner of every triangle.
inline void check_index(int64_t i, size_t count, const char* what) {
    if (i < 0 || size_t(i) >= count) index_out_of_range(i, count, what);
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

// The leaf-order copy's prefetch distances (positions ahead of the one being copied): the index
// triple first, its points once the triple has arrived. Tuned on S2 (benchmarks/README.md).
constexpr size_t kCopyIndexAhead = 32;
constexpr size_t kCopyPointAhead = 16;

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
    // Flat normals kept for the meshes without vertex normals, in input order, while their
    // triangles fit kMaxCachedFlatNormals (flat_normal()).
    flat_normal_row_.assign(n_meshes, -1);
    size_t cached = 0;
    for (size_t m = 0; m < n_meshes; ++m) {
        const MeshArrays& mesh = in.meshes[m];
        if (mesh.normal_indices || mesh.triangle_count == 0 || cached + mesh.triangle_count > kMaxCachedFlatNormals)
            continue;
        flat_normal_row_[m] = int64_t(cached);
        cached += mesh.triangle_count;
    }
    flat_normals_.resize(cached);
    std::vector<std::pair<const double*, size_t>> mesh_normals;
    for (const MeshArrays& mesh : in.meshes) mesh_normals.emplace_back(mesh.normals, mesh.normal_count);
    normals.assign(mesh_normals);
    // The mesh of triangle i (global number): looked up once per chunk (then stepped) in the
    // pass below, per triangle in the leaf-order pass.
    auto mesh_of = [&](size_t i) {
        return size_t(std::upper_bound(first_triangle.begin() + 1, first_triangle.end(), i) - first_triangle.begin() -
                      1);
    };

    const size_t n_spheres = in.sphere_count, n_triangles = first_triangle[n_meshes];
    // Intrinsic parts: the bounded ones join the BVH after the triangles (ids S + T + q), the
    // unbounded planes stay out of it and out of `bounds` (which the scale-aware tolerances come
    // from: an infinite ground must not make them coarse).
    for (const IntrinsicShape& part : in.intrinsics) {
        check_index(part.material, materials.size(), "intrinsic material");
        (part.kind == IntrinsicKind::kPlane ? planes : intrinsics).push_back(part);
    }
    const size_t n_intrinsics = intrinsics.size();
    // Balls (Points sets) join after the intrinsic parts (ids S + T + I + row), so that a scene
    // without them builds the same tree as before they existed.
    size_t n_balls = 0;
    for (const GeometryArrays::Balls& set : in.balls) {
        check_index(set.material, materials.size(), "points material");
        ball_groups.push_back({n_balls, set.material, set.object});
        n_balls += set.count;
    }
    const size_t first_ball_id = n_spheres + n_triangles + n_intrinsics;
    PrimRefs prims;
    resize_huge(prims, first_ball_id + n_balls);
    for (size_t q = 0; q < n_intrinsics; ++q) {
        Bounds b;
        b.lo = intrinsics[q].bounds_lo;
        b.hi = intrinsics[q].bounds_hi;
        bounds.grow(b);
        prims[n_spheres + n_triangles + q] = PrimRef(b, uint32_t(n_spheres + n_triangles + q));
    }
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
    // A ball's box as a sphere's: centre ± sqrt(r²) = r (ball_sphere).
    auto ball_bounds = [](const double* c, double r) {
        Bounds b;
        b.lo = {c[0] - r, c[1] - r, c[2] - r};
        b.hi = {c[0] + r, c[1] + r, c[2] + r};
        return b;
    };
    for (size_t g = 0; g < in.balls.size(); ++g) {
        const GeometryArrays::Balls& set = in.balls[g];
        const size_t first = ball_groups[g].first;
        for_chunks(set.count, [&](size_t begin, size_t end) {
            Bounds chunk_bounds;
            for (size_t i = begin; i < end; ++i) {
                const Bounds b = ball_bounds(set.centers + 3 * i, set.radii[i]);
                chunk_bounds.grow(b);
                prims[first_ball_id + first + i] = PrimRef(b, uint32_t(first_ball_id + first + i));
            }
            const std::lock_guard<std::mutex> lock(bounds_mutex);
            bounds.grow(chunk_bounds);
        });
    }
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
    // Float corners when every vertex is a float (triangle_store.hpp): the same doubles.
    bool every_vertex_float = !in.povray_triangles;
    for (const MeshArrays& mesh : in.meshes)
        for (size_t i = 0; i < 3 * mesh.point_count && every_vertex_float; ++i)
            every_vertex_float = float_exact(mesh.points[i]);
    // Leaves of triangles alone, which the float prefilter will test eight at a time (the AVX2
    // walk over float corners: prefilter_applies below), are built up to eight (bvh.cpp).
    LaneIds lanes;
    if (use_avx2() && every_vertex_float && n_triangles >= size_t(kMinPrefilterLeaf))
        lanes = {uint32_t(n_spheres), uint32_t(n_spheres + n_triangles)};
    // The build consumes (and frees) the primitive boxes before the leaf-order copies below are
    // allocated.
    bvh_.build(std::move(prims), lanes);
#if defined(__GLIBC__)
    // The freed primitive boxes (30 MiB at 1M triangles) stay resident in glibc's heap, under
    // the collapse and the copies below, unless handed back: S2's peak 300 -> 286 MiB
    // (benchmarks/memory_stages.py; benchmarks/README.md).
    malloc_trim(0);
#endif
    // The rays walk the 4-wide tree; the binary one's nodes are freed once it is collapsed.
    // (Or the 8-wide tree where the CPU has AVX2: every walk takes it then.)
    if (use_avx2())
        bvh8_ = collapse_to_bvh8(bvh_.nodes);
    else
        bvh4_ = collapse_to_bvh4(bvh_.nodes);
    BvhNodes().swap(bvh_.nodes);

    // Primitive refs and triangle data in leaf order, so leaves read memory sequentially.
    // Leaf position k holds triangle slot k − (spheres before k).
    const auto& order = bvh_.order;
    // (Positions of every primitive that is not a triangle: spheres and intrinsic parts.)
    // (Scanned for only when there are any: on a scene of triangles alone, S2, the scan of 1M
    // positions found none in ~1 ms while the other build thread waited.)
    std::vector<uint32_t> sphere_positions;
    if (order.size() > n_triangles)
        for (size_t k = 0; k < order.size(); ++k)
            if (order[k] < n_spheres || order[k] >= n_spheres + n_triangles) sphere_positions.push_back(uint32_t(k));
    resize_huge(refs_, order.size());
    if (in.povray_triangles) {
        // POV-Ray's numerics: the corners in their meshes' frames, as its mesh2 holds them
        // (triangle_store.hpp), and the world doubles only if those do not give them back.
        std::vector<Vec3> origins;
        bool every_point_recovered = true;
        for (const MeshArrays& mesh : in.meshes) {
            origins.push_back(mesh.origin);
            for (size_t i = 0; i < mesh.point_count && every_point_recovered; ++i)
                every_point_recovered = recovered_from_mesh_frame(mesh.points + 3 * i, mesh.origin);
        }
        triangles.resize_mesh_local(n_triangles, std::move(origins), !every_point_recovered);
    } else {
        // In lanes only where the prefilter can run (prefilter_applies); elsewhere in rows.
        triangles.resize(n_triangles, every_vertex_float, !bvh8_.empty() && n_triangles >= size_t(kMinPrefilterLeaf));
    }
    bool any_vertex_normals = false;
    for (const MeshArrays& mesh : in.meshes) any_vertex_normals = any_vertex_normals || mesh.normal_indices;
    if (any_vertex_normals) resize_huge(triangle_normals, n_triangles);
    resize_huge(triangle_source, n_triangles);
    if (in.povray_triangles) resize_huge(povray_triangles, n_triangles);
    // Leaf order is spatial, not the meshes' order: each triangle's indices, points and normal
    // indices are random reads. Two prefetch stages hide them: the index triple kCopyIndexAhead
    // positions ahead, the three points it names kCopyPointAhead ahead (their indices have
    // arrived by then).
    // The mesh of triangle i, from `m` (a guess, updated): that of a triangle near it in leaf
    // order, mostly the same mesh, so the binary search runs only when i lies outside it (S2,
    // two meshes: three searches a triangle were ~3 % of its build's instructions).
    auto mesh_near = [&](size_t i, size_t& m) {
        if (i < first_triangle[m] || i >= first_triangle[m + 1]) m = mesh_of(i);
        return m;
    };
    auto triangle_at = [&](size_t k, const MeshArrays*& mesh, size_t& local, size_t& guess) {
        const uint32_t id = order[k];
        if (id < n_spheres || id >= n_spheres + n_triangles) return false;
        const size_t i = id - n_spheres, m = mesh_near(i, guess);
        mesh = &in.meshes[m];
        local = i - first_triangle[m];
        return true;
    };
    auto prefetch_ahead = [&](size_t k, size_t end, size_t& index_guess, size_t& point_guess) {
        const MeshArrays* mesh;
        size_t local;
        if (k + kCopyIndexAhead < end && triangle_at(k + kCopyIndexAhead, mesh, local, index_guess)) {
            __builtin_prefetch(mesh->triangles + 3 * local);
            if (mesh->normal_indices) __builtin_prefetch(mesh->normal_indices + 3 * local);
        }
        if (k + kCopyPointAhead < end && triangle_at(k + kCopyPointAhead, mesh, local, point_guess)) {
            const int32_t* t = mesh->triangles + 3 * local;
            for (int c = 0; c < 3; ++c) __builtin_prefetch(mesh->points + 3 * size_t(t[c]));
        }
    };
    for_chunks(order.size(), [&](size_t begin, size_t end) {
        size_t spheres_before =
            size_t(std::lower_bound(sphere_positions.begin(), sphere_positions.end(), uint32_t(begin)) -
                   sphere_positions.begin());
        size_t index_guess = 0, point_guess = 0, mesh_guess = 0;  // meshes (mesh_near)
        for (size_t k = begin; k < end; ++k) {
            prefetch_ahead(k, end, index_guess, point_guess);
            const uint32_t id = order[k];
            if (id < n_spheres) {
                refs_[k] = ~int32_t(id);
                ++spheres_before;
                continue;
            }
            if (id >= first_ball_id) {  // a ball: its ref is set below
                ++spheres_before;
                continue;
            }
            if (id >= n_spheres + n_triangles) {  // an intrinsic part
                refs_[k] = ~int32_t(n_spheres + n_balls + (id - n_spheres - n_triangles));
                ++spheres_before;
                continue;
            }
            const size_t i = id - n_spheres, slot = k - spheres_before;
            const size_t m = mesh_near(i, mesh_guess);
            const MeshArrays& mesh = in.meshes[m];
            const size_t local = i - first_triangle[m];
            const int32_t* t = mesh.triangles + 3 * local;
            refs_[k] = int32_t(slot);
            const TriangleShape corners{row3(mesh.points + 3 * size_t(t[0])), row3(mesh.points + 3 * size_t(t[1])),
                                        row3(mesh.points + 3 * size_t(t[2]))};
            if (in.povray_triangles) {
                const LocalTriangle local = to_mesh_frame(corners, mesh.origin, uint32_t(m));
                triangles.set_local(slot, local, corners);
                povray_triangles[slot] = make_povray_triangle(local);
            } else {
                triangles.set(slot, corners);
            }
            if (flat_normal_row_[m] >= 0)  // from the corners as stored, as a hit reads them
                flat_normals_[size_t(flat_normal_row_[m]) + local] = flat_triangle_normal(triangles[slot]);
            if (any_vertex_normals) {
                TriangleNormals sh{-1, -1, -1};
                if (mesh.normal_indices && mesh.normal_indices[3 * local] >= 0) {
                    const int32_t* n = mesh.normal_indices + 3 * local;
                    const int32_t offset = int32_t(first_normal[m]);
                    sh.n0 = n[0] + offset;
                    sh.n1 = n[1] + offset;
                    sh.n2 = n[2] + offset;
                }
                triangle_normals[slot] = sh;
            }
            triangle_source[slot] = uint32_t(i);
        }
    });
    // The balls in leaf order (one pass: a ball's slot is the number of balls before it).
    balls.resize(n_balls);
    ball_source.resize(n_balls);
    size_t ball = 0, group = 0;  // group: the set of the last ball seen (neighbours share it)
    for (size_t k = 0; k < (n_balls > 0 ? order.size() : 0); ++k) {  // (no 1M-position scan for none)
        const uint32_t id = order[k];
        if (id < first_ball_id) continue;
        const size_t row = id - first_ball_id;
        if (row >= ball_groups[group].first + in.balls[group].count)  // rows ascend within a set's run
            group = size_t(std::upper_bound(ball_groups.begin() + 1, ball_groups.end(), row,
                                            [](size_t r, const BallGroup& g) { return r < g.first; }) -
                           ball_groups.begin() - 1);
        else if (row < ball_groups[group].first)
            group = size_t(std::upper_bound(ball_groups.begin() + 1, ball_groups.end(), row,
                                            [](size_t r, const BallGroup& g) { return r < g.first; }) -
                           ball_groups.begin() - 1);
        const GeometryArrays::Balls& set = in.balls[group];
        const size_t local = row - ball_groups[group].first;
        balls[ball] = {row3(set.centers + 3 * local), set.radii[local]};
        ball_source[ball] = uint32_t(row);
        refs_[k] = ~int32_t(n_spheres + ball);
        ++ball;
    }
    bvh_.order.clear();
    bvh_.order.shrink_to_fit();
    first_triangle_ = std::move(first_triangle);
    mesh_material_.resize(n_meshes);
    for (size_t m = 0; m < n_meshes; ++m) mesh_material_[m] = in.meshes[m].material;
    prefilter_ = !bvh8_.empty() && triangles.lanes() && povray_triangles.empty() &&
                 triangles.size() >= size_t(kMinPrefilterLeaf);
    mixed_leaves_ = !spheres.empty() || !balls.empty() || !intrinsics.empty();
    // POV-Ray's triangles (their own test, mesh-frame corners) keep the tree, as the SSE2 path does.
    if (!bvh8_.empty() && povray_triangles.empty() && balls.empty() && intrinsics.empty() &&
        SmallScene::fits(spheres, triangles.size()))
        small_ = std::make_unique<const SmallScene>(spheres, triangles);
}

void Scene::add_instances(std::unique_ptr<Scene> prototype, const double* world_from_prototype, size_t count,
                          bool rebuild, const double* colors) {
    if (!instances) instances = std::make_unique<InstanceLayer>();
    instances->add(std::move(prototype), world_from_prototype, count, rebuild, colors);
    bounds.grow(instances->bounds);
}

int32_t Scene::triangle_mesh_searched(size_t slot) const {
    const size_t i = triangle_source[slot];
    return int32_t(std::upper_bound(first_triangle_.begin() + 1, first_triangle_.end(), i) - first_triangle_.begin() -
                   1);
}

int64_t Scene::primitive_id(int32_t ref) const {
    // Python's numbering: spheres, triangles, then intrinsic parts (unbounded planes last).
    if (is_sphere(ref)) return int64_t(~ref);
    if (is_ball(ref))
        return int64_t(spheres.size() + triangle_source.size() + intrinsics.size() + planes.size()) +
               ball_source[ball_index(ref)];
    if (ref < 0) return int64_t(triangle_source.size()) + int64_t(~ref) - int64_t(balls.size());
    return int64_t(spheres.size()) + triangle_source[size_t(ref)];
}

bool Scene::closest_hit(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max, Hit& hit) const {
    ClosestSearch search(*this, ray, t_min, t_max, hit);
    if (small()) {
        closest_small(ray, search);
        return search.finish(t_max);
    }
    if (prefilter_applies()) {
        // Only the triangles the float prefilter keeps (triangle_prefilter.hpp). The leaf is
        // compiled for AVX2 with the prefilter and the tests inlined: GCC inlines no default-target
        // function into a target("avx2") one unless made to (always_inline on `test`, flatten
        // here); out of line they cost S2 more than the prefilter saves (benchmarks/README.md).
        TriangleLeafFilter filter(triangles, magnitude, mixed_leaves());
        auto leaf = [&](int32_t first, int count, double&) PHONG_AVX2 __attribute__((flatten)) {
            const int32_t* refs = refs_.data() + first;
            for (unsigned kept = filter(refs, first, count, ray, search.wr); kept != 0; kept &= kept - 1)
                search.test(leaf_ref(first + int32_t(__builtin_ctz(kept))));
            return false;
        };
        traverse_bvh8<true>(bvh8_, magnitude, ray, origin, t_min, search.t_cull, leaf);
    } else {
        auto leaf = [&](int32_t first, int count, double&) {
            for (int k = 0; k < count; ++k) search.test(refs_[size_t(first + k)]);
            return false;
        };
        if (!bvh8_.empty())
            traverse_bvh8<true>(bvh8_, magnitude, ray, origin, t_min, search.t_cull, leaf);
        else
            traverse_bvh4<true>(bvh4_, magnitude, ray, origin, t_min, search.t_cull, leaf);
    }
    return search.finish(t_max);
}

PHONG_AVX2 bool Scene::occluded_small(const Ray& ray, double t_min, double t_max) const {
    alignas(32) double inv[4];
    SmallScene::reciprocals(ray, inv);  // first: see reciprocals()
    const unsigned spheres_left = small_->sphere_candidates(ray, t_min);
    const unsigned triangles_left = small_->box_candidates(ray, inv, t_min);
    if ((spheres_left | triangles_left) != 0 && occluded_exactly(ray, spheres_left, triangles_left, t_min, t_max))
        return true;
    double t;
    int32_t plane;
    return !planes.empty() && hit_planes(ray, t_min, t_max, t, plane);
}

PHONG_AVX2 RayBits Scene::occluded_small_each(const Ray* rays, int count, double t_min, const double* t_max) const {
    assert(count >= 0 && count <= kMaxRaysTogether);
    alignas(32) double inv[kMaxRaysTogether][4];
    unsigned spheres_left[kMaxRaysTogether], triangles_left[kMaxRaysTogether];
    for (int i = 0; i < count; ++i) SmallScene::reciprocals(rays[i], inv[i]);
    for (int i = 0; i < count; ++i) spheres_left[i] = small_->sphere_candidates(rays[i], t_min);
    for (int i = 0; i < count; ++i) triangles_left[i] = small_->box_candidates(rays[i], inv[i], t_min);
    RayBits blocked = 0;
    for (int i = 0; i < count; ++i) {  // occluded_small's tail
        bool hit = (spheres_left[i] | triangles_left[i]) != 0 &&
                   occluded_exactly(rays[i], spheres_left[i], triangles_left[i], t_min, t_max[i]);
        double t;
        int32_t plane;
        if (!hit) hit = !planes.empty() && hit_planes(rays[i], t_min, t_max[i], t, plane);
        blocked |= RayBits(hit) << i;
    }
    return blocked;
}

// Out of line: most shadow rays of a small scene reject every primitive in lanes, and the
// registers these loops and calls keep cost each of them a frame (~26 instructions of S1's).
[[gnu::noinline]] bool Scene::occluded_exactly(const Ray& ray, unsigned spheres_left, unsigned triangles_left,
                                               double t_min, double t_max) const {
    for (unsigned k = spheres_left; k != 0; k &= k - 1) {
        double t;
        if (intersect_sphere(spheres[size_t(__builtin_ctz(k))], ray, t_min, t_max, t)) return true;
    }
    std::optional<WatertightRay> wr;
    for (unsigned k = triangles_left; k != 0; k &= k - 1) {
        double t;
        Barycentric bary;
        if (hit_triangle(int32_t(__builtin_ctz(k)), ray, wr, t_min, t_max, t, bary)) return true;
    }
    return false;
}

PHONG_AVX2 void Scene::closest_small(const Ray& ray, ClosestSearch& search) const {
    alignas(32) double inv[4];
    SmallScene::reciprocals(ray, inv);
    for (unsigned k = small_->sphere_candidates(ray, search.t_min); k != 0; k &= k - 1)
        search.test(~int32_t(__builtin_ctz(k)));
    for (unsigned k = small_->box_candidates(ray, inv, search.t_min); k != 0; k &= k - 1)
        search.test(int32_t(__builtin_ctz(k)));
}

bool Scene::occluded_tree(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max) const {
    std::optional<WatertightRay> wr;  // set up when the first triangle is tested
    bool blocked = false;
    double t_limit = t_max;
    auto test = [&](int32_t ref, double t_best) __attribute__((always_inline)) {
        double t;
        if (ref < 0) return hit_solid(ref, ray, t_min, t_best, t);
        Barycentric bary;
        return hit_triangle(ref, ray, wr, t_min, t_best, t, bary);
    };
    if (prefilter_applies()) {
        // Only the triangles the float prefilter keeps, inlined as in closest_hit.
        TriangleLeafFilter filter(triangles, magnitude, mixed_leaves());
        auto leaf = [&](int32_t first, int count, double& t_best) PHONG_AVX2 __attribute__((flatten)) {
            const int32_t* refs = refs_.data() + first;
            for (unsigned kept = filter(refs, first, count, ray, wr); kept != 0; kept &= kept - 1)
                if (test(leaf_ref(first + int32_t(__builtin_ctz(kept))), t_best))
                    return blocked = true;  // the first hit ends the walk
            return false;
        };
        traverse_bvh8<false>(bvh8_, magnitude, ray, origin, t_min, t_limit, leaf);
    } else {
        auto leaf = [&](int32_t first, int count, double& t_best) {
            for (int k = 0; k < count; ++k)
                if (test(refs_[size_t(first + k)], t_best)) return blocked = true;  // the first hit ends the walk
            return false;
        };
        if (!bvh8_.empty())
            traverse_bvh8<false>(bvh8_, magnitude, ray, origin, t_min, t_limit, leaf);
        else
            traverse_bvh4<false>(bvh4_, magnitude, ray, origin, t_min, t_limit, leaf);
    }
    if (!blocked && !planes.empty()) {
        double t;
        int32_t plane;
        blocked = hit_planes(ray, t_min, t_max, t, plane);
    }
    return blocked || (!instances_empty() && instances->occluded(ray, t_min, t_max));
}

static_assert(kMaxRaysTogether <= FloatSlabLanes::kRays && kMaxRaysTogether % 8 == 0);

PHONG_AVX2 RayBits Scene::occluded_tree_each(const Ray* rays, int count, double t_min, const double* t_max) const {
    assert(count >= 1 && count <= kMaxRaysTogether && !bvh8_.empty());
    // Each ray's own walk state, as occluded_tree sets it up.
    Deferred<FloatSlabOrigin> origin[kMaxRaysTogether];
    Deferred<TriangleLeafFilter> filter[kMaxRaysTogether];
    std::optional<WatertightRay> wr[kMaxRaysTogether];
    // The rays' float slab numbers, four at a time (FloatSlabLanes: each ray's own).
    FloatSlabLanes lanes;
    lanes.set_up(rays, count, t_min, t_max, magnitude);
    // Rays the interval bound covers walk in groups (bvh8_group.hpp); the others (outside the
    // float test's range, or with a direction component so small its float inverse is not
    // finite) walk alone, each as occluded_tree.
    const RayBits together = lanes.applies & lanes.bounded;
    RayBits blocked = 0;
    for (int r = 0; r < count; ++r) {
        if (!(together >> r & 1u)) {
            origin[r].emplace(rays[r].origin);
            blocked |= RayBits(occluded_tree(rays[r], *origin[r], t_min, t_max[r])) << r;
        }
    }
    for (RayBits bits = together; bits != 0; bits &= bits - 1)
        filter[__builtin_ctzll(bits)].emplace(triangles, magnitude, mixed_leaves());
    const bool prefilter = prefilter_applies();
    // The leaf of `count` refs at `first` for ray r: occluded_tree's leaf.
    auto leaf_blocks = [&](int r, int32_t first, int n) PHONG_AVX2 __attribute__((always_inline)) {
        const Ray& ray = rays[r];
        const int32_t* refs = refs_.data() + first;
        auto test = [&](int32_t ref) __attribute__((always_inline)) {
            double t;
            if (ref < 0) return hit_solid(ref, ray, t_min, t_max[r], t);
            Barycentric bary;
            return hit_triangle(ref, ray, wr[r], t_min, t_max[r], t, bary);
        };
        if (prefilter) {
            for (unsigned kept = (*filter[r])(refs, first, n, ray, wr[r]); kept != 0; kept &= kept - 1)
                if (test(leaf_ref(first + int32_t(__builtin_ctz(kept))))) return true;
            return false;
        }
        for (int k = 0; k < n; ++k)
            if (test(refs[k])) return true;
        return false;
    };
    // The rays whose directions' signs agree on every axis walk as one group (all of a coherent
    // group's rays, most often): each ray tests every leaf its own walk would, and only leaves
    // its own box test enters (bvh8_group.hpp), so its any-hit answer is its own walk's.
    auto leaf = [&](RayBits testing, int32_t first, int n) PHONG_AVX2 __attribute__((always_inline)) {
        RayBits blocks = 0;
        for (; testing != 0; testing &= testing - 1) {
            const int r = __builtin_ctzll(testing);
            if (leaf_blocks(r, first, n)) blocks |= RayBits(1) << r;
        }
        return blocks;
    };
    for (RayBits rest = together; rest != 0;) {
        const int first = __builtin_ctzll(rest);
        RayBits same_signs = rest;
        for (int k = 0; k < 3; ++k)
            same_signs &= lanes.negative[k] >> first & 1u ? lanes.negative[k] : ~lanes.negative[k];
        rest &= ~same_signs;
        const RaySetLanes in(same_signs);
        FloatSlabGroup8 group;
        group.set_up(lanes, same_signs, in);
        blocked |= traverse_bvh8_group(bvh8_, group, same_signs, leaf);
    }
    for (int r = 0; r < count; ++r) {  // occluded_tree's tail
        if ((blocked >> r & 1u) || !(together >> r & 1u)) continue;
        double t;
        int32_t plane;
        if ((!planes.empty() && hit_planes(rays[r], t_min, t_max[r], t, plane)) ||
            (!instances_empty() && instances->occluded(rays[r], t_min, t_max[r])))
            blocked |= RayBits(1) << r;
    }
    return blocked;
}

int Scene::count_hits(const Ray& ray, double t_min, double t_max, double& t_closest) const {
    const WatertightRay wr(ray.dir);
    int count = 0;
    t_closest = HUGE_VAL;
    for (const SphereShape& s : spheres) {
        double t;
        if (intersect_sphere(s, ray, t_min, t_max, t)) {
            ++count;
            t_closest = std::fmin(t_closest, t);
        }
    }
    for (const BallShape& b : balls) {
        double t;
        if (intersect_ball(b, ray, t_min, t_max, t)) {
            ++count;
            t_closest = std::fmin(t_closest, t);
        }
    }
    for (size_t k = 0; k < triangles.size(); ++k) {
        double t;
        Barycentric bary;
        if (intersect_triangle(triangles[k], ray, wr, t_min, t_max, t, bary)) {
            ++count;
            t_closest = std::fmin(t_closest, t);
        }
    }
    for (const std::vector<IntrinsicShape>* parts : {&intrinsics, &planes})
        for (const IntrinsicShape& part : *parts) {
            double t;
            if (intersect_intrinsic(part, ray, t_min, t_max, t)) {
                ++count;
                t_closest = std::fmin(t_closest, t);
            }
        }
    return count;
}

}  // namespace phong
