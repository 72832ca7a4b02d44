//! Passivity of the rendering, against closed forms: a simulated device of mass `m` and
//! physical damping `b` on a virtual wall of stiffness `K` and virtual damping `B` sampled at
//! the loop period `T` (zero-order hold). A sampled wall acts on a slow oscillation as a
//! negative damper of `K T / 2` (and its backward-difference damper as `B cos ωT`), so the
//! oscillation's envelope goes as `exp(σ t)`, `σ = −(b + B cos ωT − K T / 2) / 2m`; the wall
//! is passive when `b > K T / 2 + |B|` (Colgate and Schenkel 1997). The passivity observer and
//! controller (Hannaford and Ryu 2002) keep even a wall far beyond that bound passive.
//!
//! Figures: `cargo test -p lamina-haptics --test passivity -- --nocapture`.

use lamina_haptics::PassivityObserver;
use lamina_haptics::device::{DeviceDynamics, Hand, HapticDevice, SimulatedDevice};

/// Device-loop period, s (4 kHz).
const T: f64 = 250e-6;
/// Device-loop period, ns.
const T_NS: u64 = 250_000;
/// Wall stiffness, N/m: an omega.3's rendering stiffness (14.5 N/mm).
const K: f64 = 14_500.0;
/// Moving mass, kg.
const M: f64 = 0.2;
/// Force limit, N.
const MAX_FORCE: f64 = 12.0;
/// The passivity controller's damping ceiling, N s/m (an omega-class device's).
const MAX_DAMPING: f64 = 30.0;

/// What a run of a device on a wall showed.
#[derive(Debug, Default)]
struct Run {
    /// Oscillation energy `½ m v² + ½ K (z − z*)²` per tick, J.
    energy: Vec<f64>,
    /// Whether the handle was in the wall, per tick.
    contact: Vec<bool>,
    /// The observer's lowest energy, J.
    min_observed_j: f64,
    /// Energy the controller dissipated, J.
    dissipated_j: f64,
    /// Ticks the controller acted.
    controller_ticks: u64,
}

/// A 1-DOF wall along z at `z = 0` (in contact below; bilateral when `unilateral` is false)
/// rendered as `F = −K z − B (z − z_prev) / T` on a device of damping `b`, pushed down by
/// `push_n`, from `z0`, `v0`, for `seconds`; with the passivity controller when `controller`.
fn run_wall(b: f64, bv: f64, unilateral: bool, push_n: f64, z0: f64, v0: f64, seconds: f64, controller: bool) -> Run {
    let hand = Hand { push_n: [0.0, 0.0, -push_n], ..Hand::default() };
    let dynamics = DeviceDynamics { mass_kg: M, damping_n_s_per_m: b };
    let mut device = SimulatedDevice::new(SimulatedDevice::default_info(), dynamics, hand)
        .starting_at([0.0, 0.0, z0], [0.0, 0.0, v0])
        .manual();
    let mut po = PassivityObserver::new(MAX_DAMPING, controller);
    let z_eq = -push_n / K;
    let mut run = Run::default();
    let mut z_prev = z0;
    for n in 0..(seconds / T).round() as u64 {
        let z = device.read().unwrap().position_m[2];
        let inside = !unilateral || z < 0.0;
        let f = if inside { -K * z - bv * (z - z_prev) / T } else { 0.0 };
        let f = if unilateral { f.max(0.0) } else { f };
        z_prev = z;
        let out = po.tick(Some([0.0, 0.0, z]), n * T_NS, [0.0, 0.0, f], MAX_FORCE);
        device.write_force(out).unwrap();
        let v = device.velocity()[2];
        run.energy.push(0.5 * M * v * v + 0.5 * K * (z - z_eq) * (z - z_eq));
        run.contact.push(inside);
        device.advance(T);
    }
    let fig = po.figures();
    run.min_observed_j = fig.min_observed_energy_j;
    run.dissipated_j = fig.dissipated_j;
    run.controller_ticks = fig.controller_ticks;
    run
}

/// Mean of `v[from..to]`.
fn mean(v: &[f64], from: usize, to: usize) -> f64 {
    v[from..to].iter().sum::<f64>() / (to - from) as f64
}

/// The envelope's rate `σ` (1/s) between the first and the last 0.1 s of a run: the
/// oscillation energy goes as `exp(2 σ t)`.
fn envelope_rate(run: &Run) -> f64 {
    let w = (0.1 / T) as usize;
    let n = run.energy.len();
    let (first, last) = (mean(&run.energy, 0, w), mean(&run.energy, n - w, n));
    (last / first).ln() / (2.0 * (n - w) as f64 * T)
}

/// The closed form of the envelope's rate, 1/s.
fn sigma(b: f64, bv: f64) -> f64 {
    let omega = (K / M).sqrt();
    -(b + bv * (omega * T).cos() - K * T / 2.0) / (2.0 * M)
}

