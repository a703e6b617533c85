// SPDX-License-Identifier: Apache-2.0
// The C++ scene: flat geometry arrays, materials and lights from Python
// (phongscene.backends.native) turned into shapes and one BVH over every primitive; closest-hit
// and any-hit queries.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "bvh.hpp"
#include "bvh4.hpp"
#include "bvh8.hpp"
#include "instances.hpp"
#include "intrinsics.hpp"
#include "lights.hpp"
#include "materials.hpp"
#include "math.hpp"
#include "povray_triangle.hpp"
#include "shapes.hpp"
#include "small_scene.hpp"
#include "environment.hpp"
#include "textures.hpp"
#include "triangle_prefilter.hpp"
#include "triangle_store.hpp"

namespace phong {

// The most flat-shaded triangles whose normals a Scene keeps (24 bytes each: 96 KiB), for the
// meshes without vertex normals in input order while they fit. A flat triangle's shading normal
// is otherwise its corners read back and a cross product normalised at every hit (~5 % of S1's
// and ~3 % of S2's render, whose ground quad takes most hits: benchmarks/README.md, issue 25).
// Kept for small meshes only: a triangle of a big flat mesh is hit about once, and its normal
// kept would cost the build what a hit saves, and memory besides.
constexpr size_t kMaxCachedFlatNormals = 4096;

// Borrowed views of one mesh's Python arrays (row-major, C-contiguous): the model's own arrays,
// not concatenated copies.
struct MeshArrays {
    const double* points = nullptr;  // (V, 3)
    size_t point_count = 0;
    const int32_t* triangles = nullptr;  // (T, 3) rows of points
    size_t triangle_count = 0;
    const double* normals = nullptr;  // (K, 3) unit
    size_t normal_count = 0;
    const int32_t* normal_indices = nullptr;  // (T, 3) rows of normals, -1: flat; nullptr: all flat
    int32_t material = 0;                     // index of the mesh's material
    Vec3 origin;                              // the mesh's local frame, as the compiler writes it
};

// Borrowed views of the Python arrays of the geometry.
struct GeometryArrays {
    const double* sphere_world_from_object = nullptr;  // (S, 4, 4)
    const double* sphere_object_from_world = nullptr;  // (S, 4, 4)
    const int32_t* sphere_material = nullptr;          // (S,) indices of materials
    size_t sphere_count = 0;
    std::vector<MeshArrays> meshes;  // each one POV-Ray object; triangles are numbered in this order
    bool povray_triangles = false;   // test triangles as POV-Ray does (povray_triangle.hpp)
    // The intrinsic prims' parts (intrinsics.hpp), bounds filled in by the Scene; unbounded
    // planes among them go to Scene::planes.
    std::vector<IntrinsicShape> intrinsics;
    // Points sets (BallShape), each its own arrays: (N, 3) centres and (N,) radii, one material
    // and one object (LightLinking's numbering).
    struct Balls {
        const double* centers = nullptr;
        const double* radii = nullptr;
        size_t count = 0;
        int32_t material = 0;
        int32_t object = 0;
    };
    std::vector<Balls> balls;
};

// A Points set in the Scene: its balls are input rows [first, next set's first), and where they
// sit in Scene::balls (leaf order) ball_source says.
struct BallGroup {
    size_t first;
    int32_t material;
    int32_t object;
};

// A ray's closest hit. ref >= 0: triangle index (leaf order); ref < 0: sphere ~ref when
// ~ref < S, ball ~ref − S (Scene::balls, leaf order) when ~ref < S + B, else intrinsic part
// ~ref − S − B (Scene::intrinsics), or an unbounded plane (Scene::plane_ref).
// Rays Scene::occluded_each takes at once (a light's shadow rays from two packets' 64 points).
constexpr int kMaxRaysTogether = 64;
// A bit per ray of the rays taken together.
using RayBits = uint64_t;

struct Hit {
    double t;
    int32_t ref;
    Barycentric bary;
    int32_t instance = -1;  // >= 0: the hit is on this instance (InstanceLayer), ref in its prototype
};

// A candidate occluder of a shadow-ray bundle (Scene::shadow_candidates): the primitive's
// bounds rounded outward like a BVH node's, and for a sphere the bundle's shared origin in its
// object space.
struct BundleCandidate {
    float lo[3], hi[3];
    int32_t ref;  // as Hit::ref
    SphereOrigin sphere_origin;
};

// A light's UsdLux shadow switch and linking (model: phongscene.scene.Linking), by object:
// spheres 0..S-1, then meshes S + m. Empty vectors: every object.
struct LightLinking {
    bool shadows = true;               // inputs:shadow:enable: false traces no shadow ray
    std::vector<unsigned char> lit;    // collection:lightLink: 1 = the light illuminates the object
    std::vector<unsigned char> casts;  // collection:shadowLink: 1 = the object casts its shadows
};

class Scene {
  public:
    // Copies the arrays and builds the BVH. Throws std::invalid_argument on indices out of
    // range and on area lights with fewer than 2 samples per axis (Python validates scenes;
    // this only guards against a crash or a meaningless image).
    Scene(const GeometryArrays& geometry, std::vector<Material> materials, std::vector<Light> lights,
          const RGB& ambient);

