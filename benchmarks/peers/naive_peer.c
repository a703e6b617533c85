/* SPDX-License-Identifier: Apache-2.0
 * The naive scalar tracer as a peer of the native one: every primary ray tested against every
 * primitive (brute force, no acceleration structure), then a shadow ray per hit and target,
 * stopping at its first occluder. Double precision, as the native tracer's primitive tests;
 * spheres by centre and radius, triangles by Moller-Trumbore. Built and run by
 * benchmarks/compiled_peers.py at benchmark time (small scenes only), never part of the package.
 *
 *   naive_peer RAYS.bin HITS.bin THREADS REPEAT      (files: peer_input.h)
 *
 * Prints one JSON line: the best of REPEAT render times and the rays traced. */
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <time.h>

#include "peer_input.h"

typedef struct Work {
    const PeerInput* in;
    PeerOutput* out;
    int* next_row;
    size_t rays;
} Work;

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Closest (any, when `any`) hit in (0, t_max) of the ray o + t d over every primitive. */
static double trace(const PeerInput* in, const double o[3], const double d[3], double t_max, int any) {
    double best = t_max;
    for (size_t s = 0; s < in->sphere_count; ++s) {
        const float* c = in->spheres + 4 * s;
        const double oc[3] = {o[0] - c[0], o[1] - c[1], o[2] - c[2]};
        const double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
        const double cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - (double)c[3] * c[3];
        const double disc = b * b - cc;
        if (disc < 0.0) continue;
        const double root = sqrt(disc);
        double t = -b - root;
        if (!(t > 0.0)) t = -b + root;
        if (t > 0.0 && t < best) {
            best = t;
            if (any) return best;
        }
    }
    for (size_t k = 0; k < in->triangle_count; ++k) {
        const uint32_t* tri = in->triangles + 3 * k;
        const float* a = in->points + 3 * tri[0];
        const float* b = in->points + 3 * tri[1];
        const float* c = in->points + 3 * tri[2];
        const double e1[3] = {b[0] - (double)a[0], b[1] - (double)a[1], b[2] - (double)a[2]};
        const double e2[3] = {c[0] - (double)a[0], c[1] - (double)a[1], c[2] - (double)a[2]};
        const double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
        const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
        if (det == 0.0) continue;
        const double inv = 1.0 / det;
        const double s[3] = {o[0] - a[0], o[1] - a[1], o[2] - a[2]};
        const double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
        if (u < 0.0 || u > 1.0) continue;
        const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
        const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
        if (v < 0.0 || u + v > 1.0) continue;
        const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
        if (t > 0.0 && t < best) {
            best = t;
            if (any) return best;
        }
    }
    return best;
}

static void* work(void* arg) {
    Work* w = (Work*)arg;
    const PeerInput* in = w->in;
    size_t rays = 0;
    for (int y; (y = __atomic_fetch_add(w->next_row, 1, __ATOMIC_RELAXED)) < in->height;)
        for (int x = 0; x < in->width; ++x) {
            const size_t ray = (size_t)y * (size_t)in->width + (size_t)x;
            const float* of = in->origins + 3 * ray;
            const float* df = in->dirs + 3 * ray;
            const double o[3] = {of[0], of[1], of[2]}, d[3] = {df[0], df[1], df[2]};
            const double t = trace(in, o, d, INFINITY, 0);
            ++rays;
            w->out->t[ray] = (float)t;
            if (!(t < INFINITY)) continue;
            float p[3];
            hit_point(of, df, (float)t, p);
            for (size_t k = 0; k < in->target_total; ++k) {
                const ShadowRay s = shadow_ray(p, in->targets + 3 * k);
                const double so[3] = {s.org[0], s.org[1], s.org[2]}, sd[3] = {s.dir[0], s.dir[1], s.dir[2]};
                ++rays;
                peer_record(w->out, in, ray, k, trace(in, so, sd, s.tfar, 1) < s.tfar);
            }
        }
    w->rays = rays;
    return NULL;
}

int main(int argc, char** argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s RAYS.bin HITS.bin THREADS REPEAT\n", argv[0]);
        return 2;
    }
    const int threads = atoi(argv[3]), repeat = atoi(argv[4]);
    if (threads < 1 || threads > 256 || repeat < 1) return 2;
    PeerInput in;
    if (!peer_read(&in, argv[1])) return 1;
    PeerOutput out;
    peer_output_init(&out, &in);
    double best = INFINITY;
    size_t rays = 0;
    for (int r = 0; r < repeat; ++r) {
        int next_row = 0;
        Work works[256];
        pthread_t ids[256];
        const double start = now();
        for (int i = 0; i < threads; ++i) {
            works[i] = (Work){&in, &out, &next_row, 0};
            if (i > 0) pthread_create(&ids[i], NULL, work, &works[i]);
        }
        work(&works[0]);
        rays = works[0].rays;
        for (int i = 1; i < threads; ++i) {
            pthread_join(ids[i], NULL);
            rays += works[i].rays;
        }
        const double elapsed = now() - start;
        if (elapsed < best) best = elapsed;
    }
    if (!peer_write(&out, argv[2])) return 1;
    printf("{\"render\": %.6f, \"rays\": %zu}\n", best, rays);
    return 0;
}
