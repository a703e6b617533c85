// SPDX-License-Identifier: Apache-2.0
// Lights with POV-Ray 3.7's semantics (its source, trace.cpp: ComputeOneWhiteLightRay,
// TraceAreaLightShadowRay, TraceAreaLightSubsetShadowRay): shading always uses the direction
// to the light's centre; area lights only change the shadow fraction, computed over a
// samples x samples grid (edges included) with the weights of POV-Ray's full 4-corner
// subdivision, which for samples = 2^k + 1 are the trapezoid weights (1/2, 1, ..., 1, 1/2)/(n-1)
// per axis.
#pragma once

#include <immintrin.h>

#include <cmath>
#include <type_traits>
#include <variant>
#include <vector>

#include "area_cells.hpp"
#include "math.hpp"
#include "simd_dispatch.hpp"

namespace phong {

// inverse_square (UsdLux semantics): `color` is the radiant intensity, and the light arriving at
// distance d is color / d² (a rect light's additionally × max(0, cos) of the angle from its
// emitting side, -(axis_u × axis_v): a one-sided Lambertian panel seen from afar). Otherwise the
// seed's constant light: `color` arrives unchanged (or with POV-Ray's fade on a point light).
// Multipliers of a light's diffuse and specular contributions (UsdLux inputs:diffuse and
// inputs:specular; 1 and 1 for the seed's light, which then shades bit for bit as without them).
struct LightTerms {
    double diffuse = 1.0, specular = 1.0;
};

struct PointLight {
    Vec3 position;
    RGB color;
    double fade_distance;  // used only when fade_power > 0
    double fade_power;     // 0: no fade
    bool inverse_square = false;
    // A spot cone along unit cone_axis: 1 for cos >= cone_cos_inner, 0 for cos <= cone_cos_outer,
    // smoothstep in cos between (POV-Ray's spotlight edge). cone_cos_outer <= -1: no cone.
    Vec3 cone_axis{0, 0, -1};
    double cone_cos_outer = -2.0, cone_cos_inner = -2.0;
    double cone_focus = 0.0;  // × cos^focus inside the cone (POV-Ray's tightness)
    LightTerms terms;
};

struct DirectionalLight {
    Vec3 to_light;  // unit, opposite to the direction the light travels
    RGB color;
    LightTerms terms;