    bool closest_hit(const Ray& ray, double t_min, double t_max, Hit& hit) const {
        return closest_hit(ray, FloatSlabOrigin(ray.origin), t_min, t_max, hit);
    }
    bool occluded(const Ray& ray, double t_min, double t_max) const {
        if (small()) return occluded_small(ray, t_min, t_max);
        return occluded_tree(ray, FloatSlabOrigin(ray.origin), t_min, t_max);
    }
    // Bit i set where occluded(rays[i], t_min, t_max[i]), for count <= kMaxRaysTogether rays (a light's shadow
    // rays from a packet's points, lane_shading.hpp). In a small scene their lane tests run one
    // after the other with no branch between, so the CPU overlaps their latency chains.
    RayBits occluded_each(const Ray* rays, int count, double t_min, const double* t_max) const {
        if (small()) return occluded_small_each(rays, count, t_min, t_max);
        if (count >= 2 && !bvh8_.empty()) return occluded_tree_each(rays, count, t_min, t_max);
        RayBits blocked = 0;
        for (int i = 0; i < count; ++i) blocked |= RayBits(occluded(rays[i], t_min, t_max[i])) << i;
        return blocked;
    }
    // The same, for rays whose shared origin is rounded once: `origin` is FloatSlabOrigin(ray.origin).
    bool closest_hit(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max, Hit& hit) const;
    // (Inline, the small scene's branch first: behind the tree walk's frame it cost a shadow ray
    // of S1 ~40 instructions.)
    bool occluded(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max) const {
        if (small()) return occluded_small(ray, t_min, t_max);
        return occluded_tree(ray, origin, t_min, t_max);
    }
    // closest_hit(ray, origin, t_min, HUGE_VAL) for `count` <= kPacketRays rays that share their
    // origin (a perspective camera's primary rays of a block of pixels): found[k] and hits[k] are
    // ray k's, bit for bit what closest_hit() gives it. The rays walk the 8-wide tree together
    // where their directions allow (ray_packets.cpp; then it returns true), else one by one.
    bool closest_hit_packet(const Ray* rays, int count, const FloatSlabOrigin& origin, double t_min, Hit* hits,
                            bool* found) const;

