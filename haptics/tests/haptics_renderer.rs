//! The force renderer's safety and stability, against independent expectations: the wire's
//! own linear model (`ContactFeedback::force_at`), the device's limits, a 5 ms quiet budget,
//! and the energy of a simulated handle bouncing on a rendered wall.

use lamina_bridge::wire::ContactFeedback;
use lamina_haptics::device::DeviceInfo;
use lamina_haptics::{DeviceMapping, ForceRenderer, RenderLimits, SafetyEventKind};

const MS: u64 = 1_000_000;
/// Device-loop period of these tests (4 kHz), ns.
const PERIOD_NS: u64 = 250_000;

fn device() -> DeviceInfo {
    DeviceInfo {
        name: "test".into(),
        max_force_n: 8.0,
        max_stiffness_n_per_m: 2000.0,
        max_damping_n_s_per_m: 15.0,
        workspace_radius_m: 0.08,
    }
}

fn renderer(onset_ns: u64) -> ForceRenderer {
    let limits = RenderLimits { onset_ns, ..RenderLimits::for_device(&device(), PERIOD_NS) };
    ForceRenderer::new(limits, DeviceMapping::y_up_model([0.1, 0.05, 0.02]))
}

/// As [`renderer`] without coupling damping, to read the contact model alone.
fn renderer_undamped() -> ForceRenderer {
    let limits = RenderLimits { onset_ns: 0, damping_n_s_per_m: 0.0, ..RenderLimits::for_device(&device(), PERIOD_NS) };
    ForceRenderer::new(limits, DeviceMapping::y_up_model([0.1, 0.05, 0.02]))
}

/// A contact pushing the tool up (model +y) with stiffness `k` along y, linearised at the
/// device origin.
fn contact(force_y: f64, k: f64) -> ContactFeedback {
    let mut fb = ContactFeedback { in_contact: 1, x_ref: [0.1, 0.05, 0.02], ..Default::default() };
    fb.force = [0.0, force_y, 0.0];
    fb.stiffness[1][1] = -k;
    fb
}

fn norm(f: [f64; 3]) -> f64 {
    f.iter().map(|c| c * c).sum::<f64>().sqrt()
}

#[test]
fn renderer_matches_wire_linear_model_between_ticks_works() {
    let mut r = renderer_undamped();
    let mut fb = contact(1.0, 500.0);
    fb.stiffness[0][1] = -20.0;
    fb.stiffness[1][0] = -20.0;
    r.accept_feedback(&fb, 0).unwrap();
    let map = DeviceMapping::y_up_model([0.1, 0.05, 0.02]);
    // The handle still (no damping), at a few positions around the linearisation point.
    for (i, x_dev) in [[0.0, 0.0, 0.0], [0.0, 0.0, -0.001], [0.0005, 0.001, -0.0015]].into_iter().enumerate() {
        let mut r = r.clone();
        let got = r.render(x_dev, (i as u64 + 1) * PERIOD_NS).force_n;
        let want = map.force_to_device(fb.force_at(map.to_model(x_dev)));
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() < 1e-12, "at {x_dev:?}: got {got:?}, want {want:?}");
        }
    }
}

#[test]
fn renderer_force_is_clamped_to_device_limit_works() {
    let mut r = renderer(0);
    r.accept_feedback(&contact(100.0, 500.0), 0).unwrap();
    let (out, event) = r.render_with_event([0.0; 3], MS / 2);
    assert!(out.clamped);
    assert!((norm(out.force_n) - 8.0).abs() < 1e-12, "clamped to the 8 N limit: {:?}", out.force_n);
    assert!(out.force_n[2] > 0.0, "direction kept (up)");
    assert!(matches!(event, Some(SafetyEventKind::ForceClamped { limit_n, .. }) if limit_n == 8.0));
    // Still clamped on the next tick, but the episode is logged once.
    let (out, event) = r.render_with_event([0.0; 3], MS / 2 + PERIOD_NS);
    assert!(out.clamped && event.is_none());
    assert_eq!(r.counts.force_clamped_ticks, 2);
}