    // From the direction the light travels (the model's and POV-Ray's), of any length.
    static DirectionalLight travelling(const Vec3& direction, const RGB& color) {
        return {-normalize(direction), color, {}};
    }
};

struct RectAreaLight {
    Vec3 center, axis_u, axis_v;  // full edge vectors
    RGB color;
    int samples;  // per axis, 2^k + 1
    bool inverse_square = false;
    LightTerms terms;
    int adaptive = kFullSubdivision;  // POV-Ray's `adaptive n`; kFullSubdivision: every grid point
    int cell_samples = 0;  // > 0: the native cells estimator (area_cells.hpp), cell_samples^2 per partial cell
};

// POV-Ray's `area_light <2r,0,0>, <0,2r,0>, n, n circular orient`.
struct SphereAreaLight {
    Vec3 center;
    double radius;
    RGB color;
    int samples;
    bool inverse_square = false;
    LightTerms terms;
    int adaptive = kFullSubdivision;
    int cell_samples = 0;
};

using Light = std::variant<PointLight, DirectionalLight, RectAreaLight, SphereAreaLight>;

// std::visit(f, light) with f inlined into the caller (which must mark f always_inline or let
// GCC inline it): in the shading loop, std::visit's invoker stayed out of line, a call per light
// and shaded point (with visible_fraction() inlined too, S1's render -5.6 % instructions).
template <class F>
[[gnu::always_inline]] inline void visit_light(const Light& light, F&& f) {
    static_assert(std::variant_size_v<Light> == 4, "one case per alternative");
    switch (light.index()) {
        case 0:
            f(*std::get_if<0>(&light));
            return;
        case 1:
            f(*std::get_if<1>(&light));
            return;
        case 2:
            f(*std::get_if<2>(&light));
            return;
        default:
            f(*std::get_if<3>(&light));
            return;
    }
}

// The light as seen from a point, computed from its centre: unit direction l, distance (inf
// for a directional light) and colour (with POV-Ray's fade where asked for).
struct LightSample {
    Vec3 l;
    double distance;
    RGB color;
};

namespace detail {
inline LightSample toward(const Vec3& target, const Vec3& p, const RGB& color) {
    const Vec3 v = target - p;
    const double d = length(v);
    return {v / d, d, color};
}

// toward() with l's x and y divided as one pair (the same IEEE quotients): l leaves in one
// register and is stored with one 16-byte write, which the shadow ray's copy of it (a 16-byte
// load) forwards from; from two 8-byte stores the load waits for both to commit (S1: ~4 % of the
// render). Only for point lights: for S3's area light the pair measured slower (issue 25,
// benchmarks/README.md).
inline LightSample toward_paired(const Vec3& target, const Vec3& p, const RGB& color) {
    const Vec3 v = target - p;
    const double d = length(v);
    typedef double Pair __attribute__((vector_size(16)));
    const Pair xy = Pair{v.x, v.y} / d;
    return {{xy[0], xy[1], v.z / d}, d, color};
}

// Trapezoid weight of grid index i of n (n >= 2).
inline double trapezoid_weight(int i, int n) { return (i == 0 || i == n - 1 ? 0.5 : 1.0) / (n - 1); }

// POV-Ray's `adaptive n` (trace.cpp, TraceAreaLightSubsetShadowRay): the region [u1, u2] x
// [v1, v2] of the grid traces its four corners (each grid point once, cached in `grid`); it is
// split into quadrants at floor/ceil of its middle when it spans more than one step and either
// level < adaptive or two edge-adjacent corners differ by more than kAdaptiveAreaLightThreshold
// (POV-Ray's colour distance, |dr| + |dg| + |db|, of the light's colour times visibility: for
// opaque occluders |dvis| times `colour_sum`); its fraction is the mean of its 4 quadrants' or
// else of its 4 corners' fractions. `visible(u, v)` traces grid point (u, v): 1 visible, 0 not.
// A grid cell (one step each way) whose corners disagree is `partial(u1, v1)` when given (the
// native cells estimator, area_cells.hpp), else the mean of its corners (POV-Ray).
template <class Visible, class Partial>
double adaptive_fraction(int u1, int v1, int u2, int v2, int level, int adaptive, double colour_sum, int n,
                         std::vector<signed char>& grid, Visible& visible, Partial* partial) {
    double corner[4];
    const int us[4] = {u1, u2, u1, u2}, vs[4] = {v1, v1, v2, v2};
    for (int k = 0; k < 4; ++k) {
        signed char& g = grid[size_t(us[k]) * size_t(n) + size_t(vs[k])];
        if (g < 0) g = visible(us[k], vs[k]) ? 1 : 0;
        corner[k] = g;
    }
    if (u2 - u1 > 1 || v2 - v1 > 1) {
        auto differ = [&](int a, int b) {
            return std::fabs(corner[a] - corner[b]) * colour_sum > kAdaptiveAreaLightThreshold;
        };
        if (level < adaptive || differ(0, 1) || differ(1, 3) || differ(3, 2) || differ(2, 0)) {
            const int ul = int(std::floor((u1 + u2) / 2.0)), uh = int(std::ceil((u1 + u2) / 2.0));
            const int vl = int(std::floor((v1 + v2) / 2.0)), vh = int(std::ceil((v1 + v2) / 2.0));
            corner[0] = adaptive_fraction(u1, v1, ul, vl, level + 1, adaptive, colour_sum, n, grid, visible, partial);
            corner[1] = adaptive_fraction(uh, v1, u2, vl, level + 1, adaptive, colour_sum, n, grid, visible, partial);
            corner[2] = adaptive_fraction(u1, vh, ul, v2, level + 1, adaptive, colour_sum, n, grid, visible, partial);
            corner[3] = adaptive_fraction(uh, vh, u2, v2, level + 1, adaptive, colour_sum, n, grid, visible, partial);
        }
    } else if (partial != nullptr && !(corner[0] == corner[1] && corner[1] == corner[2] && corner[2] == corner[3])) {
        return (*partial)(u1, v1);
    }
    return (corner[0] + corner[1] + corner[2] + corner[3]) * 0.25;
}

// adaptive_fraction's recursion on filtered shadow rays (through transmissive objects, POV-Ray's
// TraceAreaLightSubsetShadowRay with a filtering TraceShadowRay): grid point (u, v) gives the
// colour filter of its shadow ray, `filter(u, v)` (each point once, cached in `samples` where
// `traced` says so); two edge-adjacent corners differ when the light's colour as it arrives,
// `arriving` (POV-Ray's float colour), times their filters does by more than
// kAdaptiveAreaLightThreshold (|dr| + |dg| + |db|); a region's filter is the mean of its 4
// quadrants' or else of its 4 corners'. For 0/1 filters (opaque occluders) the decisions are
// adaptive_fraction's.
template <class Filter>
RGB adaptive_filter(int u1, int v1, int u2, int v2, int level, int adaptive, const RGB& arriving, int n,
                    std::vector<RGB>& samples, std::vector<unsigned char>& traced, Filter& filter) {
    RGB corner[4];
    const int us[4] = {u1, u2, u1, u2}, vs[4] = {v1, v1, v2, v2};
    for (int k = 0; k < 4; ++k) {
        const size_t at = size_t(us[k]) * size_t(n) + size_t(vs[k]);
        if (!traced[at]) {
            samples[at] = filter(us[k], vs[k]);
            traced[at] = 1;
        }
        corner[k] = samples[at];
    }
    if (u2 - u1 > 1 || v2 - v1 > 1) {
        auto differ = [&](int a, int b) {
            return std::fabs(arriving.x * (corner[a].x - corner[b].x)) +
                       std::fabs(arriving.y * (corner[a].y - corner[b].y)) +
                       std::fabs(arriving.z * (corner[a].z - corner[b].z)) >
                   kAdaptiveAreaLightThreshold;
        };
        if (level < adaptive || differ(0, 1) || differ(1, 3) || differ(3, 2) || differ(2, 0)) {
            const int ul = int(std::floor((u1 + u2) / 2.0)), uh = int(std::ceil((u1 + u2) / 2.0));
            const int vl = int(std::floor((v1 + v2) / 2.0)), vh = int(std::ceil((v1 + v2) / 2.0));
            corner[0] = adaptive_filter(u1, v1, ul, vl, level + 1, adaptive, arriving, n, samples, traced, filter);
            corner[1] = adaptive_filter(uh, v1, u2, vl, level + 1, adaptive, arriving, n, samples, traced, filter);
            corner[2] = adaptive_filter(u1, vh, ul, v2, level + 1, adaptive, arriving, n, samples, traced, filter);
            corner[3] = adaptive_filter(uh, vh, u2, v2, level + 1, adaptive, arriving, n, samples, traced, filter);
        }
    }
    return (corner[0] + corner[1] + corner[2] + corner[3]) * 0.25;
}
}  // namespace detail

// An area light's grid points as offsets (ju, jv) along its two axes, |ju|, |jv| <= 1/2 (for a
// circular light: nudged and mapped onto the disc, POV-Ray's shells), and their weights, at index
// a·n + b in the order visible_fraction() visits them. They depend only on the sample count and
// the mapping, so a render computes them once per light (render.cpp) rather than at every shaded
// point; the same operations in the same order, so the same bits. A rect light's axes are fixed,
// so its samples' world positions c + ju·a1 + jv·a2 are computed once too (`targets`); a sphere
// light's disc turns to face each shaded point.
struct AreaLightGrid {
    int n = 0;  // samples per axis; 0 for a light without a grid
    std::vector<double> ju, jv, weight;
    double total_weight = 0.0;  // the weights summed in visiting order: the fraction of a grid no ray can shadow
    std::vector<Vec3> targets;  // rect lights: the samples in world space; empty otherwise