#[test]
fn sampled_wall_oscillation_grows_or_decays_at_the_colgate_rate_works() {
    let colgate = K * T / 2.0; // 1.8125 N s/m
    println!("K = {K} N/m, T = {T} s, m = {M} kg: K T / 2 = {colgate} N s/m");
    println!("| b, N s/m | B, N s/m | b > KT/2 + |B| | σ closed form, 1/s | σ measured, 1/s |");
    let cases = [
        (1.25 * colgate, 0.0),
        (1.25 * (colgate + 0.4), 0.4),
        (1.25 * (colgate + 0.4), -0.4),
        (0.2 * colgate, 0.0),
        (0.5 * colgate, 0.0),
    ];
    for (b, bv) in cases {
        // A linear spring about z = 0 (no hand), set ringing at 1 cm/s: 37 µm. A growing
        // one for 0.5 s, before its force reaches the 12 N limit.
        let seconds = if sigma(b, bv) > 0.0 { 0.5 } else { 2.0 };
        let run = run_wall(b, bv, false, 0.0, 0.0, 0.01, seconds, false);
        let (want, got) = (sigma(b, bv), envelope_rate(&run));
        let passive = b > colgate + bv.abs();
        println!("| {b:.4} | {bv:+.2} | {passive} | {want:+.4} | {got:+.4} |");
        assert!((got - want).abs() <= 0.02 * want.abs(), "b {b}, B {bv}: σ {got} 1/s, closed form {want} 1/s");
        assert_eq!(passive, want < 0.0, "b {b}, B {bv}: a passive wall decays, a wall below K T / 2 grows");
    }
}

/// Ticks out of the wall in `run` from tick `from` on.
fn ticks_out(run: &Run, from: usize) -> usize {
    run.contact[from..].iter().filter(|c| !**c).count()
}

/// The hand pushes the handle (at rest on the wall's surface) down with 2 N: it rings about
/// `z* = −F/K` (−0.14 mm) from its first touch. Above the Colgate bound the ringing decays and
/// the handle stays in the wall; at a fifth of `K T / 2` it grows until the handle leaves the
/// wall every cycle and bounces on it for good (a limit cycle, the buzz of a stiff wall); the
/// passivity controller on the same device keeps it in the wall, ringing down.
#[test]
fn pressed_wall_buzzes_below_the_colgate_bound_unless_the_passivity_controller_acts_works() {
    let colgate = K * T / 2.0;
    let (push, seconds) = (2.0, 3.0);
    let settle = (0.5 / T) as usize;
    let last_second = ((seconds - 1.0) / T) as usize;
    println!(
        "| case | b, N s/m | B, N s/m | ticks out of the wall after 0.5 s | oscillation energy, last s / first 0.1 s | lowest observed energy, J | dissipated by the controller, J | controller ticks |"
    );
    let report = |name: &str, b: f64, bv: f64, r: &Run| {
        let w = (0.1 / T) as usize;
        let n = r.energy.len();
        let growth = mean(&r.energy, last_second, n) / mean(&r.energy, 0, w);
        println!(
            "| {name} | {b:.3} | {bv:+.2} | {} | {growth:.3e} | {:.3e} | {:.3e} | {} |",
            ticks_out(r, settle),
            r.min_observed_j,
            r.dissipated_j,
            r.controller_ticks
        );
        growth
    };
    // Passive: b above K T / 2 + |B|.
    let bv = 0.25 * colgate;
    let b = 1.25 * (colgate + bv);
    let passive = run_wall(b, bv, true, push, 0.0, 0.0, seconds, false);
    let growth = report("passive, no controller", b, bv, &passive);
    assert_eq!(ticks_out(&passive, settle), 0, "a passive wall holds the pressed handle");
    assert!(growth < 1e-3, "and its ringing dies out: energy ratio {growth:.3e}");
    // Well below K T / 2, no controller: a limit cycle.
    let b = 0.2 * colgate;
    let buzz = run_wall(b, 0.0, true, push, 0.0, 0.0, seconds, false);
    let growth = report("b = 0.2 KT/2, no controller", b, 0.0, &buzz);
    assert!(
        ticks_out(&buzz, last_second) > 100,
        "the handle bounces on the wall in the last second: {} ticks out",
        ticks_out(&buzz, last_second)
    );
    assert!(growth > 1.5, "the oscillation grew: energy ratio {growth:.3e}");
    // The same device with the passivity controller.
    let held = run_wall(b, 0.0, true, push, 0.0, 0.0, seconds, true);
    let growth = report("b = 0.2 KT/2, controller", b, 0.0, &held);
    assert_eq!(ticks_out(&held, settle), 0, "the controller keeps the handle in the wall");
    assert!(growth < 0.5, "its ringing decays: energy ratio {growth:.3e}");
    assert!(held.controller_ticks > 0 && held.dissipated_j > 0.0, "the controller acted");
    // What the sampled wall creates over one cycle of the first ringing (speed 2 N / √(K m),
    // 37 mm/s): its negative damping K T / 2 times ∫v² dt over 2π/ω.
    let (v0, omega) = (push / (K * M).sqrt(), (K / M).sqrt());
    let cycle = colgate * v0 * v0 / 2.0 * 2.0 * core::f64::consts::PI / omega;
    assert!(
        held.min_observed_j >= -cycle,
        "observed energy {:.3e} J, below one cycle's {:.3e} J",
        held.min_observed_j,
        -cycle
    );
    assert!(
        buzz.min_observed_j < -100.0 * cycle,
        "without the controller the wall gave energy: {:.3e} J",
        buzz.min_observed_j
    );
}
