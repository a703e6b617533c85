// SPDX-License-Identifier: Apache-2.0
// Embree 3's instancing (its C API, Debian's libembree-dev) as a peer of the native tracer's
// two-level BVH: built and run by benchmarks/instances.py at benchmark time, never part of the
// package or its tests.
//
//   embree_instances INSTANCES.bin THREADS
//
// INSTANCES.bin (little-endian, written by instances.py): int32 magic, width, height, point
// count P, triangle count T, copy count K, sphere count S; float32 points (P x 3), uint32
// triangles (T x 3), float32 world-from-prototype transforms (K x 12, 3x4 row-major), float32
// world-space spheres (S x 4: centre, radius), float32 primary-ray origins and unit directions
// (width * height x 3 each, the native camera's). One prototype scene holds the triangles once;
// the top scene holds K instance geometries of it and the spheres (as the reader places them). THREADS: Embree's device
// threads and as many render threads over rows. Prints one JSON line: the build time (both
// commits), the render time (one rtcIntersect1 per pixel) and the rays that hit. Peak memory is
// the caller's measure of this whole process (/usr/bin/time -v).
#include <embree3/rtcore.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

namespace {

constexpr int32_t kMagic = 0x49525045;  // "EPRI"

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

template <class T>
bool read_into(FILE* f, std::vector<T>& v, size_t n) {
    v.resize(n);
    return std::fread(v.data(), sizeof(T), n, f) == n;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s INSTANCES.bin THREADS\n", argv[0]);
        return 2;
    }
    FILE* f = std::fopen(argv[1], "rb");
    int32_t head[7];
    if (!f || std::fread(head, sizeof(int32_t), 7, f) != 7 || head[0] != kMagic) {
        std::fprintf(stderr, "%s: not an instances file\n", argv[1]);
        return 2;
    }
    const int width = head[1], height = head[2];
    const size_t n_points = size_t(head[3]), n_triangles = size_t(head[4]), n_copies = size_t(head[5]),
                 n_spheres = size_t(head[6]);
    const size_t n_rays = size_t(width) * size_t(height);
    const int threads = std::stoi(argv[2]);
    std::vector<float> points, transforms, spheres, origins, dirs;
    std::vector<uint32_t> triangles;
    if (!read_into(f, points, 3 * n_points) || !read_into(f, triangles, 3 * n_triangles) ||
        !read_into(f, transforms, 12 * n_copies) || !read_into(f, spheres, 4 * n_spheres) ||
        !read_into(f, origins, 3 * n_rays) || !read_into(f, dirs, 3 * n_rays)) {
        std::fprintf(stderr, "%s: truncated\n", argv[1]);
        return 2;
    }
    std::fclose(f);

    const std::string config = "threads=" + std::to_string(threads);
    RTCDevice device = rtcNewDevice(config.c_str());
    const double build_start = now();
    RTCScene prototype = rtcNewScene(device);
    RTCGeometry mesh = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Shared buffers: Embree keeps pointers to this process's copy, as the native tracer keeps one.
    rtcSetSharedGeometryBuffer(mesh, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, points.data(), 0, 3 * sizeof(float),
                               n_points);
    rtcSetSharedGeometryBuffer(mesh, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, triangles.data(), 0,
                               3 * sizeof(uint32_t), n_triangles);
    rtcCommitGeometry(mesh);
    rtcAttachGeometry(prototype, mesh);
    rtcReleaseGeometry(mesh);
    rtcCommitScene(prototype);
    RTCScene top = rtcNewScene(device);
    for (size_t k = 0; k < n_copies; ++k) {
        RTCGeometry copy = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(copy, prototype);
        rtcSetGeometryTransform(copy, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, transforms.data() + 12 * k);
        rtcCommitGeometry(copy);
        rtcAttachGeometry(top, copy);
        rtcReleaseGeometry(copy);
    }
    if (n_spheres) {
        RTCGeometry balls = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        rtcSetSharedGeometryBuffer(balls, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, spheres.data(), 0,
                                   4 * sizeof(float), n_spheres);
        rtcCommitGeometry(balls);
        rtcAttachGeometry(top, balls);
        rtcReleaseGeometry(balls);
    }
    rtcCommitScene(top);
    const double build = now() - build_start;

    std::atomic<size_t> hits{0};
    std::atomic<int> next_row{0};
    const double render_start = now();
    auto work = [&] {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        size_t mine = 0;
        for (int y; (y = next_row++) < height;) {
            for (int x = 0; x < width; ++x) {
                const size_t i = size_t(y) * size_t(width) + size_t(x);
                RTCRayHit rh{};
                rh.ray.org_x = origins[3 * i];
                rh.ray.org_y = origins[3 * i + 1];
                rh.ray.org_z = origins[3 * i + 2];
                rh.ray.dir_x = dirs[3 * i];
                rh.ray.dir_y = dirs[3 * i + 1];
                rh.ray.dir_z = dirs[3 * i + 2];
                rh.ray.tnear = 0.0f;
                rh.ray.tfar = INFINITY;
                rh.ray.mask = 0xFFFFFFFFu;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(top, &context, &rh);
                mine += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            }
        }
        hits += mine;
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (std::thread& t : pool) t.join();
    const double render = now() - render_start;
    std::printf("{\"build\": %.6f, \"render\": %.6f, \"rays\": %zu, \"hits\": %zu}\n", build, render, n_rays,
                hits.load());
    rtcReleaseScene(top);
    rtcReleaseScene(prototype);
    rtcReleaseDevice(device);
    return 0;
}
