// SPDX-License-Identifier: Apache-2.0
// Instancing: the top level of a two-level BVH. Each prototype is a Scene of its own (its meshes
// in prototype space, its own BVH, built once); an instance is the affine map from the world
// into its prototype's space. A ray meets an instance's world box in the top-level BVH, is
// carried into the prototype's space (origin and direction by the same map, the direction not
// renormalised: the ray parameter t is the same in both spaces, so t_min, t_max and the hit's t
// need no conversion, and a hit is compared with world hits as it is), and is traced there.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "bvh.hpp"
#include "bvh4.hpp"
#include "math.hpp"

namespace phong {

class Scene;
struct Hit;

// An affine map x -> A x + b held as the rows of [A | b] (column vectors, like the model's).
struct AffineMap {
    double m[12];
    Vec3 point(const Vec3& p) const {
        return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
    }
    Vec3 vector(const Vec3& v) const {
        return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                m[8] * v.x + m[9] * v.y + m[10] * v.z};
    }
    // Aᵀ v: a prototype-space normal carried to the world by the inverse transpose of the
    // world-from-prototype map, i.e. the transpose of this prototype-from-world map.
    Vec3 transposed(const Vec3& v) const {
        return {m[0] * v.x + m[4] * v.y + m[8] * v.z, m[1] * v.x + m[5] * v.y + m[9] * v.z,
                m[2] * v.x + m[6] * v.y + m[10] * v.z};
    }
};

struct Instance {
    AffineMap prototype_from_world;
    uint32_t prototype;  // index into InstanceLayer's prototypes
    uint32_t id;         // the copy's number in input order (ties between copies go to the lower)
};

class InstanceLayer {
  public:
    InstanceLayer();
    ~InstanceLayer();
    InstanceLayer(InstanceLayer&&) noexcept;
    InstanceLayer& operator=(InstanceLayer&&) noexcept;

    // Adds `count` copies of `prototype` (taken over), copy k placed by the 4x4 row-major
    // world-from-prototype matrix world_from_prototype[16k..16k+16) (affine, invertible:
    // Python validates), and rebuilds the top level unless `rebuild` is false (many
    // prototypes: build once, after the last; until then the layer is stale() and must not be
    // traced). Throws std::invalid_argument for a singular or non-affine matrix.
    // `colors` (count × 3, or nullptr): copy k's cd on materials with instance_color.
    void add(std::unique_ptr<Scene> prototype, const double* world_from_prototype, size_t count, bool rebuild = true,
             const double* colors = nullptr);
    bool stale() const { return stale_; }

    // The closest hit in (t_min, t_max) among the instances (hit.instance: the instance's
    // leaf position, hit.ref and hit.bary: the prototype's own) and any hit, as Scene's.
    bool closest_hit(const Ray& ray, double t_min, double t_max, Hit& hit) const;
    bool occluded(const Ray& ray, double t_min, double t_max) const;

    const Scene& prototype_of(int32_t instance) const { return *prototypes_[instances_[size_t(instance)].prototype]; }
    // A prototype-space normal as a world-space direction (not unit).
    Vec3 normal_to_world(int32_t instance, const Vec3& n) const {
        return instances_[size_t(instance)].prototype_from_world.transposed(n);
    }
    uint32_t instance_id(int32_t instance) const { return instances_[size_t(instance)].id; }
    // The instance's colour (add's `colors`), or nullptr where its copies were given none.
    const RGB* color_of(int32_t instance) const {
        const RGB& c = colors_[instances_[size_t(instance)].id];
        return std::isnan(c.x) ? nullptr : &c;
    }
    size_t size() const { return instances_.size(); }
    size_t prototype_count() const { return prototypes_.size(); }
    const Scene& prototype(size_t p) const { return *prototypes_[p]; }
    size_t triangle_count() const;  // stored: each prototype's once

    Bounds bounds;  // of every instance's world box

  private:
    void build();

    std::vector<std::unique_ptr<Scene>> prototypes_;
    std::vector<Instance> instances_;  // leaf order once built
    std::vector<Bounds> world_boxes_;  // by instance (input order), for rebuilds
    std::vector<RGB> colors_;          // by instance (input order); NaN: none given
    Bvh4Nodes nodes_;
    double magnitude_ = 0.0;  // largest absolute coordinate of the instances' boxes
    bool stale_ = false;      // instances added since the last build
};

}  // namespace phong