    AreaLightGrid() = default;
    AreaLightGrid(int samples, bool circular) : n(samples) {
        const size_t count = size_t(n) * size_t(n);
        ju.resize(count);
        jv.resize(count);
        weight.resize(count);
        for (int a = 0; a < n; ++a) {
            const double weight_a = detail::trapezoid_weight(a, n);
            for (int b = 0; b < n; ++b) {
                const size_t k = size_t(a) * size_t(n) + size_t(b);
                double u = double(a) / (n - 1) - 0.5, v = double(b) / (n - 1) - 0.5;
                if (circular) {
                    // Map the square onto the disc (POV-Ray's shells: |(ju, jv)| -> max(|ju|, |jv|)).
                    u += kCircularAreaLightNudge;
                    v += kCircularAreaLightNudge;
                    const double scale = std::fmax(std::fabs(u), std::fabs(v)) / std::sqrt(u * u + v * v);
                    u *= scale;
                    v *= scale;
                }
                ju[k] = u;
                jv[k] = v;
                weight[k] = weight_a * detail::trapezoid_weight(b, n);
                total_weight += weight[k];
            }
        }
    }
};

// The grid of an area light (an empty one for point and directional lights).
inline AreaLightGrid area_light_grid(const Light& light) {
    return std::visit(
        [](const auto& L) -> AreaLightGrid {
            using T = std::decay_t<decltype(L)>;
            if constexpr (std::is_same_v<T, RectAreaLight>) {
                AreaLightGrid grid(L.samples, false);
                for (size_t k = 0; k < grid.weight.size(); ++k)
                    grid.targets.push_back(L.center + L.axis_u * grid.ju[k] + L.axis_v * grid.jv[k]);
                return grid;
            } else if constexpr (std::is_same_v<T, SphereAreaLight>)
                return AreaLightGrid(L.samples, true);
            else
                return AreaLightGrid();
        },
        light);
}

// sample_light_centre() and visible_fraction() take one alternative of Light (the caller visits
// the variant once per light and shaded point; each of them visiting it again cost a jump table).
// Always inlined: once per light and shaded point, and left out of line (GCC's choice in the
// shading loop) its call cost 1.5% of S1's instructions.
template <class T>
[[gnu::always_inline]] inline LightSample sample_light_centre(const T& L, const Vec3& p) {
    if constexpr (std::is_same_v<T, PointLight>) {
        LightSample s = detail::toward_paired(L.position, p, L.color);
        if (L.fade_power > 0.0)  // POV-Ray: 2 / (1 + (d / fade_distance)^fade_power)
            s.color = s.color * (2.0 / (1.0 + std::pow(s.distance / L.fade_distance, L.fade_power)));
        if (L.inverse_square) s.color = s.color * (1.0 / (s.distance * s.distance));
        if (L.cone_cos_outer > -1.0) {
            const double c = -dot(s.l, L.cone_axis);
            const double span = L.cone_cos_inner - L.cone_cos_outer;
            double t = span > 0.0 ? (c - L.cone_cos_outer) / span : (c > L.cone_cos_outer ? 1.0 : 0.0);
            t = std::fmin(1.0, std::fmax(0.0, t));
            s.color = s.color * (t * t * (3.0 - 2.0 * t));
            if (L.cone_focus > 0.0) s.color = s.color * std::pow(std::fmax(c, 0.0), L.cone_focus);
        }
        return s;
    } else if constexpr (std::is_same_v<T, DirectionalLight>) {
        return {L.to_light, HUGE_VAL, L.color};
    } else if constexpr (std::is_same_v<T, RectAreaLight>) {
        LightSample s = detail::toward(L.center, p, L.color);
        if (L.inverse_square) {
            // cos at the light = (p - c)·emit / d with emit = -unit(axis_u × axis_v) = l·unit(u × v).
            const double cos_light = dot(s.l, normalize(cross(L.axis_u, L.axis_v)));
            s.color = s.color * (std::fmax(0.0, cos_light) / (s.distance * s.distance));
        }
        return s;
    } else {
        LightSample s = detail::toward(L.center, p, L.color);
        if (L.inverse_square) s.color = s.color * (1.0 / (s.distance * s.distance));
        return s;
    }
}

namespace detail {
// For k < count: the unit direction (x[k], y[k], z[k]) and distance distance[k] from p to
// target_of(k), several points at a time in double lanes: per lane the operations of toward()
// (v = t − p, d = sqrt((x·x + y·y) + z·z), v / d), so the same numbers. A 9×9 grid needs 81
// square roots and 243 divisions, which one point at a time kept the divider busy for most of
// S3's light loop: in SSE2 pairs S3's render −9 %, in AVX2 quads (`quads`: where the scene walks
// the AVX2 tree, simd_dispatch.hpp) −3 % more. Written as the lanes the shadow bundles read
// (Scene::occluded_by_each), each array padded to an even length with a copy of the last ray.
template <class TargetOf>
void directions_in_pairs(const TargetOf& target_of, const Vec3& p, size_t count, double* x, double* y, double* z,
                         double* distance) {
    const __m128d px = _mm_set1_pd(p.x), py = _mm_set1_pd(p.y), pz = _mm_set1_pd(p.z);
    for (size_t k = 0; k < count; k += 2) {
        const Vec3 a = target_of(k), b = target_of(k + 1 < count ? k + 1 : k);
        const __m128d vx = _mm_sub_pd(_mm_set_pd(b.x, a.x), px);
        const __m128d vy = _mm_sub_pd(_mm_set_pd(b.y, a.y), py);
        const __m128d vz = _mm_sub_pd(_mm_set_pd(b.z, a.z), pz);
        const __m128d d =
            _mm_sqrt_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(vx, vx), _mm_mul_pd(vy, vy)), _mm_mul_pd(vz, vz)));
        _mm_storeu_pd(x + k, _mm_div_pd(vx, d));
        _mm_storeu_pd(y + k, _mm_div_pd(vy, d));
        _mm_storeu_pd(z + k, _mm_div_pd(vz, d));
        _mm_storeu_pd(distance + k, d);
    }
}