    // Shadow-ray bundles (an area light's grid seen from one point). shadow_candidates() walks
    // the BVH once and writes to `candidates` the box of every primitive (in a reached leaf)
    // that is neither separated from the convex hull of `hull` (the shaded point and a
    // parallelogram holding every sample) along one of a few axes, nor left by every ray before
    // t_min (the floor under the shaded point): a superset of the primitives any ray of the
    // bundle can hit in occluded(). It returns false, leaving the rays to occluded(), when there
    // are more than kMaxBundleCandidates. occluded_by() answers occluded() for one ray of the
    // bundle by testing only the candidates, each behind its own box (a primitive's hit lies in
    // its box, as the BVH relies on for every node) with the same primitive tests: the same
    // answer, as any-hit does not depend on the order. The occluder moves to the front, where
    // the next ray tries it first.
    bool shadow_candidates(const Vec3* hull, int hull_count, double t_min,
                           std::vector<BundleCandidate>& candidates) const;
    bool occluded_by(std::vector<BundleCandidate>& candidates, const Ray& ray, double t_min, double t_max) const;
    // occluded_by() for every ray of a bundle at once (an area light's full grid): ray k leaves
    // `origin` along (x[k], y[k], z[k]) and counts hits in (t_min, distance[k] − t_min);
    // blocked[k] is whether it is occluded. The four arrays hold count rounded up to even
    // entries, the pad a copy of the last ray (read two at a time). Candidate by candidate, each
    // tested against the rays not yet blocked, so a candidate's set-up is done once per bundle
    // and each ray's once per ray. A sphere is tested without its box (two rays at a time the
    // box test costs more than it saves).
    void occluded_by_each(const std::vector<BundleCandidate>& candidates, const Vec3& origin, const double* x,
                          const double* y, const double* z, const double* distance, size_t count, double t_min,
                          unsigned char* blocked) const;

    // occluded() as POV-Ray 3.7 answers it for meshes (povray_walk.cpp): a mesh's bounding-box
    // walk stops at its first hit, even one too close to count as a shadow hit, so an occluder
    // of the same mesh behind it can be missed. Call only where occluded() said true.
    bool occluded_povray_walk(const Ray& ray, double t_min, double t_max) const;
    // closest_hit() as POV-Ray's shadow search finds it (the same walk): the nearest hit in
    // (t_min, t_max) among those POV-Ray's meshes report. A filtered shadow ray's segments
    // (render.cpp: shadow_filter) start on a crossed surface, often a hair from another mesh.
    bool closest_hit_povray_walk(const Ray& ray, double t_min, double t_max, Hit& hit) const;

    // occluded() counting only the objects whose casts[object] is 1 (a light's shadow link;
    // light_linking.cpp). The BVH holds every object, so an excluded one is skipped, not culled.
    bool occluded_linked(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max,
                         const unsigned char* casts) const;
    // Objects in LightLinking's numbering: the spheres, then the meshes.
    // Objects: the spheres, the meshes, then the intrinsic prims (numbered by their parts).
    size_t object_count() const {
        size_t count = spheres.size() + (first_triangle_.empty() ? 0 : first_triangle_.size() - 1);
        for (const std::vector<IntrinsicShape>* parts : {&intrinsics, &planes})
            for (const IntrinsicShape& part : *parts) count = std::max(count, size_t(part.object) + 1);
        for (const BallGroup& group : ball_groups) count = std::max(count, size_t(group.object) + 1);
        return count;
    }
    // The object (LightLinking's numbering) of a primitive ref (as Hit::ref).
    int32_t object_of(int32_t ref) const {
        if (ref >= 0) return int32_t(spheres.size()) + triangle_mesh(size_t(ref));
        if (is_ball(ref)) return ball_group(ball_index(ref)).object;
        return is_sphere(ref) ? ~ref : intrinsic(ref).object;
    }
    // Refs of the non-triangle primitives: spheres, balls, intrinsic parts in the BVH, then
    // unbounded planes (ref = plane_ref(k), after every part).
    bool is_sphere(int32_t ref) const { return ref < 0 && size_t(~ref) < spheres.size(); }
    bool is_ball(int32_t ref) const {
        return ref < 0 && size_t(~ref) >= spheres.size() && size_t(~ref) < spheres.size() + balls.size();
    }
    bool is_round(int32_t ref) const { return ref < 0 && size_t(~ref) < spheres.size() + balls.size(); }
    size_t ball_index(int32_t ref) const { return size_t(~ref) - spheres.size(); }
    const BallGroup& ball_group(size_t ball) const {
        const size_t row = ball_source[ball];
        if (ball_groups.size() == 1) return ball_groups[0];
        return *(std::upper_bound(ball_groups.begin() + 1, ball_groups.end(), row,
                                  [](size_t r, const BallGroup& g) { return r < g.first; }) -
                 1);
    }
    // The sphere or ball (as a SphereShape, in `scratch`) of ref (is_round).
    const SphereShape& round_shape(int32_t ref, SphereShape& scratch) const {
        if (is_sphere(ref)) return spheres[size_t(~ref)];
        const size_t k = ball_index(ref);
        scratch = ball_sphere(balls[k], ball_group(k).material);
        return scratch;
    }
    int32_t plane_ref(size_t k) const { return ~int32_t(spheres.size() + balls.size() + intrinsics.size() + k); }
    const IntrinsicShape& intrinsic(int32_t ref) const {
        const size_t k = size_t(~ref) - spheres.size() - balls.size();
        return k < intrinsics.size() ? intrinsics[k] : planes[k - intrinsics.size()];
    }

