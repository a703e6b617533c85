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
#include "small_scene.hpp"
#include "sphere_lanes.hpp"
#include "triangle_lanes.hpp"
#include "triangle_prefilter.hpp"
#include "uninitialised.hpp"

namespace phong {

bool Scene::closest_hit_packet(const Ray* rays, int count, const FloatSlabOrigin& origin, double t_min, Hit* hits,
                               bool* found) const {
    assert(count >= 1 && count <= kPacketRays);
    FloatSlabPacket packet;
    // A lone ray gains nothing from the packet's walk; the 4-wide tree (no AVX2) has none.
    if (bvh8_.empty() || count < 2 || (!small() && !packet.set_up(rays, count, origin, t_min, magnitude))) {
        for (int r = 0; r < count; ++r) found[r] = closest_hit(rays[r], origin, t_min, HUGE_VAL, hits[r]);
        return false;
    }
    Deferred<ClosestSearch> search[kPacketRays];       // rays [0, count)
    Deferred<TriangleLeafFilter> filter[kPacketRays];  // rays [0, count) where `prefilter`
    const bool prefilter = prefilter_applies();
    double t_cull[kPacketRays];
    for (int r = 0; r < count; ++r) {
        search[r].emplace(*this, rays[r], t_min, HUGE_VAL, hits[r]);
        if (prefilter) filter[r].emplace(triangles, magnitude, mixed_leaves());
        t_cull[r] = HUGE_VAL;
    }
    const bool any_spheres = !spheres.empty();
    // Sphere `ref` against the rays of `rays`, four at a time (sphere_lanes.hpp: each lane the
    // scalar test's answer and root), each hit offered to its ray's search as test() would.
    auto test_sphere = [&](int32_t ref, unsigned rays_in) PHONG_AVX2 __attribute__((always_inline)) {
        const SphereShape& sphere = spheres[size_t(~ref)];
        while (rays_in != 0) {
            int lane_ray[kSphereLanes];
            int lanes = 0;
            for (; rays_in != 0 && lanes < kSphereLanes; rays_in &= rays_in - 1)
                lane_ray[lanes++] = __builtin_ctz(rays_in);
            for (int i = lanes; i < kSphereLanes; ++i) lane_ray[i] = lane_ray[0];  // spare lanes: ray 0 again
            const Vec3 &d0 = rays[lane_ray[0]].dir, &d1 = rays[lane_ray[1]].dir, &d2 = rays[lane_ray[2]].dir,
                       &d3 = rays[lane_ray[3]].dir;
            const __m256d t_max = _mm256_setr_pd(search[lane_ray[0]]->t_test, search[lane_ray[1]]->t_test,
                                                 search[lane_ray[2]]->t_test, search[lane_ray[3]]->t_test);
            double t[kSphereLanes];
            const int hits = intersect_sphere_lanes(sphere, rays[0].origin, _mm256_setr_pd(d0.x, d1.x, d2.x, d3.x),
                                                    _mm256_setr_pd(d0.y, d1.y, d2.y, d3.y),
                                                    _mm256_setr_pd(d0.z, d1.z, d2.z, d3.z), t_min, t_max, t) &
                             ((1 << lanes) - 1);
            for (unsigned h = unsigned(hits); h != 0; h &= h - 1) {
                const int i = __builtin_ctz(h);
                search[lane_ray[i]]->offer(ref, t[i], Barycentric{});
            }
        }
    };
    // The rays' WatertightRays (each search's own, set up here if no test has yet) with their
    // shears by lane, set up when a leaf first takes triangles in lanes; shears_shared() is false
    // when the rays' dominant axes differ (then every leaf's triangles go ray by ray).
    enum { kShearsUnset, kShearsShared, kShearsDiffer } shears = kShearsUnset;
    alignas(32) double shear_x[kPacketRays], shear_y[kPacketRays], shear_z[kPacketRays];
    auto shears_shared = [&]() {
        if (shears == kShearsUnset) {
            shears = kShearsShared;
            for (int r = 0; r < count; ++r) {
                std::optional<WatertightRay>& wr = search[r]->wr;
                if (!wr) wr.emplace(rays[r].dir);
                const WatertightRay& first_wr = *search[0]->wr;
                if (wr->kx != first_wr.kx || wr->ky != first_wr.ky || wr->kz != first_wr.kz) shears = kShearsDiffer;
                shear_x[r] = wr->sx;
                shear_y[r] = wr->sy;
                shear_z[r] = wr->sz;
            }
        }
        return shears == kShearsShared;
    };
    // Triangle `ref` against the rays of `rays_in`, four at a time (triangle_lanes.hpp: each lane
    // the scalar test's answer, distance and weights), each hit offered to its ray's search as
    // test() would; a lane through an edge takes the scalar test.
    auto test_triangle = [&](int32_t ref, unsigned rays_in) PHONG_AVX2 __attribute__((always_inline)) {
        const TriangleShape tri = triangles[size_t(ref)];
        const WatertightRay& axes = *search[0]->wr;
        while (rays_in != 0) {
            int lane_ray[kTriangleLanes];
            int lanes = 0;
            for (; rays_in != 0 && lanes < kTriangleLanes; rays_in &= rays_in - 1)
                lane_ray[lanes++] = __builtin_ctz(rays_in);
            for (int i = lanes; i < kTriangleLanes; ++i) lane_ray[i] = lane_ray[0];  // spare lanes: ray 0 again
            auto gather = [&](const double* x) PHONG_AVX2 {
                return _mm256_setr_pd(x[lane_ray[0]], x[lane_ray[1]], x[lane_ray[2]], x[lane_ray[3]]);
            };
            const WatertightLanes wr{axes.kx, axes.ky, axes.kz, gather(shear_x), gather(shear_y), gather(shear_z)};
            const __m256d t_max = _mm256_setr_pd(search[lane_ray[0]]->t_test, search[lane_ray[1]]->t_test,
                                                 search[lane_ray[2]]->t_test, search[lane_ray[3]]->t_test);
            TriangleLaneHits found_here;
            int scalar;
            const int used = (1 << lanes) - 1;
            const int hits = intersect_triangle_lanes(tri, rays[0].origin, wr, t_min, t_max, found_here, scalar) & used;
            for (unsigned h = unsigned(hits); h != 0; h &= h - 1) {
                const int i = __builtin_ctz(h);
                search[lane_ray[i]]->offer(ref, found_here.t[i], found_here.bary(i));
            }
            for (unsigned e = unsigned(scalar & used); e != 0; e &= e - 1)
                search[lane_ray[__builtin_ctz(e)]]->test(ref);
        }
    };
    // The prefilter for the packet's rays at once (triangle_prefilter.hpp: the corners' offsets
    // from the shared origin formed once a leaf, then each ray's shear), where every ray's own
    // prefilter would apply with the same frame's axes: each ray keeps the very triangles its
    // own would. Set up at the first leaf that takes it.
    enum { kPrefilterUnset, kPrefilterOn, kPrefilterOff } packet_prefilter = kPrefilterUnset;
    TrianglePrefilter8 shared_prefilter;
    float shear_x_f[kPacketRays], shear_y_f[kPacketRays];
    auto packet_prefilter_on = [&]() PHONG_AVX2 {
        if (packet_prefilter == kPrefilterUnset) {
            packet_prefilter = kPrefilterOff;
            if (shears_shared() && shared_prefilter.set_up(triangles, rays[0], *search[0]->wr, magnitude)) {
                packet_prefilter = kPrefilterOn;
                for (int r = 0; r < count; ++r) {
                    const WatertightRay& wr = *search[r]->wr;
                    // TrianglePrefilter8::set_up's own condition, ray by ray (false for NaN).
                    if (!(std::fabs(wr.sx) <= 1.0 && std::fabs(wr.sy) <= 1.0)) packet_prefilter = kPrefilterOff;
                    shear_x_f[r] = float(wr.sx);
                    shear_y_f[r] = float(wr.sy);
                }
            }
        }
        return packet_prefilter == kPrefilterOn;
    };
    const bool mixed = mixed_leaves();
    // Triangles in lanes only with the watertight test (not POV-Ray's), and (below) only in
    // leaves the prefilter does not take, where each ray would test every triangle in full.
    const bool triangle_lanes = povray_triangles.empty();
    // closest_hit()'s leaves, for the rays of `rays_in` (always_inline and flatten as there: the
    // tests inlined into the AVX2 walk). Each ray tests the leaf's primitives in their order, as
    // its own walk would; a leaf of spheres alone met by two rays or more takes them in lanes, and
    // so does one of triangles alone that each ray would test in full.
    auto leaf = [&](unsigned rays_in, int32_t first, int n, double* cull) PHONG_AVX2 __attribute__((flatten)) {
        const int32_t* refs = refs_.data() + first;
        const bool shared = (rays_in & (rays_in - 1)) != 0;
        bool spheres_only = any_spheres && shared;
        for (int k = 0; k < n && spheres_only; ++k) spheres_only = is_sphere(refs[k]);
        bool triangles_only = !spheres_only && triangle_lanes && shared && (!prefilter || n < kMinPrefilterLeaf);
        for (int k = 0; k < n && triangles_only; ++k) triangles_only = refs[k] >= 0;
        if (spheres_only || (triangles_only && shears_shared())) {
            for (int k = 0; k < n; ++k) {
                if (spheres_only)
                    test_sphere(refs[k], rays_in);
                else
                    test_triangle(refs[k], rays_in);
            }
            for (unsigned bits = rays_in; bits != 0; bits &= bits - 1)
                cull[__builtin_ctz(bits)] = search[__builtin_ctz(bits)]->t_cull;
            return;
        }
        // A run of triangle slots (TriangleLeafFilter's layout) big enough for the prefilter.
        const bool prefilter_run =
            prefilter && n >= kMinPrefilterLeaf && (!mixed || (refs[0] >= 0 && refs[n - 1] - refs[0] == n - 1));
        if (prefilter_run && shared && packet_prefilter_on()) {
            const TrianglePrefilter8::CornerOffsets offsets = shared_prefilter.offsets(size_t(mixed ? refs[0] : first));
            for (unsigned bits = rays_in; bits != 0; bits &= bits - 1) {
                const int r = __builtin_ctz(bits);
                ClosestSearch& s = *search[r];
                for (unsigned kept = shared_prefilter.kept(offsets, shear_x_f[r], shear_y_f[r], n); kept != 0;
                     kept &= kept - 1)
                    s.test(leaf_ref(first + int32_t(__builtin_ctz(kept))));
                cull[r] = s.t_cull;
            }
            return;
        }
        for (unsigned bits = rays_in; bits != 0; bits &= bits - 1) {
            const int r = __builtin_ctz(bits);
            ClosestSearch& s = *search[r];
            if (prefilter) {
                for (unsigned kept = (*filter[r])(refs, first, n, rays[r], s.wr); kept != 0; kept &= kept - 1)
                    s.test(leaf_ref(first + int32_t(__builtin_ctz(kept))));
            } else {
                for (int k = 0; k < n; ++k) s.test(refs[k]);
            }
            cull[r] = s.t_cull;
        }
    };
    // A small scene (small_scene.hpp): each sphere tested by the rays it does not certainly
    // reject, each triangle by every ray; no walk. (Compiled for AVX2 with the tests inlined, as
    // the leaves are.)
    auto small_scene = [&]() PHONG_AVX2 __attribute__((flatten)) {
        alignas(32) double dx[kPacketRays], dy[kPacketRays], dz[kPacketRays];
        for (int r = 0; r < kPacketRays; ++r) {
            const Vec3& d = rays[r < count ? r : 0].dir;
            dx[r] = d.x;
            dy[r] = d.y;
            dz[r] = d.z;
        }
        const unsigned all = packet_bits(count);
        for (size_t k = 0; k < spheres.size(); ++k)
            if (const unsigned near = rays_near_sphere(spheres[k], rays[0].origin, dx, dy, dz, count, t_min) & all)
                test_sphere(~int32_t(k), near);
        for (size_t k = 0; k < triangles.size(); ++k) {
            if (shears_shared()) {
                test_triangle(int32_t(k), all);
            } else {
                for (int r = 0; r < count; ++r) search[r]->test(int32_t(k));
            }
        }
    };
    if (small()) {
        small_scene();
    } else {
        traverse_bvh8_packet(bvh8_, packet, packet_bits(count), t_cull, leaf);
    }
    for (int r = 0; r < count; ++r) found[r] = search[r]->finish(HUGE_VAL);
    return true;
}

}  // namespace phong
