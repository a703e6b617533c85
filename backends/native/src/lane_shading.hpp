// SPDX-License-Identifier: Apache-2.0
// The direct lighting of a packet's primary hits in AVX double lanes (render.cpp: trace_packet).
// In shade_hit the light loop of one shaded point is a chain per light of a square root and
// three divisions (the light's direction), then n·l, the shadow ray and the Phong terms; its
// latency, not its instructions, set S1's shading time (issue 25, benchmarks/README.md). Here
// four points take one chain: per lane the same IEEE operations in the same order as shade_hit
// and shade_phong (no FMA: -ffp-contract=off), their branches replaced by masks, so every lane's
// colour is shade_hit's bit for bit. Shadow rays and std::pow stay scalar, one per lane that
// needs it.
//
// Only what S1-like scenes need: point lights without fade or spotlight cone (inverse square
// allowed), and shaded points whose material has no texture, checker, mirror or transmission
// (render.cpp decides per point, lane_material below; other points take shade_hit).
#pragma once

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <variant>
#include <vector>

#include "lights.hpp"
#include "materials.hpp"
#include "math.hpp"
#include "scene.hpp"
#include "simd_dispatch.hpp"
#include "uninitialised.hpp"

namespace phong {

// The points of the packets shaded together (render.cpp, kShadedPackets): at most 64, groups of
// four lanes.
constexpr int kShadingLanes = 64;

// What shade_hit has computed before its light loop, one lane per shaded point.
struct ShadedLanes {
    alignas(32) double px[kShadingLanes], py[kShadingLanes], pz[kShadingLanes];  // the point
    // The normal: unit, or where to_normalize has the lane's bit, to be normalized (normalize());
    // add_point_lights then turns it to face the ray, as shade_hit.
    alignas(32) double nx[kShadingLanes], ny[kShadingLanes], nz[kShadingLanes];
    alignas(32) double wx[kShadingLanes], wy[kShadingLanes], wz[kShadingLanes];  // wo = −ray direction
    // The colour: ambient + emission, then each light's terms added in the order of the lights.
    alignas(32) double cx[kShadingLanes], cy[kShadingLanes], cz[kShadingLanes];
    // cd · (kd / π): shade_phong's diffuse before the light's multiplier.
    alignas(32) double kx[kShadingLanes], ky[kShadingLanes], kz[kShadingLanes];
    alignas(32) double sx[kShadingLanes], sy[kShadingLanes], sz[kShadingLanes];  // cs
    double ks[kShadingLanes], exponent[kShadingLanes];
    uint64_t lanes = 0;  // bit k: lane k holds a point shaded here
    uint64_t to_normalize = 0;
};

// A light the lanes shade: a point light whose colour at p is its own, or / d² (inverse square).
inline bool lane_light(const Light& light) {
    const PointLight* L = std::get_if<PointLight>(&light);
    return L != nullptr && !(L->fade_power > 0.0) && !(L->cone_cos_outer > -1.0);
}

// A material whose shading is ambient + emission + the Phong terms of each light and nothing
// else (no texture or checker changing cd, cs or n; no mirror or transmitted ray).
inline bool lane_material(const Material& m) {
    return !m.textured() && !(m.checker_size > 0.0) && !(m.kr > 0.0 || m.kt > 0.0);
}

// What the lanes take of a material, computed once a render (TraceContext::lane_materials) with
// shade_hit's operations: the colour before any light (ambient term + emission), cd · (kd / π),
// cs, ks and e; `plain`: lane_material.
struct LaneMaterial {
    RGB unlit, diffuse, specular;
    double ks, exponent;
    bool plain;
    LaneMaterial(const Material& m, const RGB& ambient)
        : unlit(ambient_term(m, ambient) + m.emission),
          diffuse(m.diffuse_color * (m.kd / kPi)),
          specular(m.specular_color),
          ks(m.ks),
          exponent(m.exponent),
          plain(lane_material(m)) {}
};

// The scene's part of TraceContext::lane_shading: the AVX2 path (the lanes need it), no light
// links, and every light a lane_light.
inline bool lane_lights(const Scene& scene) {
    return scene.walk_width() == 8 && scene.light_links.empty() &&
           std::all_of(scene.lights.begin(), scene.lights.end(), lane_light);
}

namespace detail {
PHONG_AVX2 inline __m256d lane_dot(__m256d ax, __m256d ay, __m256d az, __m256d bx, __m256d by, __m256d bz) {
    // dot(): a.x·b.x + a.y·b.y + a.z·b.z, left to right
    return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ax, bx), _mm256_mul_pd(ay, by)), _mm256_mul_pd(az, bz));
}
// The lanes of bits, all ones, as a mask of doubles.
PHONG_AVX2 inline __m256d lane_mask(unsigned bits) {
    const __m256i bit = _mm256_set_epi64x(8, 4, 2, 1);
    const __m256i set = _mm256_and_si256(_mm256_set1_epi64x(bits), bit);
    return _mm256_castsi256_pd(_mm256_cmpeq_epi64(set, bit));
}
}  // namespace detail

