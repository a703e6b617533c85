// SPDX-License-Identifier: Apache-2.0
// Embree 3 (its C API, Debian's libembree-dev) as a peer of the native tracer: built and run by
// benchmarks/compiled_peers.py at benchmark time, never part of the package or its tests.
//
//   embree_peer RAYS.bin HITS.bin MODE THREADS REPEAT
//
// RAYS.bin (peer_input.h) holds the scene's triangles and spheres, the native camera's primary
// rays and each light's shadow targets. MODE: "single" (rtcIntersect1 / rtcOccluded1), "packet8"
// or "packet16" (rtcIntersect8/16 over 4x2 / 4x4 pixel blocks, then per block and shadow target
// one rtcOccluded8/16 packet of the block's hits). THREADS: Embree's device config threads=N
// (its build) and as many render threads over rows of blocks. Prints one JSON line: the best of
// REPEAT build times (rtcCommitScene only: the buffers are filled before) and render times
// (every primary ray, then a shadow ray per hit and target), and the rays traced. HITS.bin:
// peer_input.h's answers of the last render, for the check against the native tracer.
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "peer_input.h"

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

RTCScene build_scene(RTCDevice device, const PeerInput& in) {
    RTCScene scene = rtcNewScene(device);
    if (in.triangle_count) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                              3 * sizeof(float), in.point_count));
        std::memcpy(v, in.points, 3 * sizeof(float) * in.point_count);
        auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned), in.triangle_count));
        std::memcpy(t, in.triangles, 3 * sizeof(unsigned) * in.triangle_count);
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    if (in.sphere_count) {  // analytic spheres: centre and radius
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                              4 * sizeof(float), in.sphere_count));
        std::memcpy(v, in.spheres, 4 * sizeof(float) * in.sphere_count);
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    return scene;
}

// One ray's work in single mode: the primary ray, then a shadow ray per target if it hit.
void trace_single(RTCScene scene, const PeerInput& in, size_t ray, PeerOutput& out, size_t& rays) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    const float* o = in.origins + 3 * ray;
    const float* d = in.dirs + 3 * ray;
    rh.ray.org_x = o[0], rh.ray.org_y = o[1], rh.ray.org_z = o[2];
    rh.ray.dir_x = d[0], rh.ray.dir_y = d[1], rh.ray.dir_z = d[2];
    rh.ray.tnear = 0.0f, rh.ray.tfar = INFINITY, rh.ray.time = 0.0f;
    rh.ray.mask = ~0u, rh.ray.id = 0, rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    ++rays;
    const bool hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    out.t[ray] = hit ? rh.ray.tfar : INFINITY;
    if (!hit) return;
    float p[3];
    hit_point(o, d, rh.ray.tfar, p);
    for (size_t k = 0; k < in.target_total; ++k) {
        ShadowRay s = shadow_ray(p, in.targets + 3 * k);
        RTCRay r;
        r.org_x = s.org[0], r.org_y = s.org[1], r.org_z = s.org[2];
        r.dir_x = s.dir[0], r.dir_y = s.dir[1], r.dir_z = s.dir[2];
        r.tnear = 0.0f, r.tfar = s.tfar, r.time = 0.0f, r.mask = ~0u, r.id = 0, r.flags = 0;
        rtcOccluded1(scene, &ctx, &r);
        ++rays;
        peer_record(&out, &in, ray, k, r.tfar < 0.0f);
    }
}

template <int N> struct Packet;
template <> struct Packet<8> {
    using RayHit = RTCRayHit8;
    using Ray = RTCRay8;
    static constexpr int w = 4, h = 2;
    static void intersect(const int* v, RTCScene s, RTCIntersectContext* c, RayHit* r) { rtcIntersect8(v, s, c, r); }
    static void occluded(const int* v, RTCScene s, RTCIntersectContext* c, Ray* r) { rtcOccluded8(v, s, c, r); }
};
template <> struct Packet<16> {
    using RayHit = RTCRayHit16;
    using Ray = RTCRay16;
    static constexpr int w = 4, h = 4;
    static void intersect(const int* v, RTCScene s, RTCIntersectContext* c, RayHit* r) { rtcIntersect16(v, s, c, r); }
    static void occluded(const int* v, RTCScene s, RTCIntersectContext* c, Ray* r) { rtcOccluded16(v, s, c, r); }
};

