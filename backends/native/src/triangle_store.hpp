// SPDX-License-Identifier: Apache-2.0
// The triangles' corners in leaf order (and the meshes' vertex normals), held as floats when
// that loses nothing. USD points are float32, and a mesh under an identity (or otherwise
// float-exact) world transform reaches the scene with every coordinate a float: then 9 floats
// (36 B) hold a triangle instead of 9 doubles (72 B), and widening them gives back the very same
// doubles, so every test and every image is bit-identical. At 1M triangles this halves the C++
// scene's largest array (S2: 72 -> 36 MB); USD normals are float32 too (normal3f), so their copy
// halves as well (S2: 12 -> 6 MB).
//
// In POV-Ray's numerics (diff) a third mode holds what POV-Ray's mesh2 holds: each corner as a
// float in its mesh's frame (world = mesh + origin, one origin per mesh), 40 bytes a triangle with
// the mesh's number. The caller's world points are those floats plus the origin (the Python side
// rounds them so: backends/native/__init__.py, _as_povray_stores), and widening gives back the
// very same doubles; where a point is not recovered so, the world corners are kept in doubles too.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "build_threads.hpp"
#include "huge_pages.hpp"
#include "math.hpp"
#include "shapes.hpp"
#include "uninitialised.hpp"

namespace phong {

// Whether double(float(x)) == x: a coordinate that float storage keeps exactly. NaN is not (it
// compares unequal), so such a mesh keeps double storage and its own behaviour.
inline bool float_exact(double x) { return double(float(x)) == x; }

// A triangle in its mesh's frame (POV-Ray numerics): the corners as POV-Ray's mesh2 holds them,
// in the caller's order v0, v1, v2, and the number of the mesh whose origin places them.
struct LocalTriangle {
    float v[9];     // v0, v1, v2 in mesh space
    uint32_t mesh;  // index into the store's origins

    TriangleShape widen(const Vec3& o) const {
        return {{v[0] + o.x, v[1] + o.y, v[2] + o.z},
                {v[3] + o.x, v[4] + o.y, v[5] + o.z},
                {v[6] + o.x, v[7] + o.y, v[8] + o.z}};
    }
};

static_assert(sizeof(LocalTriangle) == 40, "LocalTriangle's layout: 40 bytes a triangle");

// Leaf-order triangle corners in one of two precisions, chosen per scene when it is built
// (float when every mesh vertex is float_exact, else double); read as doubles either way.
// The floats are held in one of two layouts, 36 bytes a triangle either way. Where the float
// prefilter runs (triangle_prefilter.hpp: the AVX2 walk, leaves of kMinPrefilterLeaf triangles
// or more), as nine arrays (structure of arrays: corner c's coordinate i of slot k is
// coordinates(c, i)[k]), so that eight consecutive slots (a BVH leaf's triangles) are one 8-lane
// load per coordinate; each array is padded by kTriangleLanePadding slots, so such a load from any
// slot stays inside it. Elsewhere as nine floats in a row: reading a triangle from nine arrays
// costs ~20 instructions more, which S1 (two triangles, tested by every ray) paid as 2.4 % of its
// render without any use for the lanes (benchmarks/README.md, issue 25).
constexpr size_t kTriangleLanePadding = 8;

// A triangle's corners rounded to float (only ever built from float-exact doubles).
struct FloatTriangleShape {
    float v[9];  // v0, v1, v2

    explicit FloatTriangleShape(const TriangleShape& t = {})
        : v{float(t.v0.x), float(t.v0.y), float(t.v0.z), float(t.v1.x), float(t.v1.y),
            float(t.v1.z), float(t.v2.x), float(t.v2.y), float(t.v2.z)} {}

    TriangleShape widen() const { return {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}}; }
};

class TriangleStore {
  public:
    // n slots; float corners when single_precision, then in lanes (nine arrays) when `lanes`.
    void resize(size_t n, bool single_precision, bool lanes) {
        single_precision_ = single_precision;
        lanes_ = single_precision && lanes;
        count_ = n;
        if (lanes_) {
            stride_ = n + kTriangleLanePadding;
            // Unwritten: every slot is set by the build's parallel leaf-order copy, which then
            // faults the pages in on its threads (zero-filling 36 MiB here took S2's build 4.4 ms
            // on one thread first). The padding is zeroed with the last slot (set): here, its
            // nine writes faulted in nine huge pages, ~1-2 ms of S2's build on one thread.
            resize_huge(narrow_, 9 * stride_);
            for (int kx = 0; kx < 3; ++kx)
                for (int ky = 0; ky < 3; ++ky) {
                    if (ky == kx) continue;  // no WatertightRay has these axes: those rows stay 0
                    const int axis[3] = {kx, ky, 3 - kx - ky};
                    for (int c = 0; c < 3; ++c)
                        for (int i = 0; i < 3; ++i)
                            lane_offsets_[kx][ky][3 * c + i] = size_t(3 * c + axis[i]) * stride_;
                }
        } else if (single_precision) {
            resize_huge(rows_, n);
        } else {
            resize_huge(wide_, n);
        }
    }
    // Stores slot k's corners (float_exact when single_precision()); every slot is set once.
    void set(size_t k, const TriangleShape& t) {
        if (!single_precision_) {
            wide_[k] = t;
        } else if (!lanes_) {
            rows_[k] = FloatTriangleShape(t);
        } else {
            const double v[9] = {t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z};
            for (size_t i = 0; i < 9; ++i) narrow_[i * stride_ + k] = float(v[i]);
            if (k + 1 == count_)
                for (size_t i = 0; i < 9; ++i)
                    std::fill_n(narrow_.begin() + ptrdiff_t(i * stride_ + count_), kTriangleLanePadding, 0.0f);
        }
    }
    TriangleShape operator[](size_t k) const {
        if (lanes_) {
            const float* p = narrow_.data() + k;
            const size_t s = stride_;
            return {{p[0], p[s], p[2 * s]}, {p[3 * s], p[4 * s], p[5 * s]}, {p[6 * s], p[7 * s], p[8 * s]}};
        }
        if (single_precision_) return rows_[k].widen();
        if (!mesh_local_) return wide_[k];
        return world_.empty() ? local_[k].widen(origins_[local_[k].mesh]) : world_[k];
    }
    size_t size() const { return mesh_local_ ? local_.size() : count_; }
    bool single_precision() const { return single_precision_; }
    // Whether the floats are in lanes (nine coordinate arrays), for the prefilter.
    bool lanes() const { return lanes_; }
    // Corner c's (0..2) coordinate i (0: x, 1: y, 2: z) of every slot (lanes() only);
    // kTriangleLanePadding readable floats follow the last slot.
    const float* coordinates(int corner, int i) const { return narrow_.data() + size_t(3 * corner + i) * stride_; }
    // For a ray whose sheared frame takes axes kx, ky, kz = 3 − kx − ky (WatertightRay), where
    // corner c's coordinate along axis i of the frame lies: coordinates(0, 0) +
    // lane_offsets(kx, ky)[3c + i]. Tabled when the lanes are laid out, so that the prefilter's
    // set-up picks a row instead of forming nine pointers for every ray (~40 instructions a ray
    // that reaches a leaf of lanes: benchmarks/README.md, issue 25).
    const size_t* lane_offsets(int kx, int ky) const { return lane_offsets_[kx][ky]; }

