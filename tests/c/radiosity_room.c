/*
 * Translucent radiosity through include/transcut.h, as an application would use it.
 *
 * A marble ball (an icosphere of radius 10 mm) inside a closed room: a 60 mm cube added with
 * tc_scene_add_diffuse_mesh, reflecting on its inside (TC_SIDES_BACK) and emitting M; no
 * lights, so the room's emission is all the light there is.
 *
 * 1. Methods that bake objects alone (TransCut, the hierarchical dipole) refuse the diffuse
 *    room with TC_UNSUPPORTED, naming radiosity.
 * 2. TC_METHOD_RADIOSITY with albedo 0: the room reflects nothing, so its radiosity is its
 *    emission and its radiance exactly M/pi at every vertex, whatever the ball does; the ball,
 *    lit by the room from every side, has a finite radiance > 0 at every vertex. The scene's
 *    statistics (tc_scene_radiosity_stats) are consistent.
 * 3. Bad input is named and changes nothing (the last bake's results stay readable): an
 *    albedo of 1 or NaN, a negative emission, unknown sides, albedo on the translucent ball, a
 *    medium on the diffuse room, radiosity options out of range.
 * 4. Albedo 0.5: inter-reflection brightens the room above M/pi.
 * 5. The coupled session: tc_object_edit_albedo refuses the ball and an albedo of 1.5 with
 *    nothing changed, and at 0.25 re-solves the baked scene (the room between M/pi and its
 *    radiance at 0.5); a point lamp and tc_scene_relight brighten every room vertex.
 * 6. With one bounce only (TcRadiosityOptions.bounces = 1) the room is M/pi again, exactly.
 *
 * Exit status 0 when every check passes. Run under valgrind and LeakSanitizer by
 * tests/c/run.sh.
 */
#include "common.h"

/* A closed cube of half-side h centred at the origin: 8 corners, 12 triangles. */
static const uint32_t cube_indices[36] = {
    0, 2, 3, 0, 3, 1, /* z = -h */
    4, 5, 7, 4, 7, 6, /* z = +h */
    0, 1, 5, 0, 5, 4, /* y = -h */
    2, 6, 7, 2, 7, 3, /* y = +h */
    0, 4, 6, 0, 6, 2, /* x = -h */
    1, 3, 7, 1, 7, 5, /* x = +h */
};

static void cube(float h, float positions[24]) {
    for (int i = 0; i < 8; i++) {
        positions[3 * i] = (i & 1) ? h : -h;
        positions[3 * i + 1] = (i & 2) ? h : -h;
        positions[3 * i + 2] = (i & 4) ? h : -h;
    }
}

/* Whether the last error message contains `needle` (reported when it does not). */
static int says(const char *needle) {
    const char *message = tc_last_error_message();
    if (strstr(message, needle) != NULL) return 1;
    fprintf(stderr, "message \"%s\" does not mention \"%s\"\n", message, needle);
    return 0;
}

/* Bakes with `options` (method and method options set by the caller). */
static TcStatus bake(TcScene *scene, const TcBakeOptions *options) { return tc_scene_bake(scene, options, NULL, NULL); }

/* Checks that every float of the room's radiance is want[c] / pi to float precision. */
static void check_room_is(const float *rgb, size_t n, const double want[3], const char *what) {
    for (size_t v = 0; v < n; v++)
        for (int c = 0; c < 3; c++) {
            double expected = want[c] / PI, got = rgb[3 * v + c];
            CHECK(fabs(got - expected) <= 1e-6 * expected, "%s: vertex %zu channel %d: %.8f, want %.8f", what, v, c, got,
                  expected);
        }
}

