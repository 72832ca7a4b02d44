/*
 * lamina_press: a C client of a running `lamina run` through lamina-client's C ABI.
 *
 * Reads the topology, takes --frames node frames in order (checking that the sequence rises
 * and every frame carries every node), then presses the scene's sphere into the top of the
 * skin at three depths and checks that the skin pushes back harder the deeper it goes.
 * Exits 0 when every check holds, 1 otherwise, 2 on a bad argument.
 *
 *   cargo build --release -p lamina-client
 *   gcc -std=c11 -O2 -I client/include examples/c/lamina_press.c \
 *       -L target/release -llamina_client -Wl,-rpath,"$PWD/target/release" -o lamina_press
 *   ./target/release/lamina run --prefix demo &
 *   ./lamina_press --prefix demo
 */
#define _POSIX_C_SOURCE 200809L
#include <lamina.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int fail(const char *what, LaminaStatus status) {
    fprintf(stderr, "lamina_press: %s: %s: %s\n", what, lamina_status_name(status), lamina_last_error_message());
    return 1;
}

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void sleep_ms(long ms) {
    struct timespec t = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&t, NULL);
}

/* Holds the sphere at `centre` for `seconds`, commanding every 2 ms; the mean upward force
 * (N) of the feedback in the second half, and whether all of it was in contact. */
static LaminaStatus hold(LaminaClient c, const double centre[3], double radius, double seconds, double *force_up,
                         int *in_contact) {
    double start = now_s(), sum = 0.0;
    uint64_t last = UINT64_MAX;
    int kept = 0, contact = 1;
    while (now_s() - start < seconds) {
        LaminaStatus s = lamina_send_sphere(c, centre[0], centre[1], centre[2], radius);
        if (s != LAMINA_STATUS_OK) return s;
        LaminaFeedback fb;
        s = lamina_latest_feedback(c, 1000, &fb);
        if (s != LAMINA_STATUS_OK) return s;
        if (now_s() - start >= seconds / 2 && fb.sequence != last) {
            sum += fb.force[1];
            contact &= fb.in_contact == 1;
            kept++;
        }
        last = fb.sequence;
        sleep_ms(2);
    }
    *force_up = kept ? sum / kept : 0.0;
    *in_contact = kept > 0 && contact;
    return LAMINA_STATUS_OK;
}

int main(int argc, char **argv) {
    const char *prefix = "lamina";
    long frames = 1000;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--prefix") == 0 && i + 1 < argc) {
            prefix = argv[++i];
        } else if (strcmp(argv[i], "--frames") == 0 && i + 1 < argc) {
            char *end;
            frames = strtol(argv[++i], &end, 10);
            if (*end != '\0' || frames < 2 || frames > 1000000) {
                fprintf(stderr, "lamina_press: --frames %s: give a whole number from 2 to 1000000\n", argv[i]);
                return 2;
            }
        } else {
            fprintf(stderr, "usage: lamina_press [--prefix P] [--frames N]\n");
            return 2;
        }
    }
    if (lamina_abi_version() != LAMINA_ABI_VERSION) {
        fprintf(stderr, "lamina_press: library ABI %u, header %u\n", lamina_abi_version(), LAMINA_ABI_VERSION);
        return 1;
    }

    LaminaClient c = 0;
    LaminaStatus s = lamina_open(prefix, 60000, &c);
    if (s != LAMINA_STATUS_OK) return fail("open", s);
    LaminaTopologyInfo topo;
    if ((s = lamina_topology_info(c, &topo)) != LAMINA_STATUS_OK) return fail("topology", s);
    printf("topology of '%s': %u nodes, %u triangles, %u springs, %u layers, %u surfaces, tool radius %.1f mm\n",
           topo.model_name, topo.node_count, topo.triangle_count, topo.spring_count, topo.layer_count,
           topo.surface_count, topo.tool.radius_m * 1e3);
    for (uint32_t i = 0; i < topo.surface_count; i++) {
        LaminaSurfaceInfo surface;
        if ((s = lamina_surface_info(c, i, &surface)) != LAMINA_STATUS_OK) return fail("surface", s);
        printf("  surface %s: grid %u x %u\n", surface.name, surface.grid_cols, surface.grid_rows);
    }

    size_t n = topo.node_count;
    float *x = malloc(3 * n * sizeof *x);
    if (x == NULL) return 1;
    LaminaFrameInfo f;
    if ((s = lamina_next_frame(c, 10000, x, n, &f)) != LAMINA_STATUS_OK) return fail("first frame", s);
    uint64_t first = f.sequence, last = f.sequence, gaps = 0;
    for (long k = 1; k < frames; k++) {
        if ((s = lamina_next_frame(c, 10000, x, n, &f)) != LAMINA_STATUS_OK) return fail("frame", s);
        if (f.sequence <= last || f.node_count != n) {
            fprintf(stderr, "lamina_press: frame sequence %llu after %llu, %u nodes of %zu\n",
                    (unsigned long long)f.sequence, (unsigned long long)last, f.node_count, n);
            return 1;
        }
        gaps += f.sequence - last - 1;
        last = f.sequence;
    }
    printf("%ld frames, sequence %llu..%llu, %llu lost, %zu nodes each\n", frames, (unsigned long long)first,
           (unsigned long long)last, (unsigned long long)gaps, n);
    if (gaps * 50 > (uint64_t)frames) {
        fprintf(stderr, "lamina_press: %llu of %ld frames lost (more than 2 %%)\n", (unsigned long long)gaps, frames);
        return 1;
    }

    /* The top of the skin nearest the middle of the model in x and z (the models are y up). */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], x[3 * i + a]);
            hi[a] = fmax(hi[a], x[3 * i + a]);
        }
    size_t touch = 0;
    double best = INFINITY;
    for (size_t i = 0; i < n; i++) {
        double dx = x[3 * i] - (lo[0] + hi[0]) / 2, dz = x[3 * i + 2] - (lo[2] + hi[2]) / 2;
        if (x[3 * i + 1] >= hi[1] - 1e-3 && dx * dx + dz * dz < best) {
            best = dx * dx + dz * dz;
            touch = i;
        }
    }
    double r = topo.tool.radius_m, top[3] = {x[3 * touch], x[3 * touch + 1], x[3 * touch + 2]};
    printf("pressing node %zu at (%.4f, %.4f, %.4f) m with a %.1f mm sphere\n", touch, top[0], top[1], top[2], r * 1e3);
    double previous = 0.0;
    const double depths_mm[] = {2.0, 4.0, 6.0};
    for (int k = 0; k < 3; k++) {
        double centre[3] = {top[0], top[1] + r - depths_mm[k] * 1e-3, top[2]}, up;
        int contact;
        if ((s = hold(c, centre, r, 0.5, &up, &contact)) != LAMINA_STATUS_OK) return fail("press", s);
        printf("depth %.1f mm: force up %.4f N, in contact %s\n", depths_mm[k], up, contact ? "yes" : "no");
        if (!contact || up <= previous) {
            fprintf(stderr, "lamina_press: the force does not rise with depth\n");
            return 1;
        }
        previous = up;
    }
    double clear[3] = {top[0], top[1] + r + 0.02, top[2]}, up;
    int contact;
    hold(c, clear, r, 0.1, &up, &contact);
    free(x);
    if ((s = lamina_close(c)) != LAMINA_STATUS_OK) return fail("close", s);
    printf("ok\n");
    return 0;
}
