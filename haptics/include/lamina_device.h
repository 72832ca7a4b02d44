/*
 * lamina_device.h: the C ABI of a Lamina haptic device plugin.
 *
 * A plugin is a shared library (.so) that wraps a vendor SDK (Force Dimension dhd/drd,
 * OpenHaptics HD, libnifalcon, ...) so that `lamina-haptics --device plugin:LIB.so` drives
 * the device without rebuilding Lamina. Build it against this header only, e.g.
 *
 *     cc -shared -fPIC -O2 -I haptics/include -o libmy_device.so my_device.c -lvendor
 *
 * Frame and units (CHAI3D's convention): origin at the centre of the device's workspace,
 * x toward the operator, y to the operator's right, z up (right-handed). Positions in
 * metres, forces in newtons, orientations as unit quaternions (x, y, z, w) rotating the
 * handle frame into the device frame.
 *
 * Threading: every function but lamina_device_emergency_stop is called from one thread, the
 * haptics process's device loop (1-4 kHz, SCHED_FIFO). lamina_device_read and
 * lamina_device_write_force must not block for longer than a fraction of a millisecond and
 * should not allocate. A call that has not returned after 5 ms is a fault: Lamina reports it,
 * calls lamina_device_emergency_stop from its watchdog thread, and ramps the force back in
 * from zero once calls return; if the call never returns, the process exits at the end of
 * its run (--seconds) or on SIGINT/SIGTERM. An open that has not returned by the end of the
 * run (--seconds) ends the process too.
 *
 * Safety contract: Lamina holds the limits reported in LaminaDeviceInfo to the ceilings of
 * the device's class (found from its name; docs/haptics.md lists them), clamps forces to
 * that limit and makes them finite before calling lamina_device_write_force; the plugin
 * should clamp again to the hardware's own limit. Poses beyond workspace_radius_m are faults
 * (the force fades to zero). On any error the plugin must leave the device with zero force.
 */
#ifndef LAMINA_DEVICE_H
#define LAMINA_DEVICE_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The ABI version this header describes; lamina_device_abi_version() must return it. */
#define LAMINA_DEVICE_ABI_VERSION 1u

/* Return codes of lamina_device_read and lamina_device_write_force. */
#define LAMINA_DEVICE_OK 0
#define LAMINA_DEVICE_DISCONNECTED (-1) /* the device vanished: Lamina stops and reports */
#define LAMINA_DEVICE_ERROR (-2)        /* any other failure; see lamina_device_last_error */

/* What the device is and what it can safely do (filled by lamina_device_open). */
typedef struct LaminaDeviceInfo {
    char name[64];                 /* NUL-terminated model name, e.g. "Force Dimension omega.3" */
    double max_force_n;            /* largest force norm the device may be commanded, N (> 0) */
    double max_stiffness_n_per_m;  /* largest stiffness rendered stably, N/m (> 0) */
    double max_damping_n_s_per_m;  /* largest viscous damping rendered stably, N s/m (>= 0) */
    double workspace_radius_m;     /* radius of the reachable sphere about the origin, m (> 0) */
} LaminaDeviceInfo;

/* One sample of the handle, device frame. */
typedef struct LaminaDeviceState {
    double position_m[3];          /* handle position, m */
    double orientation_xyzw[4];    /* unit quaternion (x, y, z, w); identity (0, 0, 0, 1) */
    uint32_t buttons;              /* bit i set: button i pressed */
    uint32_t reserved;             /* zero */
} LaminaDeviceState;

/* Returns LAMINA_DEVICE_ABI_VERSION. Called first; a mismatch refuses the plugin. */
uint32_t lamina_device_abi_version(void);

/* Opens the device. `args` is the text given to `lamina-haptics --device-args` (never
 * NULL, may be empty). Fills `info_out` and returns an opaque handle, or NULL on failure
 * (then lamina_device_last_error(NULL) says why). */
void *lamina_device_open(const char *args, LaminaDeviceInfo *info_out);

/* Samples the handle into `out`. Returns LAMINA_DEVICE_OK, LAMINA_DEVICE_DISCONNECTED or
 * LAMINA_DEVICE_ERROR. */
int lamina_device_read(void *device, LaminaDeviceState *out);

/* Commands `force_n` (N, device frame), held until the next call. Same return codes. */
int lamina_device_write_force(void *device, const double force_n[3]);

/* A NUL-terminated description of the last failure on `device` (or of the last failed
 * open when `device` is NULL); valid until the next call on that device. Never NULL. */
const char *lamina_device_last_error(void *device);

/* Sets zero force and releases the device. `device` is not used afterwards. */
void lamina_device_close(void *device);

/* Optional. Sets zero force at once (e.g. dhdSetForce(0, 0, 0) or disabling the amplifiers).
 * Unlike the other functions it may be called from another thread at any time, also while
 * lamina_device_read or lamina_device_write_force is in progress on `device`: Lamina's
 * watchdog calls it when such a call has blocked for more than 5 ms. A plugin without it still
 * loads; its blocked calls are reported, and the device holds its last command until its own
 * watchdog acts. */
void lamina_device_emergency_stop(void *device);

#ifdef __cplusplus
}
#endif

#endif /* LAMINA_DEVICE_H */