template <class TargetOf>
PHONG_AVX2 void directions_in_quads(const TargetOf& target_of, const Vec3& p, size_t count, double* x, double* y,
                                    double* z, double* distance) {
    const __m256d px = _mm256_set1_pd(p.x), py = _mm256_set1_pd(p.y), pz = _mm256_set1_pd(p.z);
    size_t k = 0;
    for (; k + 3 < count; k += 4) {
        const Vec3 a = target_of(k), b = target_of(k + 1), c = target_of(k + 2), e = target_of(k + 3);
        const __m256d vx = _mm256_sub_pd(_mm256_set_pd(e.x, c.x, b.x, a.x), px);
        const __m256d vy = _mm256_sub_pd(_mm256_set_pd(e.y, c.y, b.y, a.y), py);
        const __m256d vz = _mm256_sub_pd(_mm256_set_pd(e.z, c.z, b.z, a.z), pz);
        const __m256d d = _mm256_sqrt_pd(
            _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vx, vx), _mm256_mul_pd(vy, vy)), _mm256_mul_pd(vz, vz)));
        _mm256_storeu_pd(x + k, _mm256_div_pd(vx, d));
        _mm256_storeu_pd(y + k, _mm256_div_pd(vy, d));
        _mm256_storeu_pd(z + k, _mm256_div_pd(vz, d));
        _mm256_storeu_pd(distance + k, d);
    }
    // The last few one at a time, here: handing them to directions_in_pairs (code outside the
    // AVX2 function) made S3's render 20 % slower than with no lanes at all.
    for (; k < count; ++k) {
        const LightSample s = toward(target_of(k), p, RGB{});
        x[k] = s.l.x;
        y[k] = s.l.y;
        z[k] = s.l.z;
        distance[k] = s.distance;
    }
    if (count % 2 == 1) {  // the pad
        x[count] = x[count - 1];
        y[count] = y[count - 1];
        z[count] = z[count - 1];
        distance[count] = distance[count - 1];
    }
}