#[test]
fn renderer_non_finite_feedback_gives_zero_force_and_event_works() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut r = renderer(0);
        let mut fb = contact(2.0, 100.0);
        fb.stiffness[2][0] = bad;
        assert_eq!(r.accept_feedback(&fb, 0), Err(SafetyEventKind::NonFiniteFeedback));
        let out = r.render([0.0; 3], PERIOD_NS);
        assert_eq!(out.force_n, [0.0; 3], "no model yet: zero force");
        assert_eq!(r.counts.feedback_non_finite, 1);
        // A good model, then a bad one: the good one keeps ageing out, never the bad one.
        r.accept_feedback(&contact(2.0, 100.0), MS).unwrap();
        let mut fb = contact(2.0, 100.0);
        fb.force[1] = bad;
        assert!(r.accept_feedback(&fb, MS + PERIOD_NS).is_err());
        let f = r.render([0.0; 3], MS + 2 * PERIOD_NS).force_n;
        assert!(f.iter().all(|c| c.is_finite()) && (f[2] - 2.0).abs() < 1e-9);
        assert_eq!(r.render([0.0; 3], MS + 5 * MS).force_n, [0.0; 3]);
    }
}

#[test]
fn renderer_non_finite_pose_gives_zero_force_and_event_works() {
    let mut r = renderer(0);
    r.accept_feedback(&contact(2.0, 100.0), 0).unwrap();
    let (out, event) = r.render_with_event([f64::NAN, 0.0, 0.0], PERIOD_NS);
    assert_eq!(out.force_n, [0.0; 3]);
    assert_eq!(event, Some(SafetyEventKind::NonFiniteDevicePose));
}

#[test]
fn renderer_quiet_core_zero_force_within_5_ms_works() {
    let mut r = renderer(0);
    r.accept_feedback(&contact(3.0, 0.0), 0).unwrap();
    let mut previous = f64::INFINITY;
    let mut quiet_event_at = None;
    // Every device tick for 8 ms after the last feedback.
    for tick in 1..=32u64 {
        let t = tick * PERIOD_NS;
        let (out, event) = r.render_with_event([0.0; 3], t);
        let f = norm(out.force_n);
        assert!(f <= previous + 1e-12, "the force never grows while the core is quiet");
        previous = f;
        if t <= 3 * MS {
            assert!((f - 3.0).abs() < 1e-9, "fresh for 3 ms: {f} N at {t} ns");
        }
        if t >= 5 * MS {
            assert_eq!(f, 0.0, "zero by 5 ms after the last feedback: {f} N at {t} ns");
        }
        if let Some(SafetyEventKind::CoreQuiet { .. }) = event {
            quiet_event_at.get_or_insert(t);
        }
    }
    let at = quiet_event_at.expect("the quiet core is reported");
    assert!(at <= 5 * MS);
    assert_eq!(r.counts.quiet_episodes, 1);
    // The core comes back: the force ramps in again and the return is reported.
    let mut r2 = r.clone();
    r2.accept_feedback(&contact(3.0, 0.0), 10 * MS).unwrap();
    let (out, event) = r2.render_with_event([0.0; 3], 10 * MS + PERIOD_NS);
    assert_eq!(event, Some(SafetyEventKind::CoreBack));
    assert!((norm(out.force_n) - 3.0).abs() < 1e-9);
}

#[test]
fn renderer_onset_ramps_force_in_works() {
    let mut r = renderer(20 * MS);
    let t0 = 0;
    let mut fed = 0;
    for k in 0..=20u64 {
        let t = t0 + k * MS;
        // The core feeds every millisecond.
        r.accept_feedback(&contact(4.0, 0.0), t).unwrap();
        fed += 1;
        let f = norm(r.render([0.0; 3], t).force_n);
        let want = 4.0 * (k as f64 / 20.0);
        assert!((f - want).abs() < 1e-9, "tick {k}: {f} N, want {want} N");
    }
    assert_eq!(r.counts.feedback_accepted, fed);
}