    // Every primitive the ray hits in (t_min, t_max), by brute force (tests only).
    int count_hits(const Ray& ray, double t_min, double t_max, double& t_closest) const;

    // The primitive's id as Python numbers them: spheres 0..S-1, then triangles in mesh order,
    // intrinsic parts (unbounded planes last), then the balls by input row.
    int64_t primitive_id(int32_t ref) const;

    // Children per node of the walk closest_hit() and occluded() take: 8 (AVX2) or 4 (SSE2).
    int walk_width() const { return bvh8_.empty() ? 4 : 8; }
    // Whether the rays skip the tree and test every primitive in lanes (small_scene.hpp).
    bool small() const { return small_ && instances_empty(); }
    // Leaves of the walk's tree (the SAH's choices, bvh.cpp: a test's view of the tree's shape).
    size_t leaf_count() const {
        size_t leaves = 0;
        for_each_wide_node(bvh8_, [&](const Bvh8Node& node) {
            for (int i = 0; i < 8; ++i) leaves += node.count[i] > 0;
        });
        for_each_wide_node(bvh4_, [&](const Bvh4Node& node) {
            for (int i = 0; i < 4; ++i) leaves += node.count[i] > 0;
        });
        return leaves;
    }

    // A digest of the walk's tree and leaf order (FNV-1a over the wide nodes, the leaf refs and
    // each leaf-order triangle's input row): equal digests, the same tree (tests: a build's tree
    // does not depend on its threads).
    uint64_t tree_digest() const {
        uint64_t h = 14695981039346656037ull;
        auto mix = [&h](const void* data, size_t bytes) {
            const unsigned char* p = static_cast<const unsigned char*>(data);
            for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
        };
        static_assert(sizeof(Bvh8Node) == 256 && sizeof(Bvh4Node) == 128, "nodes without padding");
        // Node by node from the root (a large tree's array has unused slots: bvh4.cpp); the
        // children's slots are in the nodes, so the layout counts too.
        auto mix_node = [&](const auto& node) { mix(&node, sizeof node); };
        for_each_wide_node(bvh8_, mix_node);
        for_each_wide_node(bvh4_, mix_node);
        mix(refs_.data(), refs_.size() * sizeof(int32_t));
        mix(triangle_source.data(), triangle_source.size() * sizeof(uint32_t));
        return h;
    }

    // The mesh of leaf-order triangle `slot` (from its input row: the POV-Ray walk's rare
    // question needs no per-triangle array).
    // Inline, with the one-mesh and two-mesh answers without the search: asked at every shaded
    // triangle hit, the out-of-line binary search cost S2 (two meshes) ~28 instructions a pixel.
    int32_t triangle_mesh(size_t slot) const {
        const size_t meshes = first_triangle_.size() - 1;
        if (meshes == 1) return 0;
        if (meshes == 2) return triangle_source[slot] >= first_triangle_[1] ? 1 : 0;
        return triangle_mesh_searched(slot);
    }
    // The material of leaf-order triangle `slot`: its mesh's (a per-mesh number, not a
    // per-triangle one: 4 bytes a triangle fewer).
    int32_t triangle_material(size_t slot) const { return mesh_material(triangle_mesh(slot)); }
    int32_t mesh_material(int32_t mesh) const { return mesh_material_[size_t(mesh)]; }
    // The flat normal of leaf-order triangle `slot` of mesh `mesh` (triangle_mesh) when it is
    // kept (flat_triangle_normal of its stored corners: the number a hit would compute), else
    // nullptr.
    const Vec3* flat_normal(size_t slot, int32_t mesh) const {
        const int64_t row = flat_normal_row_[size_t(mesh)];
        if (row < 0) return nullptr;
        return &flat_normals_[size_t(row) + (triangle_source[slot] - first_triangle_[size_t(mesh)])];
    }