// visible_fraction() of an area light whose samples sit at c + ju·a1 + jv·a2 (AreaLightGrid's
// offsets). Out of line: it traces up to n² rays, and inlined into the shading loop it made the
// compiler leave a point light's own path (centre, shading) out of line.
template <class Shadow>
[[gnu::noinline]] double area_light_fraction(const AreaLightGrid& grid, const Vec3& p, const LightSample& centre,
                                             Shadow& shadow, const Vec3& c, const Vec3& a1, const Vec3& a2,
                                             bool circular, int adaptive, int cell_samples) {
    const int n = grid.n;
    // Samples sit at c + ju·a1 + jv·a2 with |ju|, |jv| <= 1/2 (the circular mapping only
    // shrinks the nudged coordinates, so <= 1/2 + the nudge there).
    const double half = circular ? 0.5 + kCircularAreaLightNudge : 0.5;
    const Vec3 corners[4] = {c - a1 * half - a2 * half, c + a1 * half - a2 * half, c + a1 * half + a2 * half,
                             c - a1 * half + a2 * half};
    const bool may_be_shadowed = shadow.begin_grid(corners);
    // The light point at grid parameters (fu, fv) in [0, 1]^2 (grid point a at a / (n - 1)).
    auto target_at = [&](double fu, double fv) {
        double ju = fu - 0.5, jv = fv - 0.5;
        if (circular) {
            // Map the square onto the disc (POV-Ray's shells: |(ju, jv)| -> max(|ju|, |jv|)).
            ju += kCircularAreaLightNudge;
            jv += kCircularAreaLightNudge;
            const double scale = std::fmax(std::fabs(ju), std::fabs(jv)) / std::sqrt(ju * ju + jv * jv);
            ju *= scale;
            jv *= scale;
        }
        return c + a1 * ju + a2 * jv;
    };
    // Grid point k (AreaLightGrid's order): the same numbers as target_at(a / (n - 1), b / (n - 1)).
    const bool fixed = !grid.targets.empty();  // then c, a1, a2 are the light's own (a rect light)
    auto target_of = [&](size_t k) { return fixed ? grid.targets[k] : c + a1 * grid.ju[k] + a2 * grid.jv[k]; };
    // The cells estimator's points inside a grid cell (area_cells.hpp).
    auto visible_at = [&](double fu, double fv) {
        const Vec3 v = target_at(fu, fv) - p;
        const double d = length(v);
        return !shadow(v / d, d);
    };
    if (cell_samples > 0 && adaptive == kFullSubdivision) {
        if (!may_be_shadowed) return 1.0;
        thread_local std::vector<signed char> cache;
        cache.assign(size_t(n) * size_t(n), -1);
        return cells_fraction(n, cell_samples, point_key(p), cache, visible_at);
    }
    if (adaptive != kFullSubdivision) {
        // Every grid point visible: every region's corners agree and the recursion's means of
        // ones are exactly 1.
        if (!may_be_shadowed) return 1.0;
        // POV-Ray compares the (float) colour of the light as it arrives (fade, cone, falloff).
        const double colour_sum = std::fabs(double(float(centre.color.x))) + std::fabs(double(float(centre.color.y))) +
                                  std::fabs(double(float(centre.color.z)));
        // Which grid points were traced (-1: not yet), per thread, reused point after point.
        thread_local std::vector<signed char> cache;
        cache.assign(size_t(n) * size_t(n), -1);
        auto visible = [&](int a, int b) {
            const Vec3 v = target_of(size_t(a) * size_t(n) + size_t(b)) - p;
            const double d = length(v);
            return !shadow(v / d, d);
        };
        const uint32_t key = cell_samples > 0 ? point_key(p) : 0;
        auto partial = [&](int a, int b) { return partial_cell_fraction(a, b, n, cell_samples, key, visible_at); };
        return detail::adaptive_fraction(0, 0, n - 1, n - 1, 0, adaptive, colour_sum, n, cache, visible,
                                         cell_samples > 0 ? &partial : nullptr);
    }
    if (!may_be_shadowed) return grid.total_weight;
    // Every ray first (the shadow query then takes them candidate by candidate), then the
    // visible weights summed in grid order.
    const size_t count = size_t(n) * size_t(n), padded = count + count % 2;
    thread_local std::vector<double> lanes;  // x, y, z and the distance, `padded` each
    thread_local std::vector<unsigned char> blocked;
    lanes.resize(4 * padded);
    blocked.resize(count);
    double* const x = lanes.data();
    double *const y = x + padded, *const z = y + padded, *const distance = z + padded;
    if (shadow.quads())
        directions_in_quads(target_of, p, count, x, y, z, distance);
    else
        directions_in_pairs(target_of, p, count, x, y, z, distance);
    shadow.each(x, y, z, distance, count, blocked.data());
    double visible = 0.0;
    for (size_t k = 0; k < count; ++k)
        if (!blocked[k]) visible += grid.weight[k];
    return visible;
}
}  // namespace detail

