// SPDX-License-Identifier: Apache-2.0
// Pixel loop, shading of a hit, and the tile-based thread pool.
#include "render.hpp"

#include "adaptive_pixels.hpp"
#include "bvh8_packet.hpp"
#include "interiors.hpp"
#include "low_discrepancy.hpp"
#include "normal_maps.hpp"
#include "uninitialised.hpp"

#include <algorithm>
#include <cassert>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>
#include <vector>

namespace phong {

namespace {

// Tiles of 16 x 16 pixels: small enough to balance 2-64 threads on a 96 x 72 test image and to
// stop within milliseconds on Ctrl-C, large enough that the shared tile counter is cold.
constexpr int kTileSize = 16;
// The pixel blocks whose primary rays are traced as one packet (bvh8_packet.hpp): 8 x 4, as
// square as 32 rays go, for the narrowest interval of directions. Render instructions with
// 8 rays (4 x 2) → 16 (4 x 4) → 32 sharing each node visit: S2 −4.9 % then −2.7 %, S1 −3.4 %
// then −2.0 % (benchmarks/README.md, issue 25).
constexpr int kPacketWidth = 8, kPacketHeight = 4;
static_assert(kPacketWidth * kPacketHeight == kPacketRays);
// Packets shaded together (two blocks across: 16 x 4 pixels): a light's shadow rays from their
// points walk the tree together (Scene::occluded_each), up to 64 rays sharing each node visit.
// Measured against one packet at a time (then of eight rays): two packets, S1's render −5 % and
// S2's −2.5 %; four, S2's −5 % more; eight, −3 % more (benchmarks/README.md, issue 25).
constexpr int kShadedAcross = 2, kShadedDown = 1, kShadedPackets = kShadedAcross * kShadedDown;
static_assert(kShadedAcross * kPacketWidth <= kTileSize && kShadedDown * kPacketHeight <= kTileSize);
// How often the calling thread wakes to report progress and check for Ctrl-C.
constexpr auto kPollInterval = std::chrono::milliseconds(50);
// POV-Ray renders in blocks of Render_Block_Size = 32 pixels from the top left (view.cpp), and
// its adaptive +AM1 decides each block on its own (tracetask.cpp: the pixels left of and above a
// block are traced, never supersampled): the adaptive AM1 tiles are those blocks.
constexpr int kPovrayBlockSize = 32;
// POV-Ray's Antialias_Gamma default (view.cpp): the +A threshold compares colours encoded as
// max(c, 0)^(1/2.5), in float (colourspace.cpp: PowerLawGammaCurve).
constexpr float kPovrayAntialiasEncodingExponent = 1.0f / 2.5f;
// POV-Ray passes a ray between two media whose indices differ by less than its EPSILON (1e-10,
// configbackend.h) straight on, as a continued ray that uses no trace level (trace.cpp,
// ComputeRefraction: TraceRay(..., continuedRay = true); ref §18).
constexpr double kPovraySameIorEpsilon = 1e-10;

// The native "stratified" pixel estimator's points: low_discrepancy.hpp.

// A colour as POV-Ray's threshold test sees it: float, gamma-encoded.
struct EncodedColour {
    float r, g, b;
    explicit EncodedColour(const RGB& c)
        : r(std::pow(std::max(float(c.x), 0.0f), kPovrayAntialiasEncodingExponent)),
          g(std::pow(std::max(float(c.y), 0.0f), kPovrayAntialiasEncodingExponent)),
          b(std::pow(std::max(float(c.z), 0.0f), kPovrayAntialiasEncodingExponent)) {}
};
// POV-Ray's Colour_Distance_RGBT (the transmit of opaque hits and of the background is 0).
inline double colour_distance(const EncodedColour& a, const EncodedColour& b) {
    return std::fabs(double(a.r) - double(b.r)) + std::fabs(double(a.g) - double(b.g)) +
           std::fabs(double(a.b) - double(b.b));
}

// visible_fraction()'s shadow rays from one shaded point p (lights.hpp). Shadow rays start at p;
// occluders count inside the window (math.hpp). An area light's grid is traced as a bundle
// against the primitives its hull can reach (Scene::shadow_candidates).
struct ShadowQuery {
    const Scene& scene;
    const Vec3& p;
    const FloatSlabOrigin& p_rounded;  // p for the BVH's float test, rounded once per shaded point
    double window;
    std::vector<BundleCandidate>& candidates;  // of the current bundle (one per worker thread)
    bool povray_walk;                          // POV-Ray numerics: its mesh walk (povray_walk.cpp)
    // The light's shadow link (LightLinking::casts), or nullptr: every object casts its shadows.
    // A linked light's rays go one by one through occluded_linked() (no bundles, no mesh walk:
    // the walk's quirk is POV-Ray's on a mesh that casts the shadow, and a shadow link's
    // objects are written per pass with no_shadow, ref §6).
    const unsigned char* casts = nullptr;
    bool bundle = false;

    bool begin_grid(const Vec3 (&corners)[4]) {
        // Linked lights and unbounded planes (outside the BVH the bundle walks): ray by ray.
        if (casts != nullptr || !scene.planes.empty()) return true;
        const Vec3 hull[5] = {p, corners[0], corners[1], corners[2], corners[3]};
        bundle = scene.shadow_candidates(hull, 5, window, candidates);
        return !bundle || !candidates.empty();
    }

    // Always inlined: one call per shadow ray (out of line, as GCC left it once the cells estimator
    // also called it, it cost 3% of S1's instructions).
    [[gnu::always_inline]] bool operator()(const Vec3& dir, double distance) const {
        const Ray ray{p, dir};
        if (casts != nullptr) return scene.occluded_linked(ray, p_rounded, window, distance - window, casts);
        const bool blocked = bundle ? scene.occluded_by(candidates, ray, window, distance - window)
                                    : scene.occluded(ray, p_rounded, window, distance - window);
        return blocked && (!povray_walk || scene.occluded_povray_walk(ray, window, distance - window));
    }

    // Whether a grid's directions may be computed in AVX2 lanes (lights.hpp): where the scene
    // took the AVX2 path (simd_dispatch.hpp).
    bool quads() const { return scene.walk_width() == 8; }

