// SPDX-License-Identifier: Apache-2.0
// Pixel loop, shading of a hit, and the tile-based thread pool.
#include "render.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace phong {

namespace {

// Tiles of 16 x 16 pixels: small enough to balance 2-64 threads on a 96 x 72 test image and to
// stop within milliseconds on Ctrl-C, large enough that the shared tile counter is cold.
constexpr int kTileSize = 16;
// How often the calling thread wakes to report progress and check for Ctrl-C.
constexpr auto kPollInterval = std::chrono::milliseconds(50);

// visible_fraction()'s shadow rays from one shaded point p (lights.hpp). Shadow rays start at p;
// occluders count inside the window (math.hpp). An area light's grid is traced as a bundle
// against the primitives its hull can reach (Scene::shadow_candidates).
struct ShadowQuery {
    const Scene& scene;
    const Vec3& p;
    double window;
    std::vector<BundleCandidate>& candidates;  // of the current bundle (one per worker thread)
    bool povray_walk;                          // POV-Ray numerics: its mesh walk (povray_walk.cpp)
    bool bundle = false;

    bool begin_grid(const Vec3 (&corners)[4]) {
        const Vec3 hull[5] = {p, corners[0], corners[1], corners[2], corners[3]};
        bundle = scene.shadow_candidates(hull, 5, window, candidates);
        return !bundle || !candidates.empty();
    }

    bool operator()(const Vec3& dir, double distance) const {
        const Ray ray{p, dir};
        const bool blocked = bundle ? scene.occluded_by(candidates, ray, window, distance - window)
                                    : scene.occluded(ray, window, distance - window);
        return blocked && (!povray_walk || scene.occluded_povray_walk(ray, window, distance - window));
    }
};

RGB shade_hit(const Scene& scene, const Ray& ray, const Hit& hit, const RenderSettings& settings, double window,
              std::vector<BundleCandidate>& candidates) {
    const Vec3 p = ray.at(hit.t);
    Vec3 n;
    const Material* material;
    Material textured;  // a textured material with this point's colours
    if (hit.ref < 0) {
        const SphereShape& s = scene.spheres[size_t(~hit.ref)];
        n = sphere_normal(s, p);
        material = &scene.materials[size_t(s.material)];
    } else {
        const TriangleShape& tri = scene.triangles[size_t(hit.ref)];
        const TriangleShading& sh = scene.triangle_shading[size_t(hit.ref)];
        if (sh.n0 >= 0) {
            // Smooth: barycentric interpolation of the vertex normals, renormalised (as POV-Ray).
            n = normalize(scene.normals[size_t(sh.n0)] * hit.bary.b0 + scene.normals[size_t(sh.n1)] * hit.bary.b1 +
                          scene.normals[size_t(sh.n2)] * hit.bary.b2);
        } else {
            n = normalize(cross(tri.v1 - tri.v0, tri.v2 - tri.v0));
        }
        material = &scene.materials[size_t(sh.material)];
        if (material->diffuse_texture >= 0 || material->specular_texture >= 0) {
            // cd and cs from the textures at the hit's (u, v), interpolated like the normals.
            const double* uv = scene.corner_uv.data() + 6 * size_t(scene.triangle_source[size_t(hit.ref)]);
            const double u = uv[0] * hit.bary.b0 + uv[2] * hit.bary.b1 + uv[4] * hit.bary.b2;
            const double v = uv[1] * hit.bary.b0 + uv[3] * hit.bary.b1 + uv[5] * hit.bary.b2;
            textured = *material;
            if (material->diffuse_texture >= 0)
                textured.diffuse_color = scene.textures[size_t(material->diffuse_texture)].lookup(u, v);
            if (material->specular_texture >= 0)
                textured.specular_color = scene.textures[size_t(material->specular_texture)].lookup(u, v);
            material = &textured;
        }
    }
    // Two-sided: the shading normal faces the viewer (as POV-Ray).
    if (dot(n, ray.dir) > 0.0) n = -n;
    const Vec3 wo = -ray.dir;

    RGB color = ambient_term(*material, scene.ambient);
    for (const Light& light : scene.lights) {
        const LightSample centre = sample_light_centre(light, p);
        const double n_dot_l = dot(n, centre.l);
        // No contribution and no shadow ray; also for a NaN n·l, from a light exactly at the point
        // (d = 0: the model's answer there is the ambient term only).
        if (!(n_dot_l >= kMinCosineToLight)) continue;
        const double fraction = visible_fraction(light, p, centre, ShadowQuery{scene, p, window, candidates, settings.numerics != Numerics::kScaleInvariant});
        if (fraction == 0.0) continue;
        const LightTerms& terms = light_terms(light);
        color += shade_phong(*material, settings.specular_convention, n, wo, centre.l, n_dot_l,
                             centre.color * fraction, terms.diffuse, terms.specular);
    }
    return color;
}

}  // namespace

