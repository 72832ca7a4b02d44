/* The yardstick scene's step (docs/yardstick-scene.md) as a plain C programmer writes it:
 * nodes as arrays of xyz triples (x[n][3], v[n][3], f[n][3]: one cache line holds a node's
 * three components, which for this scatter loop beats nine separate arrays), springs as
 * structure of arrays (a, b, k, L0, c), in the specification's order, forces scattered to
 * both ends, then symplectic Euler.
 * No intrinsics; built by cli/build.rs with `-O3 -march=native` (and `-fopenmp` for the
 * OpenMP step), float32 throughout.
 *
 * yardstick_c_step: one thread.
 * yardstick_c_step_omp: `#pragma omp parallel for` over springs (static schedule), each
 * thread scattering into its own full-size force buffer (no atomics), then a parallel loop
 * over nodes that sums the buffers and integrates. Per-thread buffers beat `#pragma omp
 * atomic` updates here: six atomics per spring serialise on shared cache lines. */

#include <stddef.h>
#include <math.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

typedef struct {
    int nodes, springs;
    const int *a, *b;
    const float *k, *rest, *c;
    const unsigned char *fixed; /* 1: the node never moves */
    float (*x)[3], (*v)[3];
    float (*f)[3];
    float mass, gy, dt;
} yardstick_c_state;

static void spring_forces(const yardstick_c_state *s, int from, int to, float (*restrict f)[3]) {
    const int *restrict a = s->a, *restrict b = s->b;
    const float *restrict k = s->k, *restrict rest = s->rest, *restrict c = s->c;
    const float (*restrict x)[3] = s->x, (*restrict v)[3] = s->v;
    for (int i = from; i < to; i++) {
        int na = a[i], nb = b[i];
        float dx = x[nb][0] - x[na][0], dy = x[nb][1] - x[na][1], dz = x[nb][2] - x[na][2];
        float len = sqrtf(dx * dx + dy * dy + dz * dz);
        float ux = dx / len, uy = dy / len, uz = dz / len;
        float dvx = v[nb][0] - v[na][0], dvy = v[nb][1] - v[na][1], dvz = v[nb][2] - v[na][2];
        float fs = k[i] * (len - rest[i]) + c[i] * (dvx * ux + dvy * uy + dvz * uz);
        f[na][0] += fs * ux; f[na][1] += fs * uy; f[na][2] += fs * uz;
        f[nb][0] -= fs * ux; f[nb][1] -= fs * uy; f[nb][2] -= fs * uz;
    }
}

static void integrate(yardstick_c_state *s, int n, float fx, float fy, float fz) {
    if (s->fixed[n]) return;
    float *v = s->v[n], *x = s->x[n];
    v[0] += s->dt * (fx / s->mass);
    v[1] += s->dt * (fy / s->mass + s->gy);
    v[2] += s->dt * (fz / s->mass);
    x[0] += s->dt * v[0];
    x[1] += s->dt * v[1];
    x[2] += s->dt * v[2];
}

void yardstick_c_step(yardstick_c_state *s) {
    memset(s->f, 0, (size_t)s->nodes * sizeof(float[3]));
    spring_forces(s, 0, s->springs, s->f);
    for (int n = 0; n < s->nodes; n++) integrate(s, n, s->f[n][0], s->f[n][1], s->f[n][2]);
}

/* Returns 1 when built with OpenMP, 0 when not (then the step runs on one thread). */
int yardstick_c_has_openmp(void) {
#ifdef _OPENMP
    return 1;
#else
    return 0;
#endif
}

/* `buffers` holds 3 * nodes * threads floats: thread t's force triples at t * nodes. */
void yardstick_c_step_omp(yardstick_c_state *s, int threads, float *buffers) {
    size_t n = (size_t)s->nodes;
#pragma omp parallel num_threads(threads)
    {
        int t = 0, nt = 1;
#ifdef _OPENMP
        t = omp_get_thread_num();
        nt = omp_get_num_threads();
#endif
        float (*f)[3] = (float (*)[3])(buffers + (size_t)t * 3 * n);
        memset(f, 0, n * sizeof(float[3]));
        /* Static schedule: thread t takes the t-th contiguous share of the springs. */
#pragma omp for schedule(static)
        for (int i = 0; i < s->springs; i++) spring_forces(s, i, i + 1, f);
#pragma omp for schedule(static)
        for (int i = 0; i < s->nodes; i++) {
            float sx = 0.0f, sy = 0.0f, sz = 0.0f;
            for (int u = 0; u < nt; u++) {
                const float *b = buffers + ((size_t)u * n + i) * 3;
                sx += b[0];
                sy += b[1];
                sz += b[2];
            }
            integrate(s, i, sx, sy, sz);
        }
    }
}