    // Every ray of a full grid at once (lights.hpp): ray k along (x[k], y[k], z[k]), blocked[k]
    // is operator()(that direction, distance[k]). The arrays are padded to an even length
    // (occluded_by_each reads them in pairs).
    void each(const double* x, const double* y, const double* z, const double* distance, size_t count,
              unsigned char* blocked) const {
        auto dir = [&](size_t k) { return Vec3{x[k], y[k], z[k]}; };
        if (casts != nullptr) {
            for (size_t k = 0; k < count; ++k) blocked[k] = (*this)(dir(k), distance[k]);
            return;
        }
        if (bundle) {
            scene.occluded_by_each(candidates, p, x, y, z, distance, count, window, blocked);
        } else {
            for (size_t k = 0; k < count; ++k)
                blocked[k] = scene.occluded(Ray{p, dir(k)}, p_rounded, window, distance[k] - window);
        }
        if (povray_walk)
            for (size_t k = 0; k < count; ++k)
                if (blocked[k]) blocked[k] = scene.occluded_povray_walk(Ray{p, dir(k)}, window, distance[k] - window);
    }
};

// `inside`: the interiors the ray travels in (interiors.hpp).
RGB trace_secondary(const TraceContext& context, const Ray& ray, int depth, std::vector<BundleCandidate>& candidates,
                    const Interiors& inside);

const Material& material_of(const Scene& world, const Hit& hit) {
    const Scene& scene = world.surface_of(hit);  // an instance's primitives are its prototype's
    const int32_t m = scene.is_sphere(hit.ref) ? scene.spheres[size_t(~hit.ref)].material
                      : scene.is_ball(hit.ref) ? scene.ball_group(scene.ball_index(hit.ref)).material
                      : hit.ref < 0            ? scene.intrinsic(hit.ref).material
                                               : scene.triangle_material(size_t(hit.ref));
    return scene.materials[size_t(m)];
}

// The (u, v) of a triangle hit at p on `surface` (the world, or the instance's prototype), as the
// textures take it: the corner uvs interpolated like the normals.
void hit_uv(const Scene& surface, const Hit& hit, const Vec3& p, double& u, double& v) {
    const double* uv = surface.corner_uv + 6 * size_t(surface.triangle_source[size_t(hit.ref)]);
    if (!surface.povray_triangles.empty() && hit.instance < 0) {
        // POV-Ray's own weights on the SDL's uvs, mapped back (povray_mesh_uv).
        const size_t slot = size_t(hit.ref);
        povray_mesh_uv(surface.povray_triangles[slot], surface.triangles.local(slot), surface.triangles.origin(slot), p,
                       uv, u, v);
        u = surface.uv_origin[0] + surface.uv_span[0] * u;
        v = surface.uv_origin[1] + surface.uv_span[1] * v;
    } else {
        u = uv[0] * hit.bary.b0 + uv[2] * hit.bary.b1 + uv[4] * hit.bary.b2;
        v = uv[1] * hit.bary.b0 + uv[3] * hit.bary.b1 + uv[5] * hit.bary.b2;
    }
}

// Whether `hit` on `ray` falls where a material's cut-out mask removes the surface (its
// opacity below the threshold, looked up as the colours are). Triangles only: masks are read on
// meshes with uvs.
bool cut_out(const Scene& world, const Ray& ray, const Hit& hit) {
    if (hit.ref < 0) return false;
    const Scene& surface = world.surface_of(hit);
    const Material& m = surface.materials[size_t(surface.triangle_material(size_t(hit.ref)))];
    if (m.opacity_texture < 0) return false;
    double u, v;
    hit_uv(surface, hit, ray.at(hit.t), u, v);
    return surface.textures[size_t(m.opacity_texture)].lookup(u, v).x < m.opacity_threshold;
}

// A material with a cut-out mask (render.cpp treats its surfaces as never wholly opaque, as
// POV-Ray treats an object whose texture transmits).
bool has_cut_out(const Scene& world, const Hit& hit) {
    if (hit.ref < 0) return false;
    const Scene& surface = world.surface_of(hit);
    return surface.materials[size_t(surface.triangle_material(size_t(hit.ref)))].opacity_texture >= 0;
}

// From `hit` on `ray`, the first surface a cut-out mask does not remove (scenes with a mask only):
// a cut-out texel passes the ray on unchanged, as a ray continued from the hit at the same depth
// (POV-Ray's through a texel that transmits all). On return `ray` is the ray the hit is on and
// `travelled` the distance covered before its origin. More crossings than any scene needs: a miss.
bool past_cut_outs(const TraceContext& context, Ray& ray, Hit& hit, double& travelled) {
    travelled = 0.0;
    for (int crossings = 0; crossings < kMaxCutOutCrossings; ++crossings) {
        if (!cut_out(context.scene, ray, hit)) return true;
        travelled += hit.t;
        ray = Ray{ray.at(hit.t), ray.dir};
        if (!context.scene.closest_hit(ray, context.tolerances.secondary_near, HUGE_VAL, hit)) return false;
    }
    return false;
}

// The interior of the object hit (interiors.hpp): an instance's copy is its own.
Interior interior_of(const Scene& world, const Hit& hit) {
    return Interior{hit.instance, world.surface_of(hit).object_of(hit.ref), &material_of(world, hit)};
}

// POV-Ray's shadow cache (ref §6) seen through glass: the thread's cached opaque occluder is
// tested first, from P over the whole ray, so an opaque object behind a transmissive one
// shadows P even where the crossing's segment search would miss it (a crossing a hair from a
// mesh hides that mesh: povray_walk.cpp). The cache's state depends on the pixels the thread
// rendered before; the shadow-cache numerics (diff's explanation) assume it holds the occluder.
bool opaque_behind_glass(const TraceContext& context, const Ray& ray, double t_min, double t_max,
                         const unsigned char* casts) {
    const Scene& scene = context.scene;
    double from = t_min;
    for (int crossings = 0; crossings <= kMaxShadowCrossings; ++crossings) {
        Hit hit;
        if (!scene.closest_hit_povray_walk(ray, from, t_max, hit)) return false;
        const bool casts_shadow = casts == nullptr || hit.instance >= 0 || casts[size_t(scene.object_of(hit.ref))];
        if (casts_shadow && !(material_of(scene, hit).kt > 0.0) && !has_cut_out(scene, hit)) return true;
        from = hit.t;
    }
    return false;
}

// How much of a light at `distance` along unit l reaches p through transmissive objects, as
// POV-Ray computes it (ref §18): the shadow ray goes straight (no refraction), an opaque object
// blocks it, and each crossing of a transmissive surface multiplies it by kt. Each segment
// counts hits in the shadow window, as an opaque shadow ray does, from the last crossing on.
// The ray starts in the shaded ray's interiors and, at each transmissive surface, leaves that
// object's interior if it is in it, else enters it (POV-Ray's ComputeShadowMedia). A crossing of
// a surface whose interior the ray is in is faded by Beer-Lambert over the segment since the
// last crossing (POV-Ray's fade, ComputeShadowTexture, ref §18); nothing else is: not an
// enclosing interior's stretch before a nested object, nor the last stretch to a light inside
// glass (no surface there). With the light's shadow link (`casts`, or nullptr: every object
// casts) an object outside it is passed through untouched, neither blocking nor filtering nor
// entering its interior: POV-Ray's `no_shadow` in the exact mapping's pass, which its shadow rays
// never meet. (Instances all cast, as in Scene::occluded_linked.)
RGB shadow_filter(const TraceContext& context, const Vec3& p, const Vec3& l, double distance, Interiors inside,
                  const unsigned char* casts) {
    const double window = context.tolerances.shadow_window;
    if (context.settings.numerics == Numerics::kPovrayShadowCache &&
        opaque_behind_glass(context, Ray{p, l}, window, distance - window, casts))
        return RGB{};
    RGB filter{1.0, 1.0, 1.0};
    Vec3 from = p;
    double remaining = distance;
    double segment = 0.0;  // since the last crossing of a casting surface
    for (int crossings = 0; crossings <= kMaxShadowCrossings; ++crossings) {
        Hit hit;
        const Ray ray{from, l};
        const bool found = context.povray_walk
                               ? context.scene.closest_hit_povray_walk(ray, window, remaining - window, hit)
                               : context.scene.closest_hit(ray, window, remaining - window, hit);
        if (!found) return filter;
        const Material& m = material_of(context.scene, hit);
        const bool casts_shadow =
            (casts == nullptr || hit.instance >= 0 || casts[size_t(context.scene.object_of(hit.ref))]) &&
            !(context.cut_outs && cut_out(context.scene, ray, hit));  // a cut-out texel passes the light
        segment += hit.t;
        if (casts_shadow) {
            // Opaque, or glass in the book's convention (its shadows are opaque): blocked.
            if (!(m.kt > 0.0) || !context.glass_filters_light) return RGB{};
            const Interior crossed = interior_of(context.scene, hit);
            if (inside.contains(crossed)) filter = hadamard(filter, medium_transmittance(&m, segment));
            filter = filter * m.kt;
            inside.toggle(crossed);
            segment = 0.0;
        }
        from = ray.at(hit.t);
        remaining -= hit.t;
    }
    return RGB{};  // more crossings than any scene needs: treated as blocked
}

// shade_hit's tail: `color` (the hit's Phong terms) plus what its mirror and transmitted rays
// bring, for a material that traces either (kr > 0 or kt > 0) below max_depth. `n` faces the
// ray. Out of line: most surfaces trace neither, and inlined, this tail's registers and stack
// were paid by every shaded point.
[[gnu::noinline]] RGB add_secondary_rays(const TraceContext& context, const Ray& ray, const Hit& hit, const Vec3& p,
                                         const Vec3& n, const Material& m, bool back_facing, RGB color, int depth,
                                         const Interiors& inside, std::vector<BundleCandidate>& candidates) {
    const Scene& scene = context.scene;
    const RenderSettings& settings = context.settings;
    const Material* material = &m;
    const Vec3 wo = -ray.dir;
    // Transparency (transmission.hpp): under total internal reflection the mirror ray at full
    // weight replaces both the kr and the kt terms.
    const bool book = settings.transmission_convention == TransmissionConvention::kBook;
    const bool transmissive = material->kt > 0.0;
    // The index ratio across the surface in the ray's direction (n_to / n_from) for the refracted
    // ray (eta) and for the Fresnel split (fresnel_eta), and the interiors of the refracted and
    // the reflected rays. A reflected ray keeps its side.
    double eta, fresnel_eta;
    Interiors refracted_inside;  // the book's: none, or this object's
    Interiors reflected_inside = inside;
    if (book || !transmissive) {
        const bool leaving = back_facing;
        eta = fresnel_eta = leaving ? 1.0 / material->ior : material->ior;
        if (transmissive && !leaving) refracted_inside.append(interior_of(scene, hit));
        if (book && transmissive && leaving) {  // the reflected ray stays inside (Suffern)
            reflected_inside = Interiors{};
            reflected_inside.append(interior_of(scene, hit));
        }
    } else {
        // POV-Ray's rules (trace.cpp ComputeRefraction for the ray, ComputeRelativeIOR for
        // Fresnel; 3.7.0.8, ref §18), with (X / X) a ray entering / leaving X:
        //   outside every object: enter (ior)
        //   leaving the innermost: into the next one out (n_next / ior; 1 / ior to the outside);
        //     Fresnel takes the innermost twice when there is a next one out: ratio 1, F = 0
        //   leaving an object that is not the innermost, (A (B A): ratio 1, the ray continues
        //     unrefracted into B; Fresnel takes B / A
        //   entering while inside: ior / n_innermost (the innermost is left "for" the new one)
        const Interior here = interior_of(scene, hit);
        const double ior = here.material->ior;
        refracted_inside = inside;
        if (inside.empty()) {
            eta = fresnel_eta = ior;
            refracted_inside.append(here);
        } else if (inside.innermost().same_object(here)) {
            refracted_inside.remove(here);
            eta = refracted_inside.empty() ? 1.0 / ior : refracted_inside.innermost().material->ior / ior;
            fresnel_eta = inside.size() == 1 ? 1.0 / ior : 1.0;
        } else if (refracted_inside.remove(here)) {
            eta = 1.0;
            fresnel_eta = inside.innermost().material->ior / ior;
        } else {
            eta = fresnel_eta = ior / inside.innermost().material->ior;
            refracted_inside.append(here);
        }
    }
    Vec3 refracted;
    double cos_t = 1.0;
    const bool refracts = transmissive && refract_direction(ray.dir, n, eta, refracted, cos_t);
    // POV-Ray's continued ray: unrefracted, at this ray's depth (the book counts every crossing).
    const bool continued = !book && refracts && std::fabs(eta - 1.0) < kPovraySameIorEpsilon;
    // Beer-Lambert: the book filters every ray over its path inside an interior (trace_secondary);
    // POV-Ray only what a transparent surface transmits (refracted, or internally reflected),
    // over the incoming ray's path inside this surface's interior (ref §18: its reflections and
    // opaque hits inside are not faded, nor is the stretch of an enclosing interior before a
    // nested object).
    RGB carried{1.0, 1.0, 1.0};
    if (!book && transmissive && inside.contains(interior_of(scene, hit)))
        carried = medium_transmittance(&material_of(scene, hit), hit.t);
    if (transmissive && !refracts)
        return color + hadamard(trace_secondary(context, Ray{p, mirror_direction(ray.dir, n)}, depth + 1, candidates,
                                                reflected_inside),
                                carried);
    // The dielectric's Fresnel split. An opaque fresnel material reflects as the surface of an ior
    // interior (as POV-Ray); where Snell has no solution cos θt = 0, so F = 1.
    double reflectance = 1.0;
    if (material->fresnel) {
        const double cos_i = dot(n, wo);
        const bool own_ratio = fresnel_eta != eta;  // only where POV-Ray's two rules differ
        if (!refracts || own_ratio)
            cos_t = std::sqrt(std::fmax(0.0, 1.0 - (1.0 - cos_i * cos_i) / (fresnel_eta * fresnel_eta)));
        reflectance = fresnel_reflectance(cos_i, cos_t, fresnel_eta);
    }
    // Mirror reflection on top of the Phong terms (ref §18: POV-Ray adds it the same way).
    if (material->kr > 0.0) {
        const Ray reflected{p, mirror_direction(ray.dir, n)};
        const RGB seen = trace_secondary(context, reflected, depth + 1, candidates, reflected_inside);
        color += hadamard(material->reflective_color, seen) * (material->kr * reflectance);
    }
    if (refracts) {
        const double kt = material->fresnel ? material->kt * (1.0 - reflectance) : material->kt;
        const double weight = book ? kt / (eta * eta) : kt;
        const Ray transmitted{p, continued ? ray.dir : refracted};
        color +=
            hadamard(trace_secondary(context, transmitted, continued ? depth : depth + 1, candidates, refracted_inside),
                     carried) *
            weight;
    }
    return color;
}

// The colour of `hit` on `ray`, a ray of depth `depth` (the camera's: 0).
RGB shade_hit(const TraceContext& context, const Ray& ray, const Hit& hit, std::vector<BundleCandidate>& candidates,
              int depth, const Interiors& inside) {
    const Scene& scene = context.scene;
    const RenderSettings& settings = context.settings;
    const double window = context.tolerances.shadow_window;
    const Vec3 p = ray.at(hit.t);
    // The object hit, for light linking (only looked up when a light links).
    // An instance's copies are not told apart by any link (the backend flattens those that are):
    // its hits are lit by every light, with the light's shadow switch.
    const bool linked = !scene.light_links.empty();
    const int32_t object = !linked || hit.instance >= 0 ? -1 : scene.object_of(hit.ref);
    Vec3 n;
    const Material* material;
    // A copy of the material with this point's colours (a texture, checker or instance colour),
    // left unconstructed until one applies: a default Material is ~20 stores a hit. (Material is
    // trivially copyable; the copy assignments below begin its lifetime.)
    union Unconstructed {
        Unconstructed() {}
        Material material;
    } copy;
    Material& textured = copy.material;
    Vec3 mapped_normal;  // n perturbed by the material's normal map (normal_maps.hpp), where it has one
    bool normal_mapped = false;
    // The primitive's own scene: the world's, or the prototype of the instance hit (whose normal
    // is then carried to the world below).
    const Scene& surface = scene.surface_of(hit);
    if (surface.is_round(hit.ref)) {
        SphereShape scratch;
        const SphereShape& s = surface.round_shape(hit.ref, scratch);
        n = sphere_normal(s, p);
        material = &surface.materials[size_t(s.material)];
    } else if (hit.ref < 0) {
        const IntrinsicShape& part = surface.intrinsic(hit.ref);
        n = intrinsic_normal(part, p);
        material = &surface.materials[size_t(part.material)];
    } else {
        // The corners (widened from the store: ~70 instructions a hit) only where they are used:
        // a flat normal, a normal map's tangents.
        auto corners = [&] { return surface.triangles[size_t(hit.ref)]; };
        const TriangleNormals* sh =
            surface.triangle_normals.empty() ? nullptr : &surface.triangle_normals[size_t(hit.ref)];
        const int32_t mesh = surface.triangle_mesh(size_t(hit.ref));
        if (sh && sh->n0 >= 0) {
            // Smooth: barycentric interpolation of the vertex normals, renormalised (as POV-Ray).
            n = normalize(surface.normals[size_t(sh->n0)] * hit.bary.b0 +
                          surface.normals[size_t(sh->n1)] * hit.bary.b1 +
                          surface.normals[size_t(sh->n2)] * hit.bary.b2);
        } else if (const Vec3* kept = surface.flat_normal(size_t(hit.ref), mesh)) {
            n = *kept;
        } else {
            n = flat_triangle_normal(corners());
        }
        material = &surface.materials[size_t(surface.mesh_material(mesh))];
        if (material->diffuse_texture >= 0 || material->specular_texture >= 0 || material->normal_texture >= 0) {
            // cd and cs from the textures at the hit's (u, v), interpolated like the normals.
            const double* uv = surface.corner_uv + 6 * size_t(surface.triangle_source[size_t(hit.ref)]);
            double u, v;
            hit_uv(surface, hit, p, u, v);
            if (material->normal_texture >= 0) {
                Vec3 dpdu, dpdv;
                const TriangleShape tri = corners();
                if (uv_tangents(tri.v0, tri.v1, tri.v2, uv, dpdu, dpdv)) {
                    mapped_normal = perturbed_normal(n, dpdu, dpdv,
                                                     surface.textures[size_t(material->normal_texture)].lookup(u, v));
                    normal_mapped = true;
                }
            }
            textured = *material;
            if (material->diffuse_texture >= 0)
                textured.diffuse_color = surface.textures[size_t(material->diffuse_texture)].lookup(u, v);
            if (material->specular_texture >= 0)
                textured.specular_color = surface.textures[size_t(material->specular_texture)].lookup(u, v);
            material = &textured;
        }
    }
    if (material->checker_size > 0.0) {  // the book's Checker3D or PlaneChecker: cd by the cell of p (world space)
        const RGB cd = material->checker_plane
                           ? plane_checker_colour(*material, p, settings.numerics == Numerics::kScaleInvariant)
                           : checker_colour(*material, p);
        if (material != &textured) textured = *material;
        textured.diffuse_color = cd;
        material = &textured;
    }
    if (hit.instance >= 0 && material->instance_color) {  // cd per copy (a per-instance primvar)
        if (const RGB* cd = scene.instances->color_of(hit.instance)) {
            if (material != &textured) textured = *material;
            textured.diffuse_color = *cd;
            material = &textured;
        }
    }
    if (hit.instance >= 0) {
        n = normalize(scene.instances->normal_to_world(hit.instance, n));
        if (normal_mapped) mapped_normal = normalize(scene.instances->normal_to_world(hit.instance, mapped_normal));
    }
    // Two-sided: the shading normal faces the viewer (as POV-Ray). The unflipped normal points
    // out of a closed object, so a ray meeting it from behind is leaving the interior (the book's
    // rule, Suffern's Dielectric). POV-Ray instead knows which interiors a ray is in (its
    // history, interiors.hpp): a transmissive surface is left only by a ray inside its interior.
    // The two differ where an interpolated normal turns away from a ray entering near a smooth
    // mesh's silhouette, and wherever transparent objects nest or overlap; in the POV-Ray
    // convention its rule decides. (The side is the surface's, not the normal map's: a map tilting
    // the normal past the view ray does not turn the surface inside out.)
    const bool back_facing = dot(n, ray.dir) > 0.0;
    if (normal_mapped) n = mapped_normal;
    // The book lights a transparent surface with its unflipped normal, also where a ray inside
    // meets it (Suffern's Sphere::hit does not turn the normal; Phong::shade takes n·wi > 0): a
    // light outside can then add a highlight seen from within, unless a shadow ray is blocked
    // (figure 27.23, whose light casts no shadows). POV-Ray, and every other surface here, shade
    // with the normal facing the ray.
    const bool book_inside_glass =
        back_facing && material->kt > 0.0 && settings.transmission_convention == TransmissionConvention::kBook;
    if (back_facing) n = -n;
    const Vec3 lighting_normal = book_inside_glass ? -n : n;
    const Vec3 wo = -ray.dir;

    RGB color = ambient_term(*material, scene.ambient);
    color += material->emission;  // Le: + 0 is exact, so unlit materials shade as before
    const bool povray_walk = context.povray_walk;
    const FloatSlabOrigin p_rounded(p);
    for (size_t j = 0; j < scene.lights.size(); ++j) {
        const LightLinking* link = linked ? &scene.light_links[j] : nullptr;
        if (object >= 0 && !link->lit.empty() && !link->lit[size_t(object)]) continue;  // not in its light link
        // The light's alternative decides its centre and shadow; the shading is the same for all
        // (one inlined copy of it, not one per alternative). Always inlined, as visit_light is:
        // out of line, the call per light and shaded point cost S1's render ~6 % of its instructions.
        LightSample centre;
        double n_dot_l = 0.0, fraction = 0.0;
        const LightTerms* terms = nullptr;
        auto shade_light = [&](const auto& light) __attribute__((always_inline)) {
            centre = sample_light_centre(light, p);
            n_dot_l = dot(lighting_normal, centre.l);
            // No contribution and no shadow ray; also for a NaN n·l, from a light exactly at
            // the point (d = 0: the model's answer there is the ambient term only).
            if (!(n_dot_l >= kMinCosineToLight)) return;
            terms = &light.terms;
            if (link != nullptr && !link->shadows) {
                fraction = 1.0;  // shadow:enable off: no shadow ray, the light arrives whole
                return;
            }
            using T = std::decay_t<decltype(light)>;
            if constexpr (std::is_same_v<T, RectAreaLight> || std::is_same_v<T, SphereAreaLight>) {
                if (context.filtered_shadows) {
                    // Every grid sample's shadow ray filtered as a point light's is, the
                    // colours summed with the grid's weights, as POV-Ray averages its samples'
                    // colours; or, under `adaptive n`, POV-Ray's recursion on those colours
                    // (Python validates: no cells estimator here).
                    assert(light.cell_samples == 0);
                    const unsigned char* casts = link != nullptr && !link->casts.empty() ? link->casts.data() : nullptr;
                    const AreaLightGrid& grid = context.grids[j];
                    auto filter_of = [&](size_t k) {
                        const Vec3 v = area_light_sample(light, grid, centre.l, k) - p;
                        const double d = length(v);
                        return shadow_filter(context, p, v / d, d, inside, casts);
                    };
                    RGB filtered{};
                    if (light.adaptive != kFullSubdivision) {
                        const RGB arriving{double(float(centre.color.x)), double(float(centre.color.y)),
                                           double(float(centre.color.z))};
                        const size_t count = size_t(grid.n) * size_t(grid.n);
                        thread_local std::vector<RGB> samples;
                        thread_local std::vector<unsigned char> traced;
                        samples.resize(count);
                        traced.assign(count, 0);
                        auto filter_at = [&](int a, int b) {
                            return filter_of(size_t(a) * size_t(grid.n) + size_t(b));
                        };
                        filtered = detail::adaptive_filter(0, 0, grid.n - 1, grid.n - 1, 0, light.adaptive, arriving,
                                                           grid.n, samples, traced, filter_at);
                    } else {
                        for (size_t k = 0; k < grid.weight.size(); ++k) filtered += filter_of(k) * grid.weight[k];
                    }
                    centre.color = hadamard(centre.color, filtered);
                    fraction = 1.0;
                    return;
                }
            }
            if constexpr (std::is_same_v<T, PointLight> || std::is_same_v<T, DirectionalLight>) {
                if (context.filtered_shadows) {  // filtered by transmissive occluders
                    const unsigned char* casts = link != nullptr && !link->casts.empty() ? link->casts.data() : nullptr;
                    // (Inside an object that casts none of this light's shadows the ray never
                    // crosses its surface, so its interior does not filter the light.)
                    centre.color =
                        hadamard(centre.color, shadow_filter(context, p, centre.l, centre.distance, inside, casts));
                    fraction = 1.0;
                    return;
                }
            }
            ShadowQuery query{scene, p, p_rounded, window, candidates, povray_walk};
            if (link != nullptr && !link->casts.empty()) query.casts = link->casts.data();
            fraction = visible_fraction(light, context.grids[j], p, centre, query);
        };
        visit_light(scene.lights[j], shade_light);
        if (fraction == 0.0) continue;  // unlit, or wholly in shadow
        color += shade_phong(*material, settings.specular_convention, lighting_normal, wo, centre.l, n_dot_l,
                             centre.color * fraction, terms->diffuse, terms->specular);
    }
    // Secondary rays; one that would be deeper than max_depth returns black, so it is not traced.
    // (A seed material, kr = kt = 0, stops here.)
    if (depth >= settings.max_depth || !(material->kr > 0.0 || material->kt > 0.0)) return color;
    return add_secondary_rays(context, ray, hit, p, n, *material, back_facing, color, depth, inside, candidates);
}

// What a ray that hits nothing sees: the environment along its direction, else the background.
RGB miss(const TraceContext& context, const Ray& ray) {
    const Environment& environment = context.scene.environment;
    if (!environment.present()) return context.settings.background;
    return environment.lookup(ray.dir, context.settings.numerics != Numerics::kScaleInvariant);
}

// The colour seen along a secondary ray leaving a surface (a miss: miss()).
RGB trace_secondary(const TraceContext& context, const Ray& ray, int depth, std::vector<BundleCandidate>& candidates,
                    const Interiors& inside) {
    Hit hit;
    const bool book = context.settings.transmission_convention == TransmissionConvention::kBook;
    const Material* medium = inside.innermost_material();  // the book's: at most one
    Ray on = ray;
    double travelled = 0.0;
    if (!context.scene.closest_hit(ray, context.tolerances.secondary_near, HUGE_VAL, hit) ||
        (context.cut_outs && !past_cut_outs(context, on, hit, travelled))) {
        const RGB missed = miss(context, ray);
        return book ? hadamard(missed, medium_transmittance(medium, HUGE_VAL)) : missed;
    }
    const RGB seen = shade_hit(context, on, hit, candidates, depth, inside);
    return medium == nullptr || !book ? seen : hadamard(seen, medium_transmittance(medium, travelled + hit.t));
}

}  // namespace

TraceContext::TraceContext(const Scene& scene_, const RenderSettings& settings_, const RayTolerances& tolerances_)
    : scene(scene_), settings(settings_), tolerances(tolerances_) {
    for (const Light& light : scene.lights) grids.push_back(area_light_grid(light));
    bool transmissive = false;
    for (const Material& m : scene.materials) transmissive = transmissive || m.kt > 0.0;
    if (scene.instances)
        for (size_t p = 0; p < scene.instances->prototype_count(); ++p)
            for (const Material& m : scene.instances->prototype(p).materials) transmissive = transmissive || m.kt > 0.0;
    glass_filters_light = settings.transmission_convention == TransmissionConvention::kPovray;
    cut_outs = false;
    for (const Material& m : scene.materials) cut_outs = cut_outs || m.opacity_texture >= 0;
    if (scene.instances)
        for (size_t p = 0; p < scene.instances->prototype_count(); ++p)
            for (const Material& m : scene.instances->prototype(p).materials)
                cut_outs = cut_outs || m.opacity_texture >= 0;
    // Shadow rays go surface by surface where glass filters them or a mask can let light through.
    filtered_shadows = (transmissive && glass_filters_light) || cut_outs;
    povray_walk = settings.numerics != Numerics::kScaleInvariant;
    lane_shading = lane_lights(scene) && !filtered_shadows;
    if (lane_shading)
        for (const Material& m : scene.materials) lane_materials.emplace_back(m, scene.ambient);
    for (const auto& [object, material] : settings.camera_interiors) {
        assert(material >= 0 && size_t(material) < scene.materials.size());  // bindings.cpp checks it
        camera_inside.append(Interior{-1, object, &scene.materials[size_t(material)]});
    }
}

namespace {

// The colours of a packet's primary rays (or of up to kShadedPackets packets') whose closest hits are known: colour[k]
// is shade_primary(rays[k], found[k], hits[k])'s to the bit. Where the render allows it (TraceContext::lane_shading)
// the direct lighting of the points lane_material takes is added in lanes (lane_shading.hpp), the rest one by one.
void shade_packet(const TraceContext& context, const Ray* rays, const Hit* hits, const bool* found, int count,
                  DeferredArray<RGB, kShadedPackets * kPacketRays>& colour, std::vector<BundleCandidate>& scratch) {
    static_assert(kShadedPackets * kPacketRays <= kShadingLanes && kShadingLanes <= kMaxRaysTogether);
    const Scene& scene = context.scene;
    ShadedLanes lanes;
    if (context.lane_shading) {
        for (int k = 0; k < count; ++k) {
            const Hit& hit = hits[k];
            if (!found[k] || hit.instance >= 0) continue;
            // shade_hit's material and normal, for a surface of the world; where `unit` is
            // false, before its normalize(), which the lanes take (as the turn to the viewer).
            const Vec3 p = rays[k].at(hit.t);
            Vec3 n;
            bool unit = true;
            const LaneMaterial* material;
            if (scene.is_round(hit.ref)) {
                SphereShape shape;
                const SphereShape& s = scene.round_shape(hit.ref, shape);
                material = &context.lane_materials[size_t(s.material)];
                if (!material->plain) continue;
                // sphere_normal before its normalize()
                n = s.object_from_world.transposed_vector(s.object_from_world.point(p));
                unit = false;
            } else if (hit.ref < 0) {
                const IntrinsicShape& part = scene.intrinsic(hit.ref);
                material = &context.lane_materials[size_t(part.material)];
                if (!material->plain) continue;
                n = intrinsic_normal(part, p);
            } else {
                const int32_t mesh = scene.triangle_mesh(size_t(hit.ref));
                material = &context.lane_materials[size_t(scene.mesh_material(mesh))];
                if (!material->plain) continue;
                const TriangleNormals* sh =
                    scene.triangle_normals.empty() ? nullptr : &scene.triangle_normals[size_t(hit.ref)];
                if (sh && sh->n0 >= 0) {
                    n = scene.normals[size_t(sh->n0)] * hit.bary.b0 + scene.normals[size_t(sh->n1)] * hit.bary.b1 +
                        scene.normals[size_t(sh->n2)] * hit.bary.b2;
                    unit = false;
                } else if (const Vec3* kept = scene.flat_normal(size_t(hit.ref), mesh)) {
                    n = *kept;
                } else {
                    const TriangleShape t = scene.triangles[size_t(hit.ref)];
                    n = cross(t.v1 - t.v0, t.v2 - t.v0);  // flat_triangle_normal before its normalize()
                    unit = false;
                }
            }
            const Vec3 wo = -rays[k].dir;
            lanes.px[k] = p.x, lanes.py[k] = p.y, lanes.pz[k] = p.z;
            lanes.nx[k] = n.x, lanes.ny[k] = n.y, lanes.nz[k] = n.z;
            lanes.wx[k] = wo.x, lanes.wy[k] = wo.y, lanes.wz[k] = wo.z;
            lanes.cx[k] = material->unlit.x, lanes.cy[k] = material->unlit.y, lanes.cz[k] = material->unlit.z;
            lanes.kx[k] = material->diffuse.x, lanes.ky[k] = material->diffuse.y, lanes.kz[k] = material->diffuse.z;
            lanes.sx[k] = material->specular.x, lanes.sy[k] = material->specular.y;
            lanes.sz[k] = material->specular.z;
            lanes.ks[k] = material->ks, lanes.exponent[k] = material->exponent;
            lanes.lanes |= uint64_t(1) << k;
            if (!unit) lanes.to_normalize |= uint64_t(1) << k;
        }
    }
    if (lanes.lanes != 0) {
        const double window = context.tolerances.shadow_window;
        // ShadowQuery's answers for a point light (no light link, no bundle).
        auto shadow = [&](const Vec3* p, const Vec3* l, const double* distance, int count) {
            DeferredArray<Ray, kMaxRaysTogether> rays;
            double t_max[kMaxRaysTogether];
            for (int i = 0; i < count; ++i) rays.emplace(size_t(i), Ray{p[i], l[i]}), t_max[i] = distance[i] - window;
            RayBits blocked = scene.occluded_each(rays.data(), count, window, t_max);
            if (context.povray_walk)
                for (RayBits bits = blocked; bits != 0; bits &= bits - 1) {
                    const int i = __builtin_ctzll(bits);
                    if (!scene.occluded_povray_walk(rays[i], window, t_max[i])) blocked &= ~(RayBits(1) << i);
                }
            return blocked;
        };
        add_point_lights(scene.lights, context.settings.specular_convention, lanes, shadow);
    }
    for (int k = 0; k < count; ++k)
        colour.emplace(size_t(k), lanes.lanes >> k & 1u ? RGB{lanes.cx[k], lanes.cy[k], lanes.cz[k]}
                                                        : shade_primary(context, rays[k], found[k], hits[k], scratch));
}

}  // namespace

RGB trace_primary(const TraceContext& context, const Ray& ray, std::vector<BundleCandidate>& scratch,
                  const FloatSlabOrigin* origin) {
    Hit hit;
    const double near = context.tolerances.primary_near;
    const bool found = origin ? context.scene.closest_hit(ray, *origin, near, HUGE_VAL, hit)
                              : context.scene.closest_hit(ray, near, HUGE_VAL, hit);
    return shade_primary(context, ray, found, hit, scratch);
}

RGB shade_primary(const TraceContext& context, const Ray& ray, bool found, Hit hit,
                  std::vector<BundleCandidate>& scratch) {
    if (!found) return miss(context, ray);
    if (context.cut_outs) {  // the first surface a mask does not remove (past_cut_outs)
        Ray on = ray;
        double travelled;
        if (!past_cut_outs(context, on, hit, travelled)) return miss(context, ray);
        return shade_hit(context, on, hit, scratch, 0, context.camera_inside);
    }
    return shade_hit(context, ray, hit, scratch, 0, context.camera_inside);
}

bool render_image(const Scene& scene, const Camera& camera, const RenderSettings& settings, float* pixels,
                  const PollFn& poll) {
    const int width = settings.width, height = settings.height, n = settings.samples;
    // The tolerances from the box of the geometry and the camera (math.hpp).
    Bounds box = scene.bounds;
    box.grow(camera.position);
    const RayTolerances tolerances =
        settings.numerics == Numerics::kPovray
            ? RayTolerances{kPovrayPrimaryNear, kPovrayShadowWindow, kPovrayPrimaryNear}
        : settings.numerics == Numerics::kPovrayShadowCache
            ? RayTolerances{kPovrayPrimaryNear, kPovrayShadowCacheWindow, kPovrayPrimaryNear}
            : ray_tolerances(box.lo, box.hi);
    const TraceContext context(scene, settings, tolerances);

    auto store = [&](int i, int j, const RGB& c) {
        float* out = pixels + (size_t(j) * width + i) * 3;
        out[0] = float(c.x);
        out[1] = float(c.y);
        out[2] = float(c.z);
    };
    // A perspective camera's rays all start at its position: rounded once for the BVH's float test.
    const std::optional<FloatSlabOrigin> eye =
        camera.orthographic ? std::nullopt : std::optional<FloatSlabOrigin>(camera.position);
    const FloatSlabOrigin* shared_origin = eye ? &*eye : nullptr;
    auto trace_at = [&](double sx, double sy, std::vector<BundleCandidate>& scratch) {
        return trace_primary(context, camera.generate(sx, sy, width, height), scratch, shared_origin);
    };
    // POV-Ray's +AM1 supersampling of one pixel whose centre colour is `c` (SupersampleOnePixel).
    auto am1_supersample = [&](int i, int j, const RGB& c, std::vector<BundleCandidate>& scratch) {
        RGB sum = c;
        for (int b = 0; b < n; ++b)
            for (int a = 0; a < n; ++a) sum += trace_at(i + (a + 0.5) / n, j + (b + 0.5) / n, scratch);
        return sum / double(n * n + 1);
    };

    // The primary rays through image positions (sx[k], sy[k]), k < count, traced as packets of
    // `first` and count − first rays (each at most kPacketRays; Scene::closest_hit_packet: each
    // ray's hit bit for bit as alone) and shaded together (shade_packet): colour[k] is
    // trace_at(sx[k], sy[k])'s. A perspective camera's only (one origin). (Rays and colours in
    // DeferredArray: as plain arrays each was zero-filled a packet.)
    using PacketColours = DeferredArray<RGB, kShadedPackets * kPacketRays>;
    auto trace_packets = [&](const double* sx, const double* sy, int count, const int* packet_rays,
                             PacketColours& colour, std::vector<BundleCandidate>& scratch) {
        assert(eye && count >= 1 && count <= kShadedPackets * kPacketRays);
        DeferredArray<Ray, kShadedPackets * kPacketRays> rays;
        Hit hits[kShadedPackets * kPacketRays];
        bool found[kShadedPackets * kPacketRays];
        if (scene.walk_width() == 8) {  // the AVX2 path: directions in lanes
            DeferredArray<Vec3, kShadedPackets * kPacketRays> dirs;
            for (int at = 0, p = 0; at < count; at += packet_rays[p++])
                camera.perspective_directions(sx + at, sy + at, packet_rays[p], width, height, dirs.data() + at);
            for (int k = 0; k < count; ++k) rays.emplace(size_t(k), Ray{camera.position, dirs[size_t(k)]});
        } else {
            for (int k = 0; k < count; ++k) rays.emplace(size_t(k), camera.generate(sx[k], sy[k], width, height));
        }
        for (int at = 0, p = 0; at < count; at += packet_rays[p++]) {
            assert(packet_rays[p] >= 1 && packet_rays[p] <= kPacketRays);
            scene.closest_hit_packet(rays.data() + at, packet_rays[p], *eye, tolerances.primary_near, hits + at,
                                     found + at);
        }
        shade_packet(context, rays.data(), hits, found, count, colour, scratch);
    };
    auto trace_packet = [&](const double* sx, const double* sy, int count, PacketColours& colour,
                            std::vector<BundleCandidate>& scratch) {
        trace_packets(sx, sy, count, &count, colour, scratch);
    };
    // Samples of one pixel gathered into packets, summed in the order given (the sum, and so
    // the pixel, is the one-by-one loop's to the bit).
    struct SamplePackets {
        double sx[kPacketRays], sy[kPacketRays];
        int pending = 0;
        RGB sum;
    };
    auto add_sample = [&](SamplePackets& s, double sx, double sy, std::vector<BundleCandidate>& scratch) {
        s.sx[s.pending] = sx;
        s.sy[s.pending] = sy;
        if (++s.pending < kPacketRays) return;
        PacketColours colour;
        trace_packet(s.sx, s.sy, s.pending, colour, scratch);
        for (int k = 0; k < s.pending; ++k) s.sum += colour[k];
        s.pending = 0;
    };
    auto flush_samples = [&](SamplePackets& s, std::vector<BundleCandidate>& scratch) {
        if (s.pending == 0) return;
        PacketColours colour;
        trace_packet(s.sx, s.sy, s.pending, colour, scratch);
        for (int k = 0; k < s.pending; ++k) s.sum += colour[k];
        s.pending = 0;
    };

    auto render_pixel = [&](int i, int j, std::vector<BundleCandidate>& scratch) {
        RGB sum;
        int count = 0;
        if (settings.sample_pattern == SamplePattern::kPovrayAm1) {
            sum += trace_at(i + 0.5, j + 0.5, scratch);
            ++count;
        }
        if (n == 1 && settings.sample_pattern == SamplePattern::kGrid) {
            sum += trace_at(i + 0.5, j + 0.5, scratch);
            ++count;
        } else if (eye && settings.sample_pattern == SamplePattern::kGrid) {  // the n x n grid in packets
            SamplePackets samples;
            for (int b = 0; b < n; ++b)
                for (int a = 0; a < n; ++a) add_sample(samples, i + (a + 0.5) / n, j + (b + 0.5) / n, scratch);
            flush_samples(samples, scratch);
            sum = samples.sum;
            count = n * n;
        } else {
            for (int b = 0; b < n; ++b)
                for (int a = 0; a < n; ++a) {
                    sum += trace_at(i + (a + 0.5) / n, j + (b + 0.5) / n, scratch);
                    ++count;
                }
        }
        store(i, j, sum / double(count));
    };

    // The threshold as POV-Ray holds it (a float option).
    const double threshold = double(float(settings.aa_threshold));

    // POV-Ray's adaptive +AM1 over one block (NonAdaptiveSupersamplingM1 and ...ForOnePixel): the
    // pixel centres, in rows; a pixel is supersampled (once) when its encoded colour differs from
    // its left or top neighbour's, as they are then, by >= the threshold, and so is that
    // neighbour unless it lies outside the block or was supersampled already.
    auto render_block_am1 = [&](int x0, int y0, int x1, int y1, std::vector<BundleCandidate>& scratch) {
        const int stride = x1 - x0 + 1;
        std::vector<RGB> colour(size_t(stride) * size_t(y1 - y0 + 1));
        std::vector<char> supersampled(colour.size(), 0);
        auto at = [&](int i, int j) { return size_t(j - y0 + 1) * size_t(stride) + size_t(i - x0 + 1); };
        for (int i = x0; i < x1; ++i) {
            colour[at(i, y0 - 1)] = trace_at(i + 0.5, y0 - 0.5, scratch);
            supersampled[at(i, y0 - 1)] = 1;  // outside the block: never supersampled
        }
        for (int j = y0; j < y1; ++j) {
            colour[at(x0 - 1, j)] = trace_at(x0 - 0.5, j + 0.5, scratch);
            supersampled[at(x0 - 1, j)] = 1;
            for (int i = x0; i < x1; ++i) {
                const size_t cur = at(i, j), left = at(i - 1, j), top = at(i, j - 1);
                colour[cur] = trace_at(i + 0.5, j + 0.5, scratch);
                const EncodedColour e(colour[cur]);
                const bool left_differs = colour_distance(EncodedColour(colour[left]), e) >= threshold;
                const bool top_differs = colour_distance(EncodedColour(colour[top]), e) >= threshold;
                if (!supersampled[left] && left_differs) {
                    colour[left] = am1_supersample(i - 1, j, colour[left], scratch);
                    supersampled[left] = 1;
                }
                if (!supersampled[top] && top_differs) {
                    colour[top] = am1_supersample(i, j - 1, colour[top], scratch);
                    supersampled[top] = 1;
                }
                if (left_differs || top_differs) {
                    colour[cur] = am1_supersample(i, j, colour[cur], scratch);
                    supersampled[cur] = 1;
                }
            }
        }
        for (int j = y0; j < y1; ++j)
            for (int i = x0; i < x1; ++i) store(i, j, colour[at(i, j)]);
    };

    // POV-Ray's +AM2 (AdaptiveSupersamplingM2, SubdivideOnePixel): the pixel corners, then a
    // square whose 4 corners' encoded colours differ pairwise by >= the threshold is split into
    // 4, down to m = 2^(n-1) cells per side; a square's colour is the mean of its 4 sub-squares'
    // or else of its 4 corners. Samples sit at (i + a/m, j + b/m); the corners are traced once
    // per tile, the other samples once per pixel (as POV-Ray).
    const int m = 1 << (n - 1);
    // A traced sample and its encoding for the threshold tests (encoded once: powf dominated
    // the subdivision's cost when every level re-encoded its corners).
    struct Sample {
        RGB colour;
        EncodedColour encoded;
        explicit Sample(const RGB& c = RGB()) : colour(c), encoded(c) {}
    };
    auto render_block_am2 = [&](int x0, int y0, int x1, int y1, std::vector<BundleCandidate>& scratch) {
        const int stride = x1 - x0 + 1;
        std::vector<Sample> corners(size_t(stride) * size_t(y1 - y0 + 1));
        for (int j = y0; j <= y1; ++j)
            for (int i = x0; i <= x1; ++i)
                corners[size_t(j - y0) * stride + size_t(i - x0)] = Sample(trace_at(i, j, scratch));
        const int side = m + 1;
        std::vector<Sample> sample(size_t(side) * side);
        std::vector<int> stamp(sample.size(), -1);  // which pixel traced the sample (no clearing)
        int pixel_id = 0;
        for (int j = y0; j < y1; ++j)
            for (int i = x0; i < x1; ++i, ++pixel_id) {
                auto get = [&](int a, int b) -> const Sample& {
                    const size_t k = size_t(b) * side + size_t(a);
                    if (stamp[k] != pixel_id) {
                        sample[k] = Sample(trace_at(i + double(a) / m, j + double(b) / m, scratch));
                        stamp[k] = pixel_id;
                    }
                    return sample[k];
                };
                auto set = [&](int a, int b, const Sample& c) {
                    const size_t k = size_t(b) * side + size_t(a);
                    sample[k] = c;
                    stamp[k] = pixel_id;
                };
                set(0, 0, corners[size_t(j - y0) * stride + size_t(i - x0)]);
                set(m, 0, corners[size_t(j - y0) * stride + size_t(i + 1 - x0)]);
                set(0, m, corners[size_t(j + 1 - y0) * stride + size_t(i - x0)]);
                set(m, m, corners[size_t(j + 1 - y0) * stride + size_t(i + 1 - x0)]);
                auto subdivide = [&](auto&& self, int a, int b, int step, int level) -> RGB {
                    const Sample &s00 = get(a, b), &s02 = get(a, b + step), &s20 = get(a + step, b),
                                 &s22 = get(a + step, b + step);
                    if (level > 0) {
                        const EncodedColour &e00 = s00.encoded, &e02 = s02.encoded, &e20 = s20.encoded,
                                            &e22 = s22.encoded;
                        if (colour_distance(e00, e02) >= threshold || colour_distance(e00, e20) >= threshold ||
                            colour_distance(e00, e22) >= threshold || colour_distance(e02, e20) >= threshold ||
                            colour_distance(e02, e22) >= threshold || colour_distance(e20, e22) >= threshold) {
                            const int h = step / 2;
                            return (self(self, a, b, h, level - 1) + self(self, a, b + h, h, level - 1) +
                                    self(self, a + h, b, h, level - 1) + self(self, a + h, b + h, h, level - 1)) /
                                   4.0;
                        }
                    }
                    return (s00.colour + s02.colour + s20.colour + s22.colour) / 4.0;
                };
                store(i, j, subdivide(subdivide, 0, 0, m, n - 1));
            }
    };

    // The native stratified estimator (render.hpp). With a threshold t > 0 it first looks at the
    // pixel's 4 corners (traced once per tile, shared with the neighbours, as +AM2 does): a
    // straight edge through the pixel always separates two corners, which 4 interior samples do
    // not guarantee. Corners within t of each other (|dr| + |dg| + |db|, linear): the pixel is
    // their mean (+AM2's level 0). Otherwise, and always at t = 0, it takes stages of 16, 64,
    // 256 points of the scrambled (0,2)-sequence, up to n^2, stopping when a stage moved the
    // estimate by less than t (that change estimates the previous stage's error).
    const int budget = n * n;
    const double settle = settings.aa_threshold;
    auto colour_l1 = [](const RGB& a) { return std::fabs(a.x) + std::fabs(a.y) + std::fabs(a.z); };
    auto stratified_pixel = [&](int i, int j, const RGB* corners, std::vector<BundleCandidate>& scratch) {
        if (corners != nullptr) {
            bool agree = true;
            for (int a = 0; a < 4 && agree; ++a)
                for (int b = a + 1; b < 4 && agree; ++b) agree = colour_l1(corners[a] - corners[b]) < settle;
            if (agree) return store(i, j, (corners[0] + corners[1] + corners[2] + corners[3]) / 4.0);
        }
        const uint32_t key = uint32_t(j) * 0x9E3779B1u + uint32_t(i);
        const uint32_t shift_x = hash32(key), shift_y = hash32(key ^ 0xA511E9B3u);
        RGB sum, previous;
        int count = 0;
        for (int stage = std::min(16, budget);; stage = std::min(stage * 4, budget)) {
            if (eye) {  // the stage's samples in packets, summed in order
                SamplePackets samples;
                samples.sum = sum;
                for (; count < stage; ++count) {
                    const double px = double(reverse_bits(uint32_t(count)) ^ shift_x) * kTwoToMinus32;
                    const double py = double(sobol_second(uint32_t(count)) ^ shift_y) * kTwoToMinus32;
                    add_sample(samples, i + px, j + py, scratch);
                }
                flush_samples(samples, scratch);
                sum = samples.sum;
            } else {
                for (; count < stage; ++count) {
                    const double px = double(reverse_bits(uint32_t(count)) ^ shift_x) * kTwoToMinus32;
                    const double py = double(sobol_second(uint32_t(count)) ^ shift_y) * kTwoToMinus32;
                    sum += trace_at(i + px, j + py, scratch);
                }
            }
            const RGB mean = sum / double(count);
            if (count >= budget || (settle > 0.0 && count > 16 && colour_l1(mean - previous) < settle))
                return store(i, j, mean);
            previous = mean;
        }
    };
    auto render_block_stratified = [&](int x0, int y0, int x1, int y1, std::vector<BundleCandidate>& scratch) {
        const int stride = x1 - x0 + 1;
        std::vector<RGB> corners;
        if (settle > 0.0) {
            corners.resize(size_t(stride) * size_t(y1 - y0 + 1));
            for (int j = y0; j <= y1; ++j)
                for (int i = x0; i <= x1; ++i)
                    corners[size_t(j - y0) * stride + size_t(i - x0)] = trace_at(i, j, scratch);
        }
        for (int j = y0; j < y1; ++j)
            for (int i = x0; i < x1; ++i) {
                if (corners.empty()) {
                    stratified_pixel(i, j, nullptr, scratch);
                    continue;
                }
                const size_t k = size_t(j - y0) * stride + size_t(i - x0);
                const RGB four[4] = {corners[k], corners[k + 1], corners[k + stride], corners[k + stride + 1]};
                stratified_pixel(i, j, four, scratch);
            }
    };

    // One sample per pixel at its centre through a perspective camera: the primary rays of each
    // block of kPacketWidth x kPacketHeight pixels are traced as one packet, and where the lanes
    // shade (TraceContext::lane_shading) kShadedPackets of them are shaded together
    // (trace_packets; elsewhere that gains nothing, and S3 lost 2-4 %). (More samples per pixel
    // go in packets of one pixel's samples: render_pixel, stratified_pixel.)
    const bool packets = eye && n == 1 && settings.sample_pattern == SamplePattern::kGrid;
    const int across = context.lane_shading ? kShadedAcross : 1, down = context.lane_shading ? kShadedDown : 1;
    auto render_block_packets = [&](int x0, int y0, int x1, int y1, std::vector<BundleCandidate>& scratch) {
        for (int j0 = y0; j0 < y1; j0 += down * kPacketHeight)
            for (int i0 = x0; i0 < x1; i0 += across * kPacketWidth) {
                double sx[kShadedPackets * kPacketRays], sy[kShadedPackets * kPacketRays];
                int count = 0, packets = 0, packet_rays[kShadedPackets];
                for (int p = 0; p < across * down; ++p) {  // blocks past the tile's edge: none
                    const int b0 = i0 + (p % across) * kPacketWidth, c0 = j0 + (p / across) * kPacketHeight;
                    const int before = count;
                    for (int j = c0; j < std::min(y1, c0 + kPacketHeight); ++j)
                        for (int i = b0; i < std::min(x1, b0 + kPacketWidth); ++i, ++count) {
                            sx[count] = i + 0.5;
                            sy[count] = j + 0.5;
                        }
                    if (count > before) packet_rays[packets++] = count - before;
                }
                PacketColours colour;
                trace_packets(sx, sy, count, packet_rays, colour, scratch);
                for (int k = 0; k < count; ++k) {
                    RGB sum;  // render_pixel's arithmetic, to the bit (0 + −0 is +0)
                    sum += colour[k];
                    store(int(sx[k]), int(sy[k]), sum / 1.0);
                }
            }
    };

    const bool adaptive_am1 = settings.sample_pattern == SamplePattern::kPovrayAm1 && threshold > 0.0;
    const bool stratified = settings.sample_pattern == SamplePattern::kStratified;
    const bool am2 = settings.sample_pattern == SamplePattern::kPovrayAm2;
    const bool adaptive = settings.sample_pattern == SamplePattern::kAdaptive;
    auto render_tile = [&](int x0, int y0, int x1, int y1, std::vector<BundleCandidate>& scratch) {
        if (adaptive_am1) return render_block_am1(x0, y0, x1, y1, scratch);
        if (adaptive)
            return render_adaptive_tile(
                x0, y0, x1, y1, n, settings.aa_threshold,
                [&](double sx, double sy) { return trace_at(sx, sy, scratch); }, store);
        if (am2) return render_block_am2(x0, y0, x1, y1, scratch);
        if (stratified) return render_block_stratified(x0, y0, x1, y1, scratch);
        if (packets) return render_block_packets(x0, y0, x1, y1, scratch);
        for (int j = y0; j < y1; ++j)
            for (int i = x0; i < x1; ++i) render_pixel(i, j, scratch);
    };
    const int tile_size = adaptive_am1 ? kPovrayBlockSize : kTileSize;

    const int tiles_x = (width + tile_size - 1) / tile_size, tiles_y = (height + tile_size - 1) / tile_size;
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
            const int x0 = (tile % tiles_x) * tile_size, y0 = (tile / tiles_x) * tile_size;
            const int x1 = std::min(width, x0 + tile_size), y1 = std::min(height, y0 + tile_size);
            render_tile(x0, y0, x1, y1, scratch);
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