RGB trace_primary(const Scene& scene, const Ray& ray, const RenderSettings& settings, const RayTolerances& tolerances,
                  std::vector<BundleCandidate>& scratch) {
    Hit hit;
    if (!scene.closest_hit(ray, tolerances.primary_near, HUGE_VAL, hit)) return settings.background;
    return shade_hit(scene, ray, hit, settings, tolerances.shadow_window, scratch);
}

bool render_image(const Scene& scene, const Camera& camera, const RenderSettings& settings, float* pixels,
                  const PollFn& poll) {
    const int width = settings.width, height = settings.height, n = settings.samples;
    // The tolerances from the box of the geometry and the camera (math.hpp).
    Bounds box = scene.bounds;
    box.grow(camera.position);
    const RayTolerances tolerances =
        settings.numerics == Numerics::kPovray              ? RayTolerances{kPovrayPrimaryNear, kPovrayShadowWindow}
        : settings.numerics == Numerics::kPovrayShadowCache ? RayTolerances{kPovrayPrimaryNear, kPovrayShadowCacheWindow}
                                                            : ray_tolerances(box.lo, box.hi);

    auto render_pixel = [&](int i, int j, std::vector<BundleCandidate>& scratch) {
        auto trace_at = [&](double sx, double sy) {
            return trace_primary(scene, camera.generate(sx, sy, width, height), settings, tolerances, scratch);
        };
        RGB sum;
        int count = 0;
        if (settings.sample_pattern == SamplePattern::kPovrayAm1) {
            sum += trace_at(i + 0.5, j + 0.5);
            ++count;
        }
        if (n == 1 && settings.sample_pattern == SamplePattern::kGrid) {
            sum += trace_at(i + 0.5, j + 0.5);
            ++count;
        } else {
            for (int b = 0; b < n; ++b)
                for (int a = 0; a < n; ++a) {
                    sum += trace_at(i + (a + 0.5) / n, j + (b + 0.5) / n);
                    ++count;
                }
        }
        const RGB c = sum / double(count);
        float* out = pixels + (size_t(j) * width + i) * 3;
        out[0] = float(c.x);
        out[1] = float(c.y);
        out[2] = float(c.z);
    };

    const int tiles_x = (width + kTileSize - 1) / kTileSize, tiles_y = (height + kTileSize - 1) / kTileSize;
    const int total = tiles_x * tiles_y;
    std::atomic<int> next{0}, done{0};
    std::atomic<bool> cancel{false};
    std::mutex mutex;
    std::condition_variable progressed;

    auto worker = [&] {
        std::vector<BundleCandidate> scratch;
        while (!cancel.load(std::memory_order_relaxed)) {
            const int tile = next.fetch_add(1);
            if (tile >= total) break;
            const int x0 = (tile % tiles_x) * kTileSize, y0 = (tile / tiles_x) * kTileSize;
            const int x1 = std::min(width, x0 + kTileSize), y1 = std::min(height, y0 + kTileSize);
            for (int j = y0; j < y1; ++j)
                for (int i = x0; i < x1; ++i) render_pixel(i, j, scratch);
            // Only the last tile wakes the calling thread early: it polls on its own every
            // kPollInterval, and a wake-up per tile (thousands a second) took CPU from the
            // workers on a machine with as many cores as workers.
            if (done.fetch_add(1) + 1 == total) {
                std::lock_guard<std::mutex> lock(mutex);
                progressed.notify_one();
            }
        }
    };

    int threads = settings.threads > 0 ? settings.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    threads = std::min(threads, total);
    std::vector<std::thread> pool;
    pool.reserve(size_t(threads));
    for (int k = 0; k < threads; ++k) pool.emplace_back(worker);

    // The calling thread only waits, reports progress and relays cancellation.
    bool completed = true;
    {
        std::unique_lock<std::mutex> lock(mutex);
        int reported = -1;
        while (true) {
            const int now = done.load();
            if (now != reported || now < total) {
                lock.unlock();
                const bool keep_going = poll(now, total);
                lock.lock();
                reported = now;
                if (!keep_going) {
                    cancel = true;
                    completed = false;
                    break;
                }
            }
            if (now == total) break;
            progressed.wait_for(lock, kPollInterval, [&] { return done.load() == total; });
        }
    }
    for (std::thread& t : pool) t.join();
    return completed;
}

}  // namespace phong