    std::vector<SphereShape> spheres;
    std::vector<BallShape> balls;            // the Points sets' spheres, leaf order
    std::vector<uint32_t> ball_source;       // leaf order -> input row (over every set, in order)
    std::vector<BallGroup> ball_groups;      // by first input row
    std::vector<IntrinsicShape> intrinsics;  // parts in the BVH
    std::vector<IntrinsicShape> planes;      // unbounded planes: outside the BVH and `bounds`
    TriangleStore triangles;                 // leaf order; float when that is exact
    // Leaf order; empty when no mesh has vertex normals (every triangle flat): 12 bytes a
    // triangle only where a scene needs them (benchmarks/README.md, memory per triangle).
    UninitialisedVector<TriangleNormals> triangle_normals;  // sized unwritten: the copy sets each
    UninitialisedVector<uint32_t> triangle_source;  // leaf order -> input row (sized unwritten: the copy sets each)
    // Leaf order; empty unless built in POV-Ray numerics (then `triangles` holds the corners in
    // their meshes' frames: TriangleStore::local).
    std::vector<PovrayTriangle> povray_triangles;
    Vec3Store normals;  // float when that is exact
    std::vector<Material> materials;
    std::vector<Light> lights;
    std::vector<LightLinking> light_links;  // empty (every light default), or one per light
    RGB ambient;
    // Textures (Material::diffuse_texture) and the (u, v) of each triangle corner, by input
    // triangle row (triangle_source): 6 numbers per triangle (corner_uv_rows rows; none without
    // textures), the caller's array held by corner_uv_owner (48 bytes a triangle: 614 MB for the
    // chess set's 12.8M, not copied).
    std::vector<Texture> textures;
    // What rays that hit nothing see, by direction (a textured DomeLight); absent: the
    // settings' background colour.
    Environment environment;
    const double* corner_uv = nullptr;
    size_t corner_uv_rows = 0;
    std::shared_ptr<const void> corner_uv_owner;
    // In POV-Ray numerics corner_uv holds the uvs as the SDL does (mapped into the compiler's
    // UvFrame, backends/povray/compile.py); a lookup takes u = uv_origin + uv_span·u' (the
    // identity otherwise).
    double uv_origin[2] = {0.0, 0.0};
    double uv_span[2] = {1.0, 1.0};
    // Instanced geometry (instances.hpp): null without instances. The geometry above is the
    // world's own; each instance's lies in its prototype's Scene.
    std::unique_ptr<InstanceLayer> instances;
    bool instances_empty() const { return !instances || instances->size() == 0; }
    // The scene (this, or an instance's prototype) whose primitive `hit.ref` names.
    const Scene& surface_of(const Hit& hit) const {
        return hit.instance < 0 ? *this : instances->prototype_of(hit.instance);
    }
    // Adds copies of a prototype (instances.hpp) and grows `bounds` by their boxes.
    void add_instances(std::unique_ptr<Scene> prototype, const double* world_from_prototype, size_t count,
                       bool rebuild = true, const double* colors = nullptr);

    Bounds bounds;           // of the geometry but unbounded planes, instances included (empty without primitives)
    double magnitude = 0.0;  // largest absolute coordinate of the geometry bounds

  private:
    struct ClosestSearch;  // one ray's closest-hit state and tests (closest_search.hpp)

