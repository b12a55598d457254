/*
 * What the C test programs under tests/c/ share: the CHECK and OK macros (a failed check is
 * reported on stderr and counted in `failures`; a failed call that must succeed stops the
 * program with the library's message) and the icosphere meshes they bake. Each program is one
 * translation unit that includes this once.
 */
#ifndef TRANSCUT_TESTS_C_COMMON_H
#define TRANSCUT_TESTS_C_COMMON_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "transcut.h"

static int failures = 0;

#define CHECK(cond, ...)                                                        \
    do {                                                                        \
        if (!(cond)) {                                                          \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);     \
            fprintf(stderr, __VA_ARGS__);                                       \
            fprintf(stderr, "\n");                                              \
            failures++;                                                         \
        }                                                                       \
    } while (0)

/* A call that must succeed; otherwise report the library's message and stop. */
#define OK(call)                                                                \
    do {                                                                        \
        TcStatus status_ = (call);                                              \
        if (status_ != TC_OK) {                                                 \
            fprintf(stderr, "FAIL %s:%d: %s -> %s: %s\n", __FILE__, __LINE__,   \
                    #call, tc_status_name(status_), tc_last_error_message());   \
            exit(1);                                                            \
        }                                                                       \
    } while (0)

static const double PI = 3.14159265358979323846;

/* ---------------------------------------------------------------------------------------- */
/* Icosphere: an icosahedron whose triangles are split in four `levels` times, vertices     */
/* pushed onto the sphere. Vertices on shared edges are created once (edge midpoint table). */

typedef struct {
    float *positions;   /* 3 per vertex */
    uint32_t *indices;  /* 3 per triangle */
    size_t vertex_count, triangle_count;
} Mesh;

static uint32_t midpoint(Mesh *m, uint32_t *edge_keys, uint32_t *edge_mid, size_t table,
                         uint32_t a, uint32_t b, float radius) {
    uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    size_t h = ((size_t)lo * 2654435761u + hi) % table;
    while (edge_mid[h] != UINT32_MAX) {
        if (edge_keys[2 * h] == lo && edge_keys[2 * h + 1] == hi) return edge_mid[h];
        h = (h + 1) % table;
    }
    float x = m->positions[3 * lo] + m->positions[3 * hi];
    float y = m->positions[3 * lo + 1] + m->positions[3 * hi + 1];
    float z = m->positions[3 * lo + 2] + m->positions[3 * hi + 2];
    float s = radius / sqrtf(x * x + y * y + z * z);
    uint32_t v = (uint32_t)m->vertex_count++;
    m->positions[3 * v] = x * s;
    m->positions[3 * v + 1] = y * s;
    m->positions[3 * v + 2] = z * s;
    edge_keys[2 * h] = lo;
    edge_keys[2 * h + 1] = hi;
    edge_mid[h] = v;
    return v;
}

static Mesh icosphere(float radius, int levels) {
    static const float ico_v[12][3] = {
        {-1, 1.61803399f, 0}, {1, 1.61803399f, 0}, {-1, -1.61803399f, 0}, {1, -1.61803399f, 0},
        {0, -1, 1.61803399f}, {0, 1, 1.61803399f}, {0, -1, -1.61803399f}, {0, 1, -1.61803399f},
        {1.61803399f, 0, -1}, {1.61803399f, 0, 1}, {-1.61803399f, 0, -1}, {-1.61803399f, 0, 1}};
    static const uint32_t ico_f[20][3] = {
        {0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
        {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
        {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    size_t faces = 20, verts = 12;
    for (int l = 0; l < levels; l++) { verts += faces * 3 / 2; faces *= 4; }
    Mesh m;
    m.positions = malloc(3 * verts * sizeof(float));
    m.indices = malloc(3 * faces * sizeof(uint32_t));
    m.vertex_count = 12;
    m.triangle_count = 20;
    for (int i = 0; i < 12; i++) {
        float n = sqrtf(ico_v[i][0] * ico_v[i][0] + ico_v[i][1] * ico_v[i][1] + ico_v[i][2] * ico_v[i][2]);
        for (int c = 0; c < 3; c++) m.positions[3 * i + c] = ico_v[i][c] * radius / n;
    }
    memcpy(m.indices, ico_f, sizeof ico_f);
    size_t table = 4 * verts + 1;
    uint32_t *keys = malloc(2 * table * sizeof(uint32_t));
    uint32_t *mids = malloc(table * sizeof(uint32_t));
    uint32_t *next = malloc(3 * faces * sizeof(uint32_t));
    for (int l = 0; l < levels; l++) {
        for (size_t i = 0; i < table; i++) mids[i] = UINT32_MAX;
        size_t n = 0;
        for (size_t f = 0; f < m.triangle_count; f++) {
            uint32_t a = m.indices[3 * f], b = m.indices[3 * f + 1], c = m.indices[3 * f + 2];
            uint32_t ab = midpoint(&m, keys, mids, table, a, b, radius);
            uint32_t bc = midpoint(&m, keys, mids, table, b, c, radius);
            uint32_t ca = midpoint(&m, keys, mids, table, c, a, radius);
            uint32_t tri[12] = {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca};
            memcpy(next + 3 * n, tri, sizeof tri);
            n += 4;
        }
        memcpy(m.indices, next, 3 * n * sizeof(uint32_t));
        m.triangle_count = n;
    }
    free(keys);
    free(mids);
    free(next);
    return m;
}

#endif /* TRANSCUT_TESTS_C_COMMON_H */