int main(void) {
    Mesh ball_mesh = icosphere(10.0f, 2);
    float room_positions[24];
    cube(30.0f, room_positions);
    const double emission[3] = {1.0, 0.5, 0.25};

    TcScene *scene = NULL;
    uint32_t ball = UINT32_MAX, room = UINT32_MAX, kind = 99;
    OK(tc_scene_create(&scene));
    OK(tc_scene_add_mesh(scene, ball_mesh.positions, ball_mesh.vertex_count, ball_mesh.indices,
                         3 * ball_mesh.triangle_count, &ball));
    OK(tc_object_set_medium_preset(scene, ball, "marble"));
    OK(tc_scene_add_diffuse_mesh(scene, room_positions, 8, cube_indices, 36, (const double[3]){0.0, 0.0, 0.0}, &room));
    OK(tc_object_set_name(scene, room, "room"));
    OK(tc_object_set_sides(scene, room, TC_SIDES_BACK));
    OK(tc_object_set_emission(scene, room, emission));
    OK(tc_object_material(scene, room, &kind));
    CHECK(kind == TC_MATERIAL_DIFFUSE, "the room is diffuse (%u)", kind);
    OK(tc_object_material(scene, ball, &kind));
    CHECK(kind == TC_MATERIAL_TRANSLUCENT, "the ball is translucent (%u)", kind);

    /* 1. The methods that bake objects alone refuse the room, naming radiosity. */
    TcBakeOptions options;
    OK(tc_bake_options_init(&options, sizeof options));
    options.tets = 5000;
    options.backend = TC_BACKEND_CPU; /* valgrind and a GPU driver do not mix */
    CHECK(bake(scene, &options) == TC_UNSUPPORTED && says("radiosity") && says("room"), "TransCut refuses the room");
    options.method = TC_METHOD_HIERARCHICAL_DIPOLE;
    CHECK(bake(scene, &options) == TC_UNSUPPORTED && says("radiosity"), "the dipole refuses the room");

    /* 2. Radiosity, albedo 0. */
    char name[16];
    OK(tc_method_name(TC_METHOD_RADIOSITY, name, sizeof name, NULL));
    CHECK(strcmp(name, "radiosity") == 0, "method 2 is %s", name);
    TcRadiosityOptions radiosity;
    OK(tc_radiosity_options_init(&radiosity, sizeof radiosity));
    CHECK(radiosity.size == sizeof radiosity && radiosity.iteration == TC_RADIOSITY_JACOBI &&
              radiosity.patch_size_mm == 0.0 && radiosity.bounces == 0 && radiosity.rays_per_patch == 512,
          "radiosity defaults");
    radiosity.patch_size_mm = 12.0; /* the walls in 5 x 5 patches: fast, also under valgrind */
    radiosity.rays_per_patch = 256;
    radiosity.tolerance = 1e-4;
    options.method = TC_METHOD_RADIOSITY;
    options.method_options = &radiosity;
    TcRadiosityStats stats;
    memset(&stats, 0, sizeof stats);
    stats.size = sizeof stats;
    CHECK(tc_scene_radiosity_stats(scene, &stats) == TC_NOT_BAKED, "no statistics before a bake");
    OK(bake(scene, &options));

    size_t nb = 0, nr = 0;
    OK(tc_object_vertex_count(scene, ball, &nb));
    OK(tc_object_vertex_count(scene, room, &nr));
    CHECK(nb == ball_mesh.vertex_count && nr == 8, "vertex counts %zu and %zu", nb, nr);
    float *ball_rgb = malloc(3 * nb * sizeof(float)), *room_rgb = malloc(3 * nr * sizeof(float));
    float *again = malloc(3 * nb * sizeof(float));
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    check_room_is(room_rgb, nr, emission, "albedo 0");
    OK(tc_object_radiance(scene, ball, ball_rgb, 3 * nb));
    double mean[3] = {0, 0, 0};
    for (size_t v = 0; v < nb; v++)
        for (int c = 0; c < 3; c++) {
            float x = ball_rgb[3 * v + c];
            CHECK(isfinite(x) && x > 0.0f, "ball vertex %zu channel %d: %g", v, c, x);
            mean[c] += x / nb;
        }
    printf("albedo 0: room Lo = M/pi = (%.6f %.6f %.6f), ball mean Lo = (%.5f %.5f %.5f)\n", room_rgb[0], room_rgb[1],
           room_rgb[2], mean[0], mean[1], mean[2]);

    OK(tc_scene_radiosity_stats(scene, &stats));
    printf("radiosity: %llu patches (%llu translucent, %llu covered), %llu form factors, %u sweeps, error %.2e, "
           "energy defect %.2e, form factors %.1f ms, solve %.1f ms\n",
           (unsigned long long)stats.patches, (unsigned long long)stats.translucent_patches,
           (unsigned long long)stats.covered_patches, (unsigned long long)stats.nonzeros, stats.iterations,
           stats.estimated_error, stats.energy_defect, stats.form_factor_ms, stats.solve_ms);
    CHECK(stats.size == sizeof stats, "stats size %u", stats.size);
    CHECK(stats.patches > stats.translucent_patches && stats.translucent_patches > 0, "patches");
    CHECK(stats.nonzeros > 0 && stats.form_factor_bytes == 8 * stats.nonzeros, "form factors");
    CHECK(stats.patch_size_mm == 12.0 && stats.iterations >= 1 && stats.scatterings >= 1, "sweeps");
    CHECK(stats.estimated_error < 1e-4 && stats.energy_defect < 1e-2, "converged: %g, %g", stats.estimated_error,
          stats.energy_defect);
    TcBakeStats object_stats;
    object_stats.size = sizeof object_stats;
    OK(tc_object_stats(scene, ball, &object_stats));
    CHECK(object_stats.tets > 2000 && object_stats.tets < 10000, "ball tets %llu", (unsigned long long)object_stats.tets);

    /* 3. Bad input: named, and nothing changes (the results stay readable and the same). */
    uint32_t object = 12345, count = 0;
    CHECK(tc_scene_add_diffuse_mesh(scene, room_positions, 8, cube_indices, 36, (const double[3]){1.0, 0.5, 0.5},
                                    &object) == TC_INVALID_ARGUMENT &&
              says("albedo"),
          "albedo 1 refused");
    CHECK(tc_scene_add_diffuse_mesh(scene, room_positions, 8, cube_indices, 35, (const double[3]){0.5, 0.5, 0.5},
                                    &object) == TC_INVALID_MESH,
          "index count not a multiple of 3");
    CHECK(object == 12345, "out_object untouched on failure");
    OK(tc_scene_object_count(scene, &count));
    CHECK(count == 2, "no object added (%u)", count);
    CHECK(tc_object_set_albedo(scene, room, (const double[3]){0.5, NAN, 0.5}) == TC_INVALID_ARGUMENT &&
              says("albedo") && says("room"),
          "NaN albedo");
    CHECK(tc_object_set_albedo(scene, room, (const double[3]){0.5, 1.0, 0.5}) == TC_INVALID_ARGUMENT && says("[0, 1)"),
          "albedo 1");
    CHECK(tc_object_set_emission(scene, room, (const double[3]){0.0, -1.0, 0.0}) == TC_INVALID_ARGUMENT &&
              says("emission"),
          "negative emission");
    CHECK(tc_object_set_emission(scene, room, NULL) == TC_NULL_POINTER && says("emission"), "NULL emission");
    CHECK(tc_object_set_sides(scene, room, 3) == TC_INVALID_ARGUMENT && says("sides = 3"), "unknown sides");
    CHECK(tc_object_set_albedo(scene, ball, (const double[3]){0.5, 0.5, 0.5}) == TC_INVALID_ARGUMENT &&
              says("translucent") && says("object 0"),
          "albedo on the translucent ball");
    CHECK(tc_object_set_sides(scene, ball, TC_SIDES_FRONT) == TC_INVALID_ARGUMENT && says("translucent"),
          "sides on the ball");
    CHECK(tc_object_set_medium_preset(scene, room, "marble") == TC_INVALID_ARGUMENT && says("diffuse") && says("room"),
          "a medium on the room");
    TcRadiosityOptions bad = radiosity;
    bad.iteration = 7;
    options.method_options = &bad;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("method_options->iteration = 7"), "unknown iteration");
    bad = radiosity;
    bad.patch_size_mm = -1.0;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("patch_size_mm"), "negative patch size");
    bad = radiosity;
    bad.rays_per_patch = 0;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("rays_per_patch = 0"), "no rays");
    bad = radiosity;
    bad.tolerance = 0.0;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("tolerance"), "tolerance 0");
    bad = radiosity;
    bad.iteration = TC_RADIOSITY_GAUSS_SEIDEL;
    bad.bounces = 2;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("bounces") && says("JACOBI"), "bounces need Jacobi");
    bad = radiosity;
    bad.discretization = 9;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("method_options->discretization = 9"),
          "unknown discretization");
    bad = radiosity;
    bad.grading = TC_MAX_GRADING_LAYERS + 1;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("method_options->grading"), "grading out of range");
    bad = radiosity;
    bad.size = 4;
    CHECK(bake(scene, &options) == TC_INVALID_ARGUMENT && says("tc_radiosity_options_init"), "short options struct");
    options.method_options = &radiosity;
    OK(tc_object_radiance(scene, ball, again, 3 * nb));
    CHECK(memcmp(again, ball_rgb, 3 * nb * sizeof(float)) == 0, "the results of the last bake are kept");
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    check_room_is(room_rgb, nr, emission, "after refused calls");

    /* 4. Albedo 0.5: inter-reflection; one bounce is the emission alone. */
    OK(tc_object_set_albedo(scene, room, (const double[3]){0.5, 0.5, 0.5}));
    CHECK(tc_object_radiance(scene, room, room_rgb, 3 * nr) == TC_NOT_BAKED, "a change discards the results");
    CHECK(tc_scene_radiosity_stats(scene, &stats) == TC_NOT_BAKED, "and the statistics");
    OK(bake(scene, &options));
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    for (size_t v = 0; v < nr; v++)
        for (int c = 0; c < 3; c++)
            CHECK(room_rgb[3 * v + c] > 1.2 * emission[c] / PI, "albedo 0.5: vertex %zu channel %d: %g", v, c,
                  room_rgb[3 * v + c]);
    printf("albedo 0.5: room Lo = (%.5f %.5f %.5f), M/pi = (%.5f %.5f %.5f)\n", room_rgb[0], room_rgb[1], room_rgb[2],
           emission[0] / PI, emission[1] / PI, emission[2] / PI);

    /* 5. The coupled session: an edit of the albedo and a relight re-solve the baked scene. */
    float *room_before = malloc(3 * nr * sizeof(float));
    memcpy(room_before, room_rgb, 3 * nr * sizeof(float));
    CHECK(tc_object_edit_albedo(scene, ball, (const double[3]){0.5, 0.5, 0.5}) == TC_INVALID_ARGUMENT &&
              says("translucent"),
          "edit albedo of the ball");
    CHECK(tc_object_edit_albedo(scene, room, (const double[3]){0.5, 1.5, 0.5}) == TC_INVALID_ARGUMENT && says("albedo"),
          "edit albedo 1.5");
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    CHECK(memcmp(room_rgb, room_before, 3 * nr * sizeof(float)) == 0, "a refused edit changes nothing");
    OK(tc_object_edit_albedo(scene, room, (const double[3]){0.25, 0.25, 0.25}));
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    for (size_t v = 0; v < nr; v++)
        for (int c = 0; c < 3; c++)
            CHECK(room_rgb[3 * v + c] > emission[c] / PI && room_rgb[3 * v + c] < room_before[3 * v + c],
                  "albedo 0.25: vertex %zu channel %d: %g, between %g and %g", v, c, room_rgb[3 * v + c],
                  emission[c] / PI, room_before[3 * v + c]);
    printf("edit albedo 0.25: room Lo = (%.5f %.5f %.5f)\n", room_rgb[0], room_rgb[1], room_rgb[2]);
    memcpy(room_before, room_rgb, 3 * nr * sizeof(float));
    OK(tc_scene_add_point(scene, (const double[3]){0.0, 20.0, 0.0}, (const double[3]){200.0, 200.0, 200.0}));
    OK(tc_scene_relight(scene, NULL, NULL));
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    for (size_t v = 0; v < nr; v++)
        for (int c = 0; c < 3; c++)
            CHECK(room_rgb[3 * v + c] > room_before[3 * v + c], "relit: vertex %zu channel %d: %g, not above %g", v, c,
                  room_rgb[3 * v + c], room_before[3 * v + c]);
    OK(tc_scene_radiosity_stats(scene, &stats));
    CHECK(stats.iterations >= 1, "the relight solved: %u sweeps", stats.iterations);
    printf("relit by a point lamp: room Lo = (%.5f %.5f %.5f), %u sweeps\n", room_rgb[0], room_rgb[1], room_rgb[2],
           stats.iterations);
    free(room_before);
    OK(tc_scene_clear_lights(scene));
    OK(tc_object_set_albedo(scene, room, (const double[3]){0.5, 0.5, 0.5}));

    radiosity.bounces = 1;
    OK(bake(scene, &options));
    OK(tc_object_radiance(scene, room, room_rgb, 3 * nr));
    check_room_is(room_rgb, nr, emission, "one bounce");
    OK(tc_scene_radiosity_stats(scene, &stats));
    CHECK(stats.iterations <= 1, "one bounce: %u sweeps", stats.iterations);

    tc_scene_destroy(&scene);
    free(again);
    free(ball_rgb);
    free(room_rgb);
    free(ball_mesh.positions);
    free(ball_mesh.indices);
    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("all checks passed\n");
    return 0;
}
