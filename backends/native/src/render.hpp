// SPDX-License-Identifier: Apache-2.0
// Rendering: primary rays per pixel (POV-Ray's sample patterns), direct Phong lighting with
// hard and area-light shadows, on a pool of worker threads over image tiles.
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include "camera.hpp"
#include "interiors.hpp"
#include "lane_shading.hpp"
#include "materials.hpp"
#include "scene.hpp"
#include "transmission.hpp"

namespace phong {

enum class SamplePattern {
    kGrid,        // n x n cell-centred grid, plain mean
    kPovrayAm1,   // POV-Ray +AM1 +A t +R n -J: (centre + n x n grid) / (n^2 + 1) where supersampled
    kPovrayAm2,   // POV-Ray +AM2 +A t +R n -J: corners, recursive 4-corner subdivision to depth n - 1
    kStratified,  // native only: pixel corners, then where they differ by >= the threshold a scrambled
                  // (0,2)-sequence, 16, 64, 256 points up to n^2 (render.cpp: stratified_pixel)
    kAdaptive,    // native only: error-driven quadtree on a tile-wide lattice, cells down to 1/n pixel
                  // (adaptive_pixels.hpp)
};

struct RenderSettings {
    int width = 1, height = 1;
    int samples = 1;  // per axis
    SamplePattern sample_pattern = SamplePattern::kGrid;
    int threads = 0;  // 0: all hardware threads
    RGB background;
    SpecularConvention specular_convention = SpecularConvention::kSeed;
    Numerics numerics = Numerics::kScaleInvariant;  // which ray tolerances (math.hpp)
    // POV-Ray's +A threshold of the adaptive patterns (0: every pixel is supersampled, AM1; the
    // full grid, AM2): compared with the colour distance of Antialias_Gamma-encoded colours.
    double aa_threshold = 0.0;
    // The deepest secondary ray (the book's max_depth): the camera ray has depth 0; a ray deeper
    // than this returns black (POV-Ray's max_trace_level max_depth + 1).
    int max_depth = 5;
    TransmissionConvention transmission_convention = TransmissionConvention::kBook;
    // The transparent objects containing the camera, whose interiors camera rays start in
    // (POV-Ray's rule; phongscene/containment.py), outermost first: (object in Scene::object_of's
    // numbering, its material in Scene::materials). Empty: outside every object.
    std::vector<std::pair<int32_t, int32_t>> camera_interiors;
};

// The deepest max_depth a render accepts (phongscene/limits.py MAX_DEPTH: POV-Ray's limit); the
// recursion is one shade_hit frame per level.
constexpr int kMaxDepth = 255;

// Called on the rendering (calling) thread about every kPollInterval with (tiles done, tiles
// total); returning false cancels the render (workers stop at their next tile).
using PollFn = std::function<bool(int, int)>;

// Renders into `pixels` (height x width x 3 floats, row 0 at the top). Returns false when
// cancelled by `poll`. The image is identical for every thread count: each pixel depends only
// on its own rays.
bool render_image(const Scene& scene, const Camera& camera, const RenderSettings& settings, float* pixels,
                  const PollFn& poll);

// What every ray of one render shares: the scene, the settings, the ray tolerances and each
// light's sample grid (lights.hpp), computed once per render.
struct TraceContext {
    const Scene& scene;
    const RenderSettings& settings;
    RayTolerances tolerances;
    std::vector<AreaLightGrid> grids;  // by light
    // Some material transmits (kt > 0) and the transmission convention is POV-Ray's: shadow rays
    // are then filtered by the transmissive objects they cross (render.cpp: shadow_filter). In
    // the book's convention every object casts an opaque shadow, transparent ones too (Suffern's
    // Whitted tracer: its shadow rays test every object's shadow_hit alike).
    bool filtered_shadows = false;
    // POV-Ray's convention: glass filters the light of shadow rays crossing it (the book's:
    // blocks it, as any object).
    bool glass_filters_light = false;
    // Some material has a cut-out mask (Material::opacity_texture): rays pass its cut-out texels
    // (render.cpp: past_cut_outs), shadow rays too (filtered_shadows).
    bool cut_outs = false;
    // POV-Ray numerics: shadow rays see meshes as POV-Ray's mesh walk reports them (povray_walk.cpp).
    bool povray_walk = false;
    // A packet's primary hits may be lit in AVX2 lanes (render.cpp: shade_packet): the scene's
    // lights allow it (lane_shading.hpp: lane_lights) and no shadow is filtered.
    bool lane_shading = false;
    std::vector<LaneMaterial> lane_materials;  // by material, where lane_shading
    // The interiors camera rays start in (RenderSettings::camera_interiors).
    Interiors camera_inside;

    TraceContext(const Scene& scene, const RenderSettings& settings, const RayTolerances& tolerances);
};

// The colour seen along one primary ray (exposed for tests and the pixel loop). `scratch` holds
// shadow-bundle candidates (Scene::shadow_candidates); one per thread, reused from ray to ray.
// `origin`: FloatSlabOrigin(ray.origin) when the caller shares it between rays, else nullptr.
RGB trace_primary(const TraceContext& context, const Ray& ray, std::vector<BundleCandidate>& scratch,
                  const FloatSlabOrigin* origin = nullptr);
// The colour seen along primary ray `ray` whose closest hit (found or not) is known.
RGB shade_primary(const TraceContext& context, const Ray& ray, bool found, Hit hit,
                  std::vector<BundleCandidate>& scratch);

}  // namespace phong
