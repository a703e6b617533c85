/* SPDX-License-Identifier: Apache-2.0
 * The rays a compiled peer traces (benchmarks/compiled_peers.py writes them) and the answers it
 * writes back for the check against the native tracer. Plain C, for the C and C++ peers.
 *
 * RAYS.bin, little-endian: int32 magic 0x52504850 ("PHPR"), width, height, point count,
 * triangle count, sphere count, light count; then per light its shadow-target count (int32);
 * then float32 points (x, y, z), uint32 triangles (three point rows), float32 spheres (centre
 * and radius), float32 primary-ray origins and unit directions (one per pixel, row order),
 * float32 shadow targets (x, y, z), lights in order.
 * HITS.bin: float32 hit distance per primary ray (inf: no hit); then per point light (a light
 * with one target) one byte per primary ray: 1 occluded, 0 not, 2 no shadow ray (no hit). */
#ifndef PHONGSCENE_PEER_INPUT_H
#define PHONGSCENE_PEER_INPUT_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PEER_MAGIC 0x52504850
/* A shadow ray starts this far from the hit point toward its target and stops as far before it
 * (as the Mitsuba peer's, benchmarks/mitsuba_peer.py): a timing needs a plausible offset only. */
#define PEER_SHADOW_OFFSET 1e-4f

typedef struct PeerInput {
    int width, height;
    size_t point_count, triangle_count, sphere_count, light_count, target_total, ray_count;
    float* points;
    uint32_t* triangles;
    float* spheres;
    float* origins;
    float* dirs;
    float* targets;
    int* point_slot; /* per target: its light's index among the point lights, or -1 */
    size_t point_lights;
    void* data;
} PeerInput;

typedef struct PeerOutput {
    float* t;
    unsigned char* occluded; /* point_lights x ray_count */
    size_t ray_count, point_lights;
} PeerOutput;

static int peer_read(PeerInput* in, const char* path) {
    FILE* f = fopen(path, "rb");
    if (!f) { perror(path); return 0; }
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char* data = (char*)malloc((size_t)size);
    if (!data || fread(data, 1, (size_t)size, f) != (size_t)size) { fprintf(stderr, "%s: short read\n", path); fclose(f); return 0; }
    fclose(f);
    int32_t head[7];
    memcpy(head, data, sizeof head);
    if (head[0] != PEER_MAGIC) { fprintf(stderr, "%s: not a peer ray file\n", path); return 0; }
    in->width = head[1], in->height = head[2];
    in->point_count = (size_t)head[3], in->triangle_count = (size_t)head[4], in->sphere_count = (size_t)head[5];
    in->light_count = (size_t)head[6];
    const int32_t* counts = (const int32_t*)(data + sizeof head);
    in->target_total = 0;
    for (size_t l = 0; l < in->light_count; ++l) in->target_total += (size_t)counts[l];
    in->point_slot = (int*)malloc(sizeof(int) * (in->target_total + 1));
    in->point_lights = 0;
    size_t k = 0;
    for (size_t l = 0; l < in->light_count; ++l) {
        for (int32_t j = 0; j < counts[l]; ++j) in->point_slot[k++] = counts[l] == 1 ? (int)in->point_lights : -1;
        in->point_lights += counts[l] == 1;
    }
    in->ray_count = (size_t)in->width * (size_t)in->height;
    char* p = data + sizeof head + sizeof(int32_t) * in->light_count;
    in->points = (float*)p, p += sizeof(float) * 3 * in->point_count;
    in->triangles = (uint32_t*)p, p += sizeof(uint32_t) * 3 * in->triangle_count;
    in->spheres = (float*)p, p += sizeof(float) * 4 * in->sphere_count;
    in->origins = (float*)p, p += sizeof(float) * 3 * in->ray_count;
    in->dirs = (float*)p, p += sizeof(float) * 3 * in->ray_count;
    in->targets = (float*)p, p += sizeof(float) * 3 * in->target_total;
    if (p - data != size) { fprintf(stderr, "%s: %ld bytes, expected %ld\n", path, size, (long)(p - data)); return 0; }
    in->data = data;
    return 1;
}

static void peer_output_init(PeerOutput* out, const PeerInput* in) {
    out->ray_count = in->ray_count, out->point_lights = in->point_lights;
    out->t = (float*)malloc(sizeof(float) * in->ray_count);
    out->occluded = (unsigned char*)malloc(in->ray_count * in->point_lights + 1);
    memset(out->occluded, 2, in->ray_count * in->point_lights);
}

/* The answer of ray `ray`'s shadow ray toward target k (kept for point lights only). */
static void peer_record(PeerOutput* out, const PeerInput* in, size_t ray, size_t k, int occluded) {
    const int slot = in->point_slot[k];
    if (slot >= 0) out->occluded[(size_t)slot * out->ray_count + ray] = (unsigned char)occluded;
}

static int peer_write(const PeerOutput* out, const char* path) {
    FILE* f = fopen(path, "wb");
    if (!f) { perror(path); return 0; }
    int ok = fwrite(out->t, sizeof(float), out->ray_count, f) == out->ray_count &&
             fwrite(out->occluded, 1, out->ray_count * out->point_lights, f) == out->ray_count * out->point_lights;
    return fclose(f) == 0 && ok;
}

/* The hit point o + t d, in float (benchmarks/compiled_peers.py computes the same in numpy). */
static void hit_point(const float* o, const float* d, float t, float* p) {
    for (int i = 0; i < 3; ++i) p[i] = o[i] + d[i] * t;
}

typedef struct ShadowRay {
    float org[3], dir[3], tfar;
} ShadowRay;

/* From hit point p toward `target`: unit direction, the offset origin, the far limit. */
static ShadowRay shadow_ray(const float* p, const float* target) {
    ShadowRay s;
    float l[3] = {target[0] - p[0], target[1] - p[1], target[2] - p[2]};
    const float dist = sqrtf(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (int i = 0; i < 3; ++i) {
        s.dir[i] = l[i] / dist;
        s.org[i] = p[i] + s.dir[i] * PEER_SHADOW_OFFSET;
    }
    s.tfar = dist - 2.0f * PEER_SHADOW_OFFSET;
    return s;
}

#endif