// Adds to s's colours the terms of `lights` (every one lane_light), as shade_hit's loop does for
// each point: `shadow(p, l, distance, count)` has bit i set where the shadow ray from p[i] along
// l[i] to a light at distance[i] is blocked (ShadowQuery's answer), asked only where n·l passes
// kMinCosineToLight, one light after the other.
template <class Shadow>
PHONG_AVX2 void add_point_lights(const std::vector<Light>& lights, SpecularConvention convention, ShadedLanes& s,
                                 Shadow&& shadow) {
    const __m256d zero = _mm256_setzero_pd(), two = _mm256_set1_pd(2.0);
    const __m256d min_cosine = _mm256_set1_pd(kMinCosineToLight);
    const __m256d sign = _mm256_set1_pd(-0.0);
    // Each group's normal: n / sqrt(n·n) where asked, then turned to the viewer (−n where n·d > 0,
    // d = −wo the ray's direction; negation is exact), as shade_hit; kept in s.
    for (int g = 0; g < kShadingLanes; g += 4) {
        if (((s.lanes >> g) & 0xFu) == 0) continue;
        __m256d nx = _mm256_load_pd(s.nx + g), ny = _mm256_load_pd(s.ny + g), nz = _mm256_load_pd(s.nz + g);
        if (const unsigned raw = unsigned(s.to_normalize >> g) & 0xFu) {
            const __m256d length = _mm256_sqrt_pd(detail::lane_dot(nx, ny, nz, nx, ny, nz));
            const __m256d keep = detail::lane_mask(raw);
            nx = _mm256_blendv_pd(nx, _mm256_div_pd(nx, length), keep);
            ny = _mm256_blendv_pd(ny, _mm256_div_pd(ny, length), keep);
            nz = _mm256_blendv_pd(nz, _mm256_div_pd(nz, length), keep);
        }
        const __m256d wx = _mm256_load_pd(s.wx + g), wy = _mm256_load_pd(s.wy + g), wz = _mm256_load_pd(s.wz + g);
        const __m256d away = _mm256_cmp_pd(
            detail::lane_dot(nx, ny, nz, _mm256_xor_pd(wx, sign), _mm256_xor_pd(wy, sign), _mm256_xor_pd(wz, sign)),
            zero, _CMP_GT_OQ);
        const __m256d flip = _mm256_and_pd(away, sign);
        _mm256_store_pd(s.nx + g, _mm256_xor_pd(nx, flip));
        _mm256_store_pd(s.ny + g, _mm256_xor_pd(ny, flip));
        _mm256_store_pd(s.nz + g, _mm256_xor_pd(nz, flip));
    }
    for (const Light& light : lights) {
        const PointLight& L = *std::get_if<PointLight>(&light);
        // sample_light_centre in every group: v = position − p, d = |v|, l = v / d; then n·l.
        alignas(32) double l[3][kShadingLanes], distance[kShadingLanes], cosine_nl[kShadingLanes];
        uint64_t lit = 0;
        for (int g = 0; g < kShadingLanes; g += 4) {
            const unsigned group = unsigned(s.lanes >> g) & 0xFu;
            if (group == 0) continue;
            const __m256d vx = _mm256_sub_pd(_mm256_set1_pd(L.position.x), _mm256_load_pd(s.px + g));
            const __m256d vy = _mm256_sub_pd(_mm256_set1_pd(L.position.y), _mm256_load_pd(s.py + g));
            const __m256d vz = _mm256_sub_pd(_mm256_set1_pd(L.position.z), _mm256_load_pd(s.pz + g));
            const __m256d d = _mm256_sqrt_pd(detail::lane_dot(vx, vy, vz, vx, vy, vz));
            const __m256d lx = _mm256_div_pd(vx, d), ly = _mm256_div_pd(vy, d), lz = _mm256_div_pd(vz, d);
            const __m256d n_dot_l = detail::lane_dot(_mm256_load_pd(s.nx + g), _mm256_load_pd(s.ny + g),
                                                     _mm256_load_pd(s.nz + g), lx, ly, lz);
            _mm256_store_pd(l[0] + g, lx);
            _mm256_store_pd(l[1] + g, ly);
            _mm256_store_pd(l[2] + g, lz);
            _mm256_store_pd(distance + g, d);
            _mm256_store_pd(cosine_nl + g, n_dot_l);
            // No term and no shadow ray unless n·l >= kMinCosineToLight (false for NaN).
            lit |= uint64_t(group & unsigned(_mm256_movemask_pd(_mm256_cmp_pd(n_dot_l, min_cosine, _CMP_GE_OQ)))) << g;
        }
        if (lit == 0) continue;
        {
            // The lit points' shadow rays to this light, asked together.
            DeferredArray<Vec3, kShadingLanes> p, dir;
            double limit[kShadingLanes];
            int lane[kShadingLanes], rays = 0;
            for (uint64_t bits = lit; bits != 0; bits &= bits - 1, ++rays) {
                const int k = __builtin_ctzll(bits);
                lane[rays] = k;
                p.emplace(size_t(rays), Vec3{s.px[k], s.py[k], s.pz[k]});
                dir.emplace(size_t(rays), Vec3{l[0][k], l[1][k], l[2][k]});
                limit[rays] = distance[k];
            }
            const uint64_t blocked = shadow(p.data(), dir.data(), limit, rays);
            for (int i = 0; i < rays; ++i)
                if (blocked >> i & 1u) lit &= ~(uint64_t(1) << lane[i]);
        }
        for (int g = 0; g < kShadingLanes; g += 4) {
            const unsigned on_bits = unsigned(lit >> g) & 0xFu;
            if (on_bits == 0) continue;
            const __m256d nx = _mm256_load_pd(s.nx + g), ny = _mm256_load_pd(s.ny + g), nz = _mm256_load_pd(s.nz + g);
            const __m256d wx = _mm256_load_pd(s.wx + g), wy = _mm256_load_pd(s.wy + g), wz = _mm256_load_pd(s.wz + g);
            const __m256d lx = _mm256_load_pd(l[0] + g), ly = _mm256_load_pd(l[1] + g), lz = _mm256_load_pd(l[2] + g);
            const __m256d d = _mm256_load_pd(distance + g), n_dot_l = _mm256_load_pd(cosine_nl + g);
            // The light's colour at p (sample_light_centre), times the visible fraction 1 (exact).
            __m256d ex = _mm256_set1_pd(L.color.x), ey = _mm256_set1_pd(L.color.y), ez = _mm256_set1_pd(L.color.z);
            if (L.inverse_square) {
                const __m256d falloff = _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_mul_pd(d, d));
                ex = _mm256_mul_pd(ex, falloff);
                ey = _mm256_mul_pd(ey, falloff);
                ez = _mm256_mul_pd(ez, falloff);
            }
            // shade_phong: diffuse = cd · (kd / π) · the light's multiplier.
            const __m256d diffuse_scale = _mm256_set1_pd(L.terms.diffuse);
            const __m256d dx = _mm256_mul_pd(_mm256_load_pd(s.kx + g), diffuse_scale),
                          dy = _mm256_mul_pd(_mm256_load_pd(s.ky + g), diffuse_scale),
                          dz = _mm256_mul_pd(_mm256_load_pd(s.kz + g), diffuse_scale);
            __m256d tx, ty, tz;  // this light's terms
            alignas(32) double specular[4] = {0.0, 0.0, 0.0, 0.0};
            alignas(32) double cosine[4];
            if (convention == SpecularConvention::kSeed) {
                // r = n (2 n·l) − l; cs (ks (r·wo)^e) where r·wo > 0, else 0.
                const __m256d twice = _mm256_mul_pd(two, n_dot_l);
                const __m256d rx = _mm256_sub_pd(_mm256_mul_pd(nx, twice), lx);
                const __m256d ry = _mm256_sub_pd(_mm256_mul_pd(ny, twice), ly);
                const __m256d rz = _mm256_sub_pd(_mm256_mul_pd(nz, twice), lz);
                const __m256d r_dot_wo = detail::lane_dot(rx, ry, rz, wx, wy, wz);
                const unsigned glossy =
                    on_bits & unsigned(_mm256_movemask_pd(_mm256_cmp_pd(r_dot_wo, zero, _CMP_GT_OQ)));
                _mm256_store_pd(cosine, r_dot_wo);
                for (unsigned bits = glossy; bits != 0; bits &= bits - 1) {
                    const int k = __builtin_ctz(bits);
                    specular[k] = s.ks[g + k] * std::pow(cosine[k], s.exponent[g + k]);
                }
                const __m256d f = _mm256_load_pd(specular), keep = detail::lane_mask(glossy);
                const __m256d specular_scale = _mm256_set1_pd(L.terms.specular);
                // (cs · f) · multiplier where glossy; +0 (RGB{}) elsewhere.
                const __m256d gx =
                    _mm256_and_pd(keep, _mm256_mul_pd(_mm256_mul_pd(_mm256_load_pd(s.sx + g), f), specular_scale));
                const __m256d gy =
                    _mm256_and_pd(keep, _mm256_mul_pd(_mm256_mul_pd(_mm256_load_pd(s.sy + g), f), specular_scale));
                const __m256d gz =
                    _mm256_and_pd(keep, _mm256_mul_pd(_mm256_mul_pd(_mm256_load_pd(s.sz + g), f), specular_scale));
                // hadamard(diffuse + specular, light) · n·l
                tx = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(dx, gx), ex), n_dot_l);
                ty = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(dy, gy), ey), n_dot_l);
                tz = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(dz, gz), ez), n_dot_l);
            } else {
                // POV-Ray's: hadamard(diffuse, light) · n·l, plus light · (ks (r·l)^e · multiplier)
                // where ks > 0, r·l > 0 and the classic cut-off does not apply; r mirrors the ray.
                tx = _mm256_mul_pd(_mm256_mul_pd(dx, ex), n_dot_l);
                ty = _mm256_mul_pd(_mm256_mul_pd(dy, ey), n_dot_l);
                tz = _mm256_mul_pd(_mm256_mul_pd(dz, ez), n_dot_l);
                const __m256d rayx = _mm256_xor_pd(wx, sign), rayy = _mm256_xor_pd(wy, sign),
                              rayz = _mm256_xor_pd(wz, sign);
                const __m256d twice = _mm256_mul_pd(two, detail::lane_dot(rayx, rayy, rayz, nx, ny, nz));
                const __m256d rx = _mm256_sub_pd(rayx, _mm256_mul_pd(nx, twice));
                const __m256d ry = _mm256_sub_pd(rayy, _mm256_mul_pd(ny, twice));
                const __m256d rz = _mm256_sub_pd(rayz, _mm256_mul_pd(nz, twice));
                _mm256_store_pd(cosine, detail::lane_dot(rx, ry, rz, lx, ly, lz));
                unsigned glossy = 0;
                for (unsigned bits = on_bits; bits != 0; bits &= bits - 1) {
                    const int k = __builtin_ctz(bits);
                    const double ks = s.ks[g + k], e = s.exponent[g + k], r_dot_l = cosine[k];
                    if (!(ks > 0.0 && r_dot_l > 0.0)) continue;
                    if (e >= kClassicPhongCutoffExponent && r_dot_l <= kClassicPhongCutoffCosine) continue;
                    specular[k] = ks * std::pow(r_dot_l, e) * L.terms.specular;
                    glossy |= 1u << k;
                }
                const __m256d f = _mm256_load_pd(specular), keep = detail::lane_mask(glossy);
                tx = _mm256_blendv_pd(tx, _mm256_add_pd(tx, _mm256_mul_pd(ex, f)), keep);
                ty = _mm256_blendv_pd(ty, _mm256_add_pd(ty, _mm256_mul_pd(ey, f)), keep);
                tz = _mm256_blendv_pd(tz, _mm256_add_pd(tz, _mm256_mul_pd(ez, f)), keep);
            }
            const __m256d on = detail::lane_mask(on_bits);
            const __m256d cx = _mm256_load_pd(s.cx + g), cy = _mm256_load_pd(s.cy + g), cz = _mm256_load_pd(s.cz + g);
            _mm256_store_pd(s.cx + g, _mm256_blendv_pd(cx, _mm256_add_pd(cx, tx), on));
            _mm256_store_pd(s.cy + g, _mm256_blendv_pd(cy, _mm256_add_pd(cy, ty), on));
            _mm256_store_pd(s.cz + g, _mm256_blendv_pd(cz, _mm256_add_pd(cz, tz), on));
        }
    }
}

}  // namespace phong