    // The third mode, in POV-Ray's numerics (resize_mesh_local instead of resize): the corners in
    // their meshes' frames, read as the same world doubles. n triangles of meshes placed at
    // `origins`; with keep_world, the world corners are held too (some point is not its float
    // plus its origin).
    void resize_mesh_local(size_t n, std::vector<Vec3> origins, bool keep_world) {
        mesh_local_ = true;
        single_precision_ = false;
        origins_ = std::move(origins);
        resize_huge(local_, n);
        if (keep_world) resize_huge(world_, n);
    }
    // Stores slot k: its corners in its mesh's frame and (kept only with keep_world) in the world.
    void set_local(size_t k, const LocalTriangle& t, const TriangleShape& world) {
        local_[k] = t;
        if (!world_.empty()) world_[k] = world;
    }
    bool mesh_local() const { return mesh_local_; }
    // Whether the world corners are held in doubles beside the mesh-frame ones.
    bool keeps_world() const { return !world_.empty(); }
    const LocalTriangle& local(size_t k) const { return local_[k]; }
    const Vec3& origin(size_t k) const { return origins_[local_[k].mesh]; }

  private:
    bool single_precision_ = false;
    size_t count_ = 0;
    size_t stride_ = 0;  // floats from one coordinate array to the next
    bool lanes_ = false;
    UninitialisedVector<float> narrow_;     // lanes: 9 arrays of stride_ floats: v0.x, v0.y, v0.z, v1.x, ..., v2.z
    size_t lane_offsets_[3][3][9] = {};     // lane_offsets(kx, ky)
    std::vector<FloatTriangleShape> rows_;  // floats not in lanes
    std::vector<TriangleShape> wide_;
    bool mesh_local_ = false;
    std::vector<LocalTriangle> local_;
    std::vector<Vec3> origins_;         // by mesh
    std::vector<TriangleShape> world_;  // empty unless some point is not recovered from its mesh's frame
};

// Rows of 3 doubles (the meshes' normals), held as floats when every coordinate is
// float_exact; read back as the same doubles.
class Vec3Store {
  public:
    // Stores `rows` (count x 3) of each of `parts`, concatenated in order. The check and the
    // copy run in chunks on the build's threads (for_chunks): serial, S2's 500k normals took
    // ~2 ms of its build at two threads while the other thread waited (benchmarks/README.md).
    template <class Parts>
    void assign(const Parts& parts) {
        size_t count = 0;
        std::atomic<bool> every_float{true};
        for (const auto& [rows, n] : parts) {
            count += n;
            const double* part = rows;
            for_chunks(3 * n, [&every_float, part](size_t begin, size_t end) {
                for (size_t i = begin; i < end && every_float.load(std::memory_order_relaxed); ++i)
                    if (!float_exact(part[i])) every_float.store(false, std::memory_order_relaxed);
            });
        }
        single_precision_ = every_float.load();
        UninitialisedVector<float>().swap(narrow_);
        UninitialisedVector<Vec3>().swap(wide_);
        if (single_precision_)
            resize_huge(narrow_, 3 * count);
        else
            resize_huge(wide_, count);
        size_t first = 0;  // the part's first row in the store
        for (const auto& [rows, n] : parts) {
            const double* part = rows;
            for_chunks(n, [this, part, first](size_t begin, size_t end) {
                for (size_t i = begin; i < end; ++i) {
                    const double* v = part + 3 * i;
                    if (single_precision_)
                        for (int k = 0; k < 3; ++k) narrow_[3 * (first + i) + k] = float(v[k]);
                    else
                        wide_[first + i] = {v[0], v[1], v[2]};
                }
            });
            first += n;
        }
    }
    Vec3 operator[](size_t k) const {
        if (!single_precision_) return wide_[k];
        const float* v = &narrow_[3 * k];
        return {v[0], v[1], v[2]};
    }
    size_t size() const { return single_precision_ ? narrow_.size() / 3 : wide_.size(); }
    bool single_precision() const { return single_precision_; }

  private:
    bool single_precision_ = false;
    UninitialisedVector<float> narrow_;
    UninitialisedVector<Vec3> wide_;
};

}  // namespace phong
