// SPDX-License-Identifier: Apache-2.0
// Closest hits for packets of rays that share their origin (Scene::closest_hit_packet): the rays
// walk the 8-wide tree together (bvh8_packet.hpp says why each gets closest_hit()'s hit) and
// test their leaves one by one with closest_hit()'s own search (closest_search.hpp). Kept apart
// from the single-ray queries (scene.cpp) and the shadow bundles (shadow_bundles.cpp).
#include <cassert>
#include <cmath>
#include <optional>

#include "bvh8_packet.hpp"
#include "closest_search.hpp"
#include "scene.hpp"
#include "triangle_prefilter.hpp"

namespace phong {

bool Scene::closest_hit_packet(const Ray* rays, int count, const FloatSlabOrigin& origin, double t_min, Hit* hits,
                               bool* found) const {
    assert(count >= 1 && count <= kPacketRays);
    FloatSlabPacket8 packet;
    // A lone ray gains nothing from the packet's walk; the 4-wide tree (no AVX2) has none.
    if (bvh8_.empty() || count < 2 || !packet.set_up(rays, count, origin, t_min, magnitude)) {
        for (int r = 0; r < count; ++r) found[r] = closest_hit(rays[r], origin, t_min, HUGE_VAL, hits[r]);
        return false;
    }
    std::optional<ClosestSearch> search[kPacketRays];
    std::optional<TriangleLeafFilter> filter[kPacketRays];
    const bool prefilter = prefilter_applies();
    double t_cull[kPacketRays];
    for (int r = 0; r < count; ++r) {
        search[r].emplace(*this, rays[r], t_min, HUGE_VAL, hits[r]);
        if (prefilter) filter[r].emplace(triangles, magnitude);
        t_cull[r] = HUGE_VAL;
    }
    // closest_hit()'s leaves, for ray r (always_inline and flatten as there: the tests inlined
    // into the AVX2 walk).
    auto leaf = [&](int r, int32_t first, int n) PHONG_AVX2 __attribute__((flatten)) {
        ClosestSearch& s = *search[r];
        const int32_t* refs = refs_.data() + first;
        if (prefilter) {
            for (unsigned kept = (*filter[r])(refs, n, rays[r], s.wr); kept != 0; kept &= kept - 1)
                s.test(refs[__builtin_ctz(kept)]);
        } else {
            for (int k = 0; k < n; ++k) s.test(refs[k]);
        }
        return s.t_cull;
    };
    traverse_bvh8_packet(bvh8_, packet, (1u << count) - 1u, t_cull, leaf);
    for (int r = 0; r < count; ++r) found[r] = search[r]->finish(HUGE_VAL);
    return true;
}

}  // namespace phong
