/*
 * sim_device.c: a simulated haptic device implementing lamina_device.h, used by Lamina's
 * tests (and as a template for a vendor wrapper).
 *
 * The handle is a point mass (0.1 kg) on a spring to the workspace centre (50 N/m, damping
 * 2 N s/m): each lamina_device_read advances it 1 ms under the force last written, so a
 * force written moves the handle the way a hand-held stylus would move.
 *
 * Arguments (comma-separated): "disconnect_after=N" makes read return
 * LAMINA_DEVICE_DISCONNECTED after N reads; "fail_open" makes open fail;
 * "nan_after=N" reports a NaN position after N reads.
 * Misbehaviours for the safety tests (a plugin that lies):
 *   "huge_limits"        reports 1e308 N, N/m and N s/m as its limits;
 *   "huge_pose_after=N"  reports z = 1e300 m after N reads;
 *   "block_after=N"      read blocks after N reads: for "block_ms=M" ms once, else forever;
 *   "block_open"         open never returns;
 *   "press_mm=D"         the handle ignores forces and presses: z from +10 mm down 10 um per
 *                        read to -D mm, then holds;
 *   "log=PATH"           at close, writes the writes received, the largest force norm
 *                        received (N) and the emergency stops to PATH.
 * lamina_device_emergency_stop zeroes the held force and says so on stderr.
 * Compile-time variants for the ABI tests: -DLAMINA_SIM_BAD_ABI (reports ABI 2) and
 * -DLAMINA_SIM_NO_CLOSE (leaves lamina_device_close out).
 */
#include "lamina_device.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SIM_MASS 0.1
#define SIM_SPRING 50.0
#define SIM_DAMPING 2.0
#define SIM_DT 0.001

typedef struct SimDevice {
    double x[3], v[3], f[3];
    long reads, disconnect_after, nan_after, huge_pose_after, block_after, block_ms, press_mm;
    long writes, emergency_stops;
    double max_force;
    char log[256];
    char error[128];
} SimDevice;

static char open_error[128] = "no error";

uint32_t lamina_device_abi_version(void) {
#ifdef LAMINA_SIM_BAD_ABI
    return 2u;
#else
    return LAMINA_DEVICE_ABI_VERSION;
#endif
}

static long arg_value(const char *args, const char *key) {
    const char *p = strstr(args, key);
    if (!p) return -1;
    return strtol(p + strlen(key), NULL, 10);
}

void *lamina_device_open(const char *args, LaminaDeviceInfo *info_out) {
    if (strstr(args, "block_open")) {
        struct timespec ms = {0, 1000000};
        for (;;) nanosleep(&ms, NULL);
    }
    if (strstr(args, "fail_open")) {
        strcpy(open_error, "simulated device: no device on the USB bus (fail_open)");
        return NULL;
    }
    SimDevice *d = calloc(1, sizeof *d);
    if (!d) {
        strcpy(open_error, "simulated device: out of memory");
        return NULL;
    }
    d->disconnect_after = arg_value(args, "disconnect_after=");
    d->nan_after = arg_value(args, "nan_after=");
    d->huge_pose_after = arg_value(args, "huge_pose_after=");
    d->block_after = arg_value(args, "block_after=");
    d->block_ms = arg_value(args, "block_ms=");
    d->press_mm = arg_value(args, "press_mm=");
    const char *log = strstr(args, "log=");
    if (log) {
        size_t n = strcspn(log + 4, ",");
        if (n >= sizeof d->log) n = sizeof d->log - 1;
        memcpy(d->log, log + 4, n);
        d->log[n] = 0;
    }
    strcpy(d->error, "no error");
    memset(info_out, 0, sizeof *info_out);
    strcpy(info_out->name, "lamina simulated device");
    int huge = strstr(args, "huge_limits") != NULL;
    info_out->max_force_n = huge ? 1e308 : 8.0;
    info_out->max_stiffness_n_per_m = huge ? 1e308 : 2500.0;
    info_out->max_damping_n_s_per_m = huge ? 1e308 : 15.0;
    info_out->workspace_radius_m = 0.075;
    return d;
}

int lamina_device_read(void *device, LaminaDeviceState *out) {
    SimDevice *d = device;
    d->reads++;
    if (d->disconnect_after >= 0 && d->reads > d->disconnect_after) {
        strcpy(d->error, "simulated device: cable pulled (disconnect_after)");
        return LAMINA_DEVICE_DISCONNECTED;
    }
    if (d->block_after >= 0 && d->reads > d->block_after) {
        struct timespec ms = {0, 1000000};
        if (d->block_ms >= 0) {
            for (long i = 0; i < d->block_ms; i++) nanosleep(&ms, NULL);
            d->block_after = -1;
        } else {
            for (;;) nanosleep(&ms, NULL);
        }
    }
    for (int c = 0; c < 3; c++) {
        double a = (d->f[c] - SIM_SPRING * d->x[c] - SIM_DAMPING * d->v[c]) / SIM_MASS;
        d->v[c] += SIM_DT * a;
        d->x[c] += SIM_DT * d->v[c];
        out->position_m[c] = d->x[c];
    }
    if (d->press_mm >= 0) {
        double z = 0.01 - 1e-5 * (double)d->reads;
        out->position_m[0] = 0.0;
        out->position_m[1] = 0.0;
        out->position_m[2] = z > -1e-3 * (double)d->press_mm ? z : -1e-3 * (double)d->press_mm;
    }
    if (d->nan_after >= 0 && d->reads > d->nan_after) out->position_m[0] = NAN;
    if (d->huge_pose_after >= 0 && d->reads > d->huge_pose_after) out->position_m[2] = 1e300;
    out->orientation_xyzw[0] = 0.0;
    out->orientation_xyzw[1] = 0.0;
    out->orientation_xyzw[2] = 0.0;
    out->orientation_xyzw[3] = 1.0;
    out->buttons = 0;
    out->reserved = 0;
    return LAMINA_DEVICE_OK;
}

int lamina_device_write_force(void *device, const double force_n[3]) {
    SimDevice *d = device;
    if (d->disconnect_after >= 0 && d->reads > d->disconnect_after) {
        strcpy(d->error, "simulated device: cable pulled (disconnect_after)");
        return LAMINA_DEVICE_DISCONNECTED;
    }
    for (int c = 0; c < 3; c++) d->f[c] = force_n[c];
    double n = sqrt(force_n[0] * force_n[0] + force_n[1] * force_n[1] + force_n[2] * force_n[2]);
    if (n > d->max_force) d->max_force = n;
    d->writes++;
    return LAMINA_DEVICE_OK;
}

const char *lamina_device_last_error(void *device) {
    if (!device) return open_error;
    return ((SimDevice *)device)->error;
}

void lamina_device_emergency_stop(void *device) {
    SimDevice *d = device;
    for (int c = 0; c < 3; c++) d->f[c] = 0.0;
    __atomic_add_fetch(&d->emergency_stops, 1, __ATOMIC_SEQ_CST);
    fprintf(stderr, "simulated device: emergency stop, force set to zero\n");
}

#ifndef LAMINA_SIM_NO_CLOSE
void lamina_device_close(void *device) {
    SimDevice *d = device;
    if (d->log[0]) {
        FILE *f = fopen(d->log, "w");
        if (f) {
            fprintf(f, "writes %ld\nmax_force_n %.17g\nemergency_stops %ld\n", d->writes, d->max_force,
                    __atomic_load_n(&d->emergency_stops, __ATOMIC_SEQ_CST));
            fclose(f);
        }
    }
    free(device);
}
#endif