    // The nearest unbounded plane hit in (t_min, t_max) (closest_hit, occluded).
    bool hit_planes(const Ray& ray, double t_min, double t_max, double& t, int32_t& ref) const {
        bool found = false;
        for (size_t k = 0; k < planes.size(); ++k) {
            double tk;
            if (intersect_intrinsic(planes[k], ray, t_min, t_max, tk)) {
                t_max = tk;
                t = tk;
                ref = plane_ref(k);
                found = true;
            }
        }
        return found;
    }
    // A sphere's, ball's or intrinsic part's hit test (ref < 0).
    bool hit_solid(int32_t ref, const Ray& ray, double t_min, double t_max, double& t) const {
        if (is_sphere(ref)) return intersect_sphere(spheres[size_t(~ref)], ray, t_min, t_max, t);
        if (is_ball(ref)) return intersect_ball(balls[ball_index(ref)], ray, t_min, t_max, t);
        return intersect_intrinsic(intrinsic(ref), ray, t_min, t_max, t);
    }
    // A triangle's hit test: POV-Ray's where the scene was built for it, else the watertight one.
    bool hit_triangle(int32_t ref, const Ray& ray, std::optional<WatertightRay>& wr, double t_min, double t_max,
                      double& t, Barycentric& bary) const {
        if (!povray_triangles.empty())
            return intersect_povray_triangle(povray_triangles[size_t(ref)], triangles.local(size_t(ref)),
                                             triangles.origin(size_t(ref)), ray, t_min, t_max, t, bary);
        if (!wr) wr.emplace(ray.dir);
        return intersect_triangle(triangles[size_t(ref)], ray, *wr, t_min, t_max, t, bary);
    }

    // Whether the rays' leaves take the float prefilter (triangle_prefilter.hpp): on the AVX2
    // walk, with float corners and the watertight test, in a scene with a leaf it can take
    // (kMinPrefilterLeaf triangles). Elsewhere the leaves are tested as before it: its AVX2 leaf
    // loop, every test inlined, rendered S1 (4 spheres, 2 triangles) ~10 % slower in CPU time.
    // (Decided once the scene is built: asked per ray, the four tests cost ~11 instructions of an
    // S2 shadow ray.)
    bool prefilter_applies() const { return prefilter_; }
    // Whether spheres, balls or intrinsic parts share the tree's leaves with the triangles
    // (decided with prefilter_applies).
    bool mixed_leaves() const { return mixed_leaves_; }
    // The ref at leaf position `position` (refs_[position]): in a scene of triangles alone, each
    // triangle's slot is its leaf position (scene.cpp), so the refs need not be read, a cache
    // line a leaf.
    int32_t leaf_ref(int32_t position) const { return mixed_leaves_ ? refs_[size_t(position)] : position; }

    Bvh bvh_;  // the binary tree; its nodes are freed once collapsed
    // What the rays and bundles walk: the 8-wide tree where the CPU has AVX2 (simd_dispatch.hpp),
    // else the 4-wide one; the other is empty.
    Bvh4Nodes bvh4_;
    Bvh8Nodes bvh8_;
    UninitialisedVector<int32_t> refs_;   // BVH leaf order (sized unwritten: the copy sets each)
    std::vector<size_t> first_triangle_;  // mesh m's input rows start at first_triangle_[m]
    std::vector<int32_t> mesh_material_;  // by mesh
    // Flat normals of the meshes without vertex normals, while they total at most
    // kMaxCachedFlatNormals triangles: mesh m's rows start at flat_normal_row_[m] (-1: not kept).
    std::vector<int64_t> flat_normal_row_;
    std::vector<Vec3> flat_normals_;
    int32_t triangle_mesh_searched(size_t slot) const;  // triangle_mesh for three meshes or more
    bool prefilter_ = false;                            // prefilter_applies()
    bool mixed_leaves_ = false;                         // mixed_leaves()
    // Where the scene is a small one (small_scene.hpp: on the AVX2 path, a few axis-aligned
    // spheres and triangles and no other bounded primitive), its rays' lanes; else empty.
    std::unique_ptr<const SmallScene> small_;
    // occluded() there, and the exact tests of the spheres and triangles its lanes did not reject.
    bool occluded_small(const Ray& ray, double t_min, double t_max) const;
    bool occluded_exactly(const Ray& ray, unsigned spheres_left, unsigned triangles_left, double t_min,
                          double t_max) const;
    RayBits occluded_small_each(const Ray* rays, int count, double t_min, const double* t_max) const;
    // occluded_each on the 8-wide tree: the rays walk it together, each by its own box tests.
    RayBits occluded_tree_each(const Ray* rays, int count, double t_min, const double* t_max) const;
    void closest_small(const Ray& ray, ClosestSearch& search) const;  // closest_hit()'s tests there
    bool occluded_tree(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max) const;  // elsewhere
};

}  // namespace phong
