//! The force renderer's safety and stability, against independent expectations: the wire's
//! own linear model (`ContactFeedback::force_at`), the device's limits, a 5 ms quiet budget,
//! and the energy of a simulated handle bouncing on a rendered wall.

use lamina_bridge::wire::ContactFeedback;
use lamina_haptics::device::{DeviceInfo, within_ceilings};
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

/// A device that reports 1e308 N, N/m and N s/m (a lying plugin) pressing 8 mm into a wall
/// of 1e6 N/m, moving at 4 cm/s: every force rendered is finite and at most the ceiling of
/// the device's class (0.88 N for a PHANTOM Omni), and the press reaches it.
#[test]
fn renderer_with_huge_reported_limits_holds_an_8mm_press_to_the_class_ceiling_works() {
    let lying = DeviceInfo {
        name: "SensAble PHANTOM Omni".into(),
        max_force_n: 1e308,
        max_stiffness_n_per_m: 1e308,
        max_damping_n_s_per_m: 1e308,
        workspace_radius_m: 0.08,
    };
    let (held, clamps) = within_ceilings(&lying);
    assert_eq!(
        clamps.iter().map(|c| (c.limit, c.reported, c.ceiling)).collect::<Vec<_>>(),
        [("max force", 1e308, 0.88), ("max stiffness", 1e308, 1020.0), ("max damping", 1e308, 5.0)]
    );
    let limits = RenderLimits { onset_ns: 0, ..RenderLimits::for_device(&held, PERIOD_NS) };
    let map = DeviceMapping::y_up_model([0.0; 3]);
    let mut r = ForceRenderer::new(limits, map);
    let k_wall = 1e6;
    let mut max_f: f64 = 0.0;
    // From 2 mm above the wall down to 8 mm into it at 4 cm/s (1e-5 m per 250 us tick), then
    // held for 100 ticks; the core linearises at the handle every 4 ticks (1 kHz).
    for tick in 0..1100u64 {
        let t = tick * PERIOD_NS;
        let z = (0.002 - 1e-5 * tick as f64).max(-0.008);
        if tick.is_multiple_of(4) {
            let pen = (-z).max(0.0);
            let mut fb = ContactFeedback { in_contact: u32::from(pen > 0.0), ..Default::default() };
            fb.x_ref = map.to_model([0.0, 0.0, z]);
            fb.force = [0.0, k_wall * pen, 0.0];
            fb.stiffness[1][1] = if pen > 0.0 { -k_wall } else { 0.0 };
            r.accept_feedback(&fb, t).unwrap();
        }
        let f = r.render([0.0, 0.0, z], t).force_n;
        assert!(f.iter().all(|c| c.is_finite()), "tick {tick}: {f:?}");
        max_f = max_f.max(norm(f));
    }
    assert!(max_f <= 0.88 + 1e-12, "an 8 mm press commanded {max_f} N, above the 0.88 N ceiling");
    assert!(max_f > 0.88 - 1e-9, "the press (8 kN asked) reaches the ceiling: {max_f} N");
    assert!(r.counts.stiffness_limited > 0 && r.counts.force_clamped_ticks > 0);
}

/// A pose beyond the workspace (a sensor fault, 1e300 m) fades the force from its last value
/// to zero over `fade_ns` (1.5 ms), linearly on the renderer's clock, is reported once, and
/// the force ramps back in over `onset_ns` when the pose is back inside.
#[test]
fn renderer_pose_beyond_workspace_fades_the_force_to_zero_works() {
    let limits = RenderLimits { onset_ns: 2 * MS, ..RenderLimits::for_device(&device(), PERIOD_NS) };
    let mut r = ForceRenderer::new(limits, DeviceMapping::y_up_model([0.1, 0.05, 0.02]));
    // A constant 2 N push (no stiffness), fed every tick so the core is never quiet.
    let feed = |r: &mut ForceRenderer, t: u64| r.accept_feedback(&contact(2.0, 0.0), t).unwrap();
    feed(&mut r, 0);
    let (t_in, t_fault) = (3 * MS, 3 * MS + PERIOD_NS);
    feed(&mut r, t_in);
    assert!((norm(r.render([0.0; 3], t_in).force_n) - 2.0).abs() < 1e-9, "2 N before the fault");
    let mut events = Vec::new();
    for k in 0..=8u64 {
        let t = t_fault + k * PERIOD_NS;
        feed(&mut r, t);
        let (out, event) = r.render_with_event([0.0, 0.0, 1e300], t);
        events.extend(event);
        // Linear fade over 1.5 ms from the 2 N of the tick before.
        let want = 2.0 * (1.0 - (k * PERIOD_NS) as f64 / 1.5e6).max(0.0);
        assert!(
            (norm(out.force_n) - want).abs() < 1e-9,
            "{} ms into the fault: {:?}, want {want} N",
            k as f64 / 4.0,
            out.force_n
        );
    }
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(
        matches!(events[0], SafetyEventKind::OutsideWorkspace { distance_m, radius_m } if distance_m == 1e300 && radius_m == 0.08)
    );
    assert_eq!((r.counts.workspace_faults, r.counts.workspace_fault_ticks), (1, 9));
    // Just beyond the radius is a fault too; just inside is not.
    let t_back = t_fault + 9 * PERIOD_NS;
    feed(&mut r, t_back);
    let (out, event) = r.render_with_event([0.0, 0.0, 0.08], t_back);
    assert_eq!(event, Some(SafetyEventKind::WorkspaceBack));
    assert_eq!(out.force_n, [0.0; 3], "the force ramps in from zero");
    let t_half = t_back + MS;
    feed(&mut r, t_half);
    let f = norm(r.render([0.0, 0.0, 0.08], t_half).force_n);
    assert!((f - 1.0).abs() < 1e-9, "half way through the 2 ms onset ramp: {f} N");
    let t_out = t_half + PERIOD_NS;
    feed(&mut r, t_out);
    let (_, event) = r.render_with_event([0.0, 0.0, 0.08 + 1e-9], t_out);
    assert!(matches!(event, Some(SafetyEventKind::OutsideWorkspace { .. })));
    assert_eq!(r.counts.workspace_faults, 2);
}

/// A device call that took too long restarts the force from zero (onset ramp), counted.
#[test]
fn renderer_device_call_stall_restarts_the_force_from_zero_works() {
    let limits = RenderLimits { onset_ns: 4 * MS, ..RenderLimits::for_device(&device(), PERIOD_NS) };
    let mut r = ForceRenderer::new(limits, DeviceMapping::y_up_model([0.1, 0.05, 0.02]));
    r.accept_feedback(&contact(2.0, 0.0), 0).unwrap();
    r.accept_feedback(&contact(2.0, 0.0), 5 * MS).unwrap();
    assert!((norm(r.render([0.0; 3], 5 * MS).force_n) - 2.0).abs() < 1e-9);
    r.device_call_stalled(5 * MS);
    assert_eq!(r.counts.device_call_stalls, 1);
    assert_eq!(r.render([0.0; 3], 5 * MS).force_n, [0.0; 3], "zero right after the stall");
    r.accept_feedback(&contact(2.0, 0.0), 6 * MS).unwrap();
    let f = norm(r.render([0.0; 3], 6 * MS).force_n);
    assert!((f - 0.5).abs() < 1e-9, "a quarter of the 4 ms ramp: {f} N");
}