// `orient`: a sphere light's disc faces p. Axis 1 is perpendicular to l (towards the light's
// centre) and a helper axis (z, or y when l is nearly vertical), axis 2 to l and axis 1; both of
// length 2r.
inline void oriented_axes(const SphereAreaLight& L, const Vec3& l, Vec3& a1, Vec3& a2) {
    const Vec3 helper = std::fabs(std::fabs(l.z) - 1.0) < kOrientVerticalTolerance ? Vec3{0, 1, 0} : Vec3{0, 0, 1};
    const double size = 2.0 * L.radius;
    const Vec3 u = normalize(cross(l, helper));
    a1 = u * size;
    a2 = normalize(cross(l, u)) * size;
}

// The unshadowed fraction of the light at p, in [0, 1]. `grid` is area_light_grid(light).
// `shadow(dir, distance)` traces one shadow ray from p (unit dir; distance to the light sample,
// inf for directional lights); `shadow.each(dirs, distances, count, blocked)` traces the rays of
// a full grid at once (blocked[k] = shadow(dirs[k], distances[k])). Before an area light's grid,
// `shadow.begin_grid(corners)` is told the four corners of a parallelogram that holds every sample of the grid; it
// returns false when no sample can be shadowed (then no ray is traced, and the fraction is the weights' sum in the same
// order, so it is bit-identical).
template <class T, class Shadow>
[[gnu::always_inline]] inline double visible_fraction(const T& L, const AreaLightGrid& grid, const Vec3& p,
                                                      const LightSample& centre, Shadow&& shadow) {
    if constexpr (std::is_same_v<T, PointLight> || std::is_same_v<T, DirectionalLight>) {
        return shadow(centre.l, centre.distance) ? 0.0 : 1.0;
    } else if constexpr (std::is_same_v<T, RectAreaLight>) {
        return detail::area_light_fraction(grid, p, centre, shadow, L.center, L.axis_u, L.axis_v, false, L.adaptive,
                                           L.cell_samples);
    } else {
        Vec3 a1, a2;
        oriented_axes(L, centre.l, a1, a2);
        return detail::area_light_fraction(grid, p, centre, shadow, L.center, a1, a2, true, L.adaptive, L.cell_samples);
    }
}

// The grid sample k of an area light seen along `l` from the shaded point (a rect light's own
// samples; a sphere light's oriented disc), the point area_light_fraction traces towards.
inline Vec3 area_light_sample(const RectAreaLight&, const AreaLightGrid& grid, const Vec3&, size_t k) {
    return grid.targets[k];
}
inline Vec3 area_light_sample(const SphereAreaLight& L, const AreaLightGrid& grid, const Vec3& l, size_t k) {
    Vec3 a1, a2;
    oriented_axes(L, l, a1, a2);
    return L.center + a1 * grid.ju[k] + a2 * grid.jv[k];
}

}  // namespace phong