// One w x h pixel block in packet mode (blocks at the image's right and bottom edges are partial:
// their lanes outside the image are invalid).
template <int N>
void trace_block(RTCScene scene, const PeerInput& in, int bx, int by, PeerOutput& out, size_t& rays) {
    using P = Packet<N>;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(64) typename P::RayHit rh;
    alignas(64) int valid[N];
    size_t index[N];
    for (int i = 0; i < N; ++i) {
        const int x = bx * P::w + i % P::w, y = by * P::h + i / P::w;
        valid[i] = x < in.width && y < in.height ? -1 : 0;
        index[i] = valid[i] ? size_t(y) * size_t(in.width) + size_t(x) : 0;
        const float* o = in.origins + 3 * index[i];
        const float* d = in.dirs + 3 * index[i];
        rh.ray.org_x[i] = o[0], rh.ray.org_y[i] = o[1], rh.ray.org_z[i] = o[2];
        rh.ray.dir_x[i] = d[0], rh.ray.dir_y[i] = d[1], rh.ray.dir_z[i] = d[2];
        rh.ray.tnear[i] = 0.0f, rh.ray.tfar[i] = INFINITY, rh.ray.time[i] = 0.0f;
        rh.ray.mask[i] = ~0u, rh.ray.id[i] = 0, rh.ray.flags[i] = 0;
        rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rays += valid[i] ? 1 : 0;
    }
    P::intersect(valid, scene, &ctx, &rh);
    alignas(64) int hit[N];
    float p[N][3];
    bool any = false;
    for (int i = 0; i < N; ++i) {
        hit[i] = valid[i] && rh.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID ? -1 : 0;
        if (valid[i]) out.t[index[i]] = hit[i] ? rh.ray.tfar[i] : INFINITY;
        if (!hit[i]) continue;
        any = true;
        hit_point(in.origins + 3 * index[i], in.dirs + 3 * index[i], rh.ray.tfar[i], p[i]);
    }
    if (!any) return;
    for (size_t k = 0; k < in.target_total; ++k) {
        alignas(64) typename P::Ray r;
        for (int i = 0; i < N; ++i) {
            ShadowRay s = hit[i] ? shadow_ray(p[i], in.targets + 3 * k) : ShadowRay{};
            r.org_x[i] = s.org[0], r.org_y[i] = s.org[1], r.org_z[i] = s.org[2];
            r.dir_x[i] = s.dir[0], r.dir_y[i] = s.dir[1], r.dir_z[i] = s.dir[2];
            r.tnear[i] = 0.0f, r.tfar[i] = s.tfar, r.time[i] = 0.0f, r.mask[i] = ~0u, r.id[i] = 0, r.flags[i] = 0;
            rays += hit[i] ? 1 : 0;
        }
        P::occluded(hit, scene, &ctx, &r);
        for (int i = 0; i < N; ++i)
            if (hit[i]) peer_record(&out, &in, index[i], k, r.tfar[i] < 0.0f);
    }
}

// Every primary ray and its shadow rays on `threads` threads taking rows of blocks (block height
// 1 in single mode) in turn; returns the rays traced.
size_t render(RTCScene scene, const PeerInput& in, const std::string& mode, int threads, PeerOutput& out) {
    const int bw = mode == "single" ? 1 : 4, bh = mode == "packet8" ? 2 : mode == "packet16" ? 4 : 1;
    const int rows = (in.height + bh - 1) / bh, cols = (in.width + bw - 1) / bw;
    std::atomic<int> next{0};
    std::vector<size_t> counts(size_t(threads), 0);
    auto work = [&](int id) {
        size_t rays = 0;
        for (int by; (by = next.fetch_add(1)) < rows;)
            for (int bx = 0; bx < cols; ++bx) {
                if (mode == "single") trace_single(scene, in, size_t(by) * size_t(in.width) + size_t(bx), out, rays);
                else if (mode == "packet8") trace_block<8>(scene, in, bx, by, out, rays);
                else trace_block<16>(scene, in, bx, by, out, rays);
            }
        counts[size_t(id)] = rays;
    };
    std::vector<std::thread> pool;
    for (int i = 1; i < threads; ++i) pool.emplace_back(work, i);
    work(0);
    for (auto& t : pool) t.join();
    size_t total = 0;
    for (size_t c : counts) total += c;
    return total;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 6) {
        std::fprintf(stderr, "usage: %s RAYS.bin HITS.bin single|packet8|packet16 THREADS REPEAT\n", argv[0]);
        return 2;
    }
    const std::string mode = argv[3];
    const int threads = std::atoi(argv[4]), repeat = std::atoi(argv[5]);
    if ((mode != "single" && mode != "packet8" && mode != "packet16") || threads < 1 || repeat < 1) {
        std::fprintf(stderr, "bad mode, threads or repeat\n");
        return 2;
    }
    PeerInput in;
    if (!peer_read(&in, argv[1])) return 1;
    const std::string config = "threads=" + std::to_string(threads);
    RTCDevice device = rtcNewDevice(config.c_str());
    if (!device) {
        std::fprintf(stderr, "rtcNewDevice failed: %d\n", int(rtcGetDeviceError(nullptr)));
        return 1;
    }
    double best_build = INFINITY;
    RTCScene scene = nullptr;
    for (int r = 0; r < repeat; ++r) {
        if (scene) rtcReleaseScene(scene);
        scene = build_scene(device, in);
        const double start = now();
        rtcCommitScene(scene);
        best_build = std::min(best_build, now() - start);
    }
    PeerOutput out;
    peer_output_init(&out, &in);
    double best_render = INFINITY;
    size_t rays = 0;
    for (int r = 0; r < repeat; ++r) {
        const double start = now();
        rays = render(scene, in, mode, threads, out);
        best_render = std::min(best_render, now() - start);
    }
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
        std::fprintf(stderr, "Embree error %d\n", int(rtcGetDeviceError(device)));
        return 1;
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    if (!peer_write(&out, argv[2])) return 1;
    std::printf("{\"build\": %.6f, \"render\": %.6f, \"rays\": %zu}\n", best_build, best_render, rays);
    return 0;
}