#[test]
fn renderer_contact_is_unilateral_works() {
    let mut r = renderer_undamped();
    // 1 N up with 1000 N/m: the linear model crosses zero 1 mm above the reference.
    r.accept_feedback(&contact(1.0, 1000.0), 0).unwrap();
    for (k, z) in [0.0005, 0.001, 0.002, 0.01].into_iter().enumerate() {
        let f = r.render([0.0, 0.0, z], (k as u64 + 1) * PERIOD_NS).force_n;
        assert!(f[2] >= 0.0, "a contact never pulls the tool into the tissue: {f:?} at {z} m");
        if z >= 0.001 {
            assert_eq!(f, [0.0; 3]);
        }
    }
}

#[test]
fn renderer_stiffness_is_limited_to_device_works() {
    let mut r = renderer_undamped();
    r.accept_feedback(&contact(5.0, 1e6), 0).unwrap();
    assert_eq!(r.counts.stiffness_limited, 1);
    // Finite-difference slope along z (up) in device coordinates.
    let mut at = |z: f64, t: u64| r.render([0.0, 0.0, z], t).force_n[2];
    let (f0, f1) = (at(0.0, MS / 4), at(0.0005, MS / 2));
    let slope = (f0 - f1) / 0.0005;
    assert!((slope - 2000.0).abs() < 1e-6, "rendered stiffness {slope} N/m, device limit 2000 N/m");
}

/// A 1-DOF handle (mass on the operator's soft grip) bouncing on a wall the core updates at
/// 1 kHz, with every 10th core tick 3 ms late; the device renders at 4 kHz. The wall is stiff
/// (the device's limit). A stable renderer never puts energy into the handle: its total
/// energy (kinetic + grip spring + wall) never exceeds the initial one.
#[test]
fn renderer_wall_with_late_core_ticks_is_passive_works() {
    let mut r = renderer(0);
    let k_wall = 2000.0; // N/m, the device limit
    let (m, dt) = (0.08, PERIOD_NS as f64 * 1e-9); // kg, s
    let map = DeviceMapping::y_up_model([0.1, 0.05, 0.02]);
    let (mut z, mut v) = (0.004, -0.3); // m, m/s: approaching the wall at z = 0 from above
    let wall_energy = |z: f64| if z < 0.0 { 0.5 * k_wall * z * z } else { 0.0 };
    let e0 = 0.5 * m * v * v + wall_energy(z);
    let mut max_e: f64 = e0;
    let mut next_core_ns = 0u64;
    let mut core_tick = 0u64;
    let mut touched = false;
    for tick in 0..40_000u64 {
        let t = tick * PERIOD_NS;
        if t >= next_core_ns {
            // The core linearises the wall at the handle's current position.
            let pen = (-z).max(0.0);
            let mut fb = ContactFeedback { in_contact: u32::from(pen > 0.0), ..Default::default() };
            fb.x_ref = map.to_model([0.0, 0.0, z]);
            if pen > 0.0 {
                fb.force = [0.0, k_wall * pen, 0.0];
                fb.stiffness[1][1] = -k_wall;
                touched = true;
            }
            r.accept_feedback(&fb, t).unwrap();
            core_tick += 1;
            next_core_ns = t + if core_tick.is_multiple_of(10) { 3 * MS } else { MS };
        }
        let f = r.render([0.0, 0.0, z], t).force_n[2];
        // Semi-implicit Euler of the handle under the rendered force.
        v += dt * f / m;
        z += dt * v;
        max_e = max_e.max(0.5 * m * v * v + wall_energy(z));
    }
    assert!(touched, "the handle reached the wall");
    assert!(max_e <= e0 * 1.02, "energy grew from {e0:.6} J to {max_e:.6} J: the rendering is not passive");
    assert!(z > -0.01, "the handle did not fall through the wall: z = {z} m");
}
