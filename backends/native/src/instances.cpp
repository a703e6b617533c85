// SPDX-License-Identifier: Apache-2.0
// The top level of the two-level BVH: instance boxes, rays carried into prototype space.
#include "instances.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "scene.hpp"

namespace phong {

namespace {

// The inverse of the affine map with rows [A | b]: rows [A⁻¹ | −A⁻¹ b] (cofactors; the
// determinant's sign and size are checked by the caller).
bool invert_affine(const double* w, AffineMap& out) {
    const double a = w[0], b = w[1], c = w[2], d = w[4], e = w[5], f = w[6], g = w[8], h = w[9], i = w[10];
    const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    if (!(std::fabs(det) > 0.0) || !std::isfinite(det)) return false;
    const double r = 1.0 / det;
    const double inv[9] = {(e * i - f * h) * r, (c * h - b * i) * r, (b * f - c * e) * r,
                           (f * g - d * i) * r, (a * i - c * g) * r, (c * d - a * f) * r,
                           (d * h - e * g) * r, (b * g - a * h) * r, (a * e - b * d) * r};
    const double t[3] = {w[3], w[7], w[11]};
    for (int row = 0; row < 3; ++row) {
        out.m[4 * row + 0] = inv[3 * row + 0];
        out.m[4 * row + 1] = inv[3 * row + 1];
        out.m[4 * row + 2] = inv[3 * row + 2];
        out.m[4 * row + 3] = -(inv[3 * row] * t[0] + inv[3 * row + 1] * t[1] + inv[3 * row + 2] * t[2]);
    }
    return true;
}

// The world box of a prototype box under [A | b]: centre A c + b, half-extents |A| h (exact for
// the box), widened by kInstanceBoxMargin of its magnitude for the rounding of these products
// (a few roundings of ≤ ε/2 each, relative to the largest term: 16ε keeps a 4x margin, as the
// tracer's other box margins do). The prototype's hits lie in its box, so the instance's in this.
constexpr double kInstanceBoxMargin = ulps(16);
// Boxes up to a little beyond the best hit are still entered, so that an exact tie can go to the
// lower id: the same margin as Scene::closest_hit's (a box's entry errs by < 2ε relative).
constexpr double kTieCullMargin = ulps(8);

Bounds world_box(const double* w, const Bounds& local) {
    const Vec3 c = (local.lo + local.hi) * 0.5, h = (local.hi - local.lo) * 0.5;
    Bounds out;
    double centre[3], half[3];
    for (int row = 0; row < 3; ++row) {
        const double* r = w + 4 * row;
        centre[row] = r[0] * c.x + r[1] * c.y + r[2] * c.z + r[3];
        half[row] = std::fabs(r[0]) * h.x + std::fabs(r[1]) * h.y + std::fabs(r[2]) * h.z;
        const double margin = kInstanceBoxMargin * (std::fabs(centre[row]) + half[row]);
        half[row] += margin;
    }
    out.lo = {centre[0] - half[0], centre[1] - half[1], centre[2] - half[2]};
    out.hi = {centre[0] + half[0], centre[1] + half[1], centre[2] + half[2]};
    return out;
}

}  // namespace

InstanceLayer::InstanceLayer() = default;
InstanceLayer::~InstanceLayer() = default;
InstanceLayer::InstanceLayer(InstanceLayer&&) noexcept = default;
InstanceLayer& InstanceLayer::operator=(InstanceLayer&&) noexcept = default;

size_t InstanceLayer::triangle_count() const {
    size_t n = 0;
    for (const auto& p : prototypes_) n += p->triangles.size();
    return n;
}

void InstanceLayer::add(std::unique_ptr<Scene> prototype, const double* world_from_prototype, size_t count,
                        bool rebuild, const double* colors) {
    const uint32_t index = uint32_t(prototypes_.size());
    const Bounds local = prototype->bounds;
    if (!prototype->instances_empty())
        throw std::invalid_argument("a prototype holds no instances (nesting is composed in Python)");
    std::vector<Instance> added(count);
    std::vector<Bounds> boxes(count);
    for (size_t k = 0; k < count; ++k) {
        const double* w = world_from_prototype + 16 * k;
        if (w[12] != 0.0 || w[13] != 0.0 || w[14] != 0.0 || w[15] != 1.0)
            throw std::invalid_argument("an instance transform is not affine (last row must be 0 0 0 1)");
        if (!invert_affine(w, added[k].prototype_from_world))
            throw std::invalid_argument("an instance transform is singular");
        added[k].prototype = index;
        added[k].id = uint32_t(instances_.size() + k);
        if (!local.empty()) boxes[k] = world_box(w, local);
    }
    prototypes_.push_back(std::move(prototype));
    // Rebuild over the instances in input order (ids), then put them in leaf order.
    std::vector<Instance> all(instances_.size() + count);
    for (const Instance& inst : instances_) all[inst.id] = inst;
    for (size_t k = 0; k < count; ++k) all[added[k].id] = added[k];
    instances_ = std::move(all);
    world_boxes_.insert(world_boxes_.end(), boxes.begin(), boxes.end());
    for (size_t k = 0; k < count; ++k)
        colors_.push_back(colors ? RGB{colors[3 * k], colors[3 * k + 1], colors[3 * k + 2]} : RGB{NAN, NAN, NAN});
    for (const Bounds& b : boxes) bounds.grow(b);
    stale_ = true;
    if (rebuild) build();
}

void InstanceLayer::build() {
    PrimRefs prims;
    bounds = Bounds();
    for (size_t k = 0; k < instances_.size(); ++k) {
        if (world_boxes_[k].empty()) continue;  // a prototype without triangles: nothing to hit
        prims.emplace_back(world_boxes_[k], uint32_t(k));
        bounds.grow(world_boxes_[k]);
    }
    magnitude_ = bounds.empty() ? 0.0 : std::fmax(max_abs_component(bounds.lo), max_abs_component(bounds.hi));
    nodes_.clear();
    stale_ = false;
    if (prims.empty()) return;
    Bvh bvh;
    bvh.build(std::move(prims));
    nodes_ = collapse_to_bvh4(bvh.nodes);
    // Leaf position p holds instance bvh.order[p]: reorder so that leaves read in sequence.
    std::vector<Instance> ordered(bvh.order.size());
    std::vector<Bounds> boxes(bvh.order.size());
    std::vector<Instance> rest;
    for (size_t p = 0; p < bvh.order.size(); ++p) {
        ordered[p] = instances_[bvh.order[p]];
        boxes[p] = world_boxes_[bvh.order[p]];
    }
    // Instances with empty boxes stay after the leaves (never reached).
    std::vector<bool> placed(instances_.size(), false);
    for (uint32_t i : bvh.order) placed[i] = true;
    for (size_t k = 0; k < instances_.size(); ++k)
        if (!placed[k]) {
            ordered.push_back(instances_[k]);
            boxes.push_back(world_boxes_[k]);
        }
    // Keep input order recoverable for the next add(): ids are input positions.
    instances_ = std::move(ordered);
    std::vector<Bounds> by_id(instances_.size());
    for (size_t p = 0; p < instances_.size(); ++p) by_id[instances_[p].id] = boxes[p];
    world_boxes_ = std::move(by_id);
}

bool InstanceLayer::closest_hit(const Ray& ray, double t_min, double t_max, Hit& hit) const {
    bool found = false;
    double t_best = t_max;
    const FloatSlabOrigin origin(ray.origin);
    traverse_bvh4<true>(nodes_, magnitude_, ray, origin, t_min, t_max, [&](int32_t first, int count, double& cull) {
        for (int k = 0; k < count; ++k) {
            const int32_t position = first + k;
            const Instance& inst = instances_[size_t(position)];
            const Ray local{inst.prototype_from_world.point(ray.origin), inst.prototype_from_world.vector(ray.dir)};
            Hit h;
            // Up to and including t_best, so that an exact tie can go to the lower id.
            const double limit = found ? std::nextafter(t_best, HUGE_VAL) : t_best;
            if (!prototypes_[inst.prototype]->closest_hit(local, t_min, limit, h)) continue;
            if (found && !(h.t < t_best || (h.t == t_best && inst.id < instances_[size_t(hit.instance)].id))) continue;
            found = true;
            t_best = h.t;
            hit = h;
            hit.instance = position;
            cull = t_best + std::fabs(t_best) * kTieCullMargin;
        }
        return false;
    });
    return found;
}

bool InstanceLayer::occluded(const Ray& ray, double t_min, double t_max) const {
    bool blocked = false;
    const FloatSlabOrigin origin(ray.origin);
    double limit = t_max;
    traverse_bvh4<false>(nodes_, magnitude_, ray, origin, t_min, limit, [&](int32_t first, int count, double&) {
        for (int k = 0; k < count; ++k) {
            const Instance& inst = instances_[size_t(first + k)];
            const Ray local{inst.prototype_from_world.point(ray.origin), inst.prototype_from_world.vector(ray.dir)};
            if (prototypes_[inst.prototype]->occluded(local, t_min, t_max)) {
                blocked = true;
                return true;
            }
        }
        return false;
    });
    return blocked;
}

}  // namespace phong
