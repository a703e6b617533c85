// SPDX-License-Identifier: Apache-2.0
// Shadow rays of a light with a shadow link (UsdLux collection:shadowLink): any-hit through the
// BVH over the objects that cast the light's shadows. The BVH is shared by every light, so the
// objects outside the link are skipped at their primitives, not culled at the nodes.
#include <optional>

#include "scene.hpp"

namespace phong {

bool Scene::occluded_linked(const Ray& ray, const FloatSlabOrigin& origin, double t_min, double t_max,
                            const unsigned char* casts) const {
    std::optional<WatertightRay> wr;  // set up when the first triangle is tested
    bool blocked = false;
    double t_limit = t_max;
    auto leaf = [&](int32_t first, int count, double& t_best) {
        for (int k = 0; k < count; ++k) {
            const int32_t ref = refs_[size_t(first + k)];
            if (!casts[size_t(object_of(ref))]) continue;
            double t;
            bool hit;
            if (ref >= 0) {
                Barycentric bary;
                hit = hit_triangle(ref, ray, wr, t_min, t_best, t, bary);
            } else {
                hit = hit_solid(ref, ray, t_min, t_best, t);
            }
            if (hit) {
                blocked = true;
                return true;  // shadow rays stop at the first hit
            }
        }
        return false;
    };
    // The tree the rays walk (scene.hpp: the 8-wide one where the CPU has AVX2, else the 4-wide).
    if (!bvh8_.empty())
        traverse_bvh8<false>(bvh8_, magnitude, ray, origin, t_min, t_limit, leaf);
    else
        traverse_bvh4<false>(bvh4_, magnitude, ray, origin, t_min, t_limit, leaf);
    for (size_t k = 0; k < planes.size() && !blocked; ++k) {
        double t;
        blocked = casts[size_t(planes[k].object)] && intersect_intrinsic(planes[k], ray, t_min, t_max, t);
    }
    // Instances all cast: the native backend flattens those a link tells apart (__init__.py).
    return blocked || (!instances_empty() && instances->occluded(ray, t_min, t_max));
}

}  // namespace phong
