//! Passivity of the rendering, against closed forms: a simulated device of mass `m` and
//! physical damping `b` on a virtual wall of stiffness `K` and virtual damping `B` sampled at
//! the loop period `T` (zero-order hold). A sampled wall acts on a slow oscillation as a
//! negative damper of `K T / 2` (and its backward-difference damper as `B cos ωT`), so the
//! oscillation's envelope goes as `exp(σ t)`, `σ = −(b + B cos ωT − K T / 2) / 2m`; the wall
//! is passive when `b > K T / 2 + |B|` (Colgate and Schenkel 1997). The passivity observer and
//! controller (Hannaford and Ryu 2002) keep even a wall far beyond that bound passive.
//!
//! Figures: `cargo test -p lamina-haptics --test passivity -- --nocapture`.

mod common;

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
/// `push_n`, from the wall's surface at `v0`, for `seconds`; with the passivity controller when `controller`.
fn run_wall(b: f64, bv: f64, unilateral: bool, push_n: f64, v0: f64, seconds: f64, controller: bool) -> Run {
    let z0 = 0.0;
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
        let run = run_wall(b, bv, false, 0.0, 0.01, seconds, false);
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
    let passive = run_wall(b, bv, true, push, 0.0, seconds, false);
    let growth = report("passive, no controller", b, bv, &passive);
    assert_eq!(ticks_out(&passive, settle), 0, "a passive wall holds the pressed handle");
    assert!(growth < 1e-3, "and its ringing dies out: energy ratio {growth:.3e}");
    // Well below K T / 2, no controller: a limit cycle.
    let b = 0.2 * colgate;
    let buzz = run_wall(b, 0.0, true, push, 0.0, seconds, false);
    let growth = report("b = 0.2 KT/2, no controller", b, 0.0, &buzz);
    assert!(
        ticks_out(&buzz, last_second) > 100,
        "the handle bounces on the wall in the last second: {} ticks out",
        ticks_out(&buzz, last_second)
    );
    assert!(growth > 1.5, "the oscillation grew: energy ratio {growth:.3e}");
    // The same device with the passivity controller.
    let held = run_wall(b, 0.0, true, push, 0.0, seconds, true);
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

/// The core's stand-in: a flat tissue at model y = 0 whose contact stiffness is
/// `STIFF_TISSUE` (the living-limb scene's 30 kN/m), answering at 1 kHz, linearised at the
/// pose it received one core tick before (the core steps on the newest command, and its
/// feedback reaches the device a tick later).
const STIFF_TISSUE: f64 = 30_000.0;

/// How the stand-in core's tissue answers a press.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Tissue {
    /// An elastic wall of `STIFF_TISSUE`: its force is the contact stiffness times the depth
    /// (the worst case: nothing gives way).
    Wall,
    /// The living limb's response: 7.5 N at 8 mm, Hertz-like (`F ∝ d^1.5`), with the contact
    /// stiffness `STIFF_TISSUE` of its penalty contact as the local model's stiffness.
    Limb,
}

impl Tissue {
    /// Force at `depth`, N.
    fn force(self, depth: f64) -> f64 {
        match self {
            Tissue::Wall => STIFF_TISSUE * depth,
            Tissue::Limb => 7.5 * (depth / 0.008).powf(1.5),
        }
    }
}

/// What a press through the renderer showed.
#[derive(Debug)]
struct Press {
    figures: lamina_haptics::PassivityFigures,
    /// Largest speed of the handle over the hold, m/s.
    hold_speed_max: f64,
    /// Ticks out of contact over the hold.
    hold_ticks_out: usize,
    /// Largest force commanded, N.
    max_force: f64,
    /// Stiffness the renderer was limited to, N/m.
    rendered_stiffness: f64,
}

/// Presses along `config/trajectories/demo_press_pull.csv`'s first 3.6 s (from 1 cm above
/// the tissue to 12 mm into it, a 0.8 s hold, back out) on an omega-class device, through the
/// renderer and the passivity observer (controller when `controller`): the handle follows the
/// trajectory exactly (a position source) when `hand` is `None`, else it is a simulated device
/// of `DeviceDynamics` held by a grip following the trajectory.
fn press(tissue: Tissue, hand: Option<(DeviceDynamics, f64, f64)>, controller: bool) -> Press {
    use lamina_bridge::wire::ContactFeedback;
    use lamina_haptics::device::{DeviceInfo, Trajectory, within_ceilings};
    use lamina_haptics::{DeviceMapping, ForceRenderer, RenderLimits};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/trajectories/demo_press_pull.csv");
    let trajectory = Trajectory::load(&path).unwrap();
    let info = DeviceInfo {
        name: "Force Dimension omega.3".into(),
        max_force_n: 1e3,
        max_stiffness_n_per_m: 1e6,
        max_damping_n_s_per_m: 1e3,
        workspace_radius_m: 0.075,
    };
    let (info, _) = within_ceilings(&info);
    let limits = RenderLimits::for_device(&info, T_NS);
    let mapping = DeviceMapping::y_up_model([0.0; 3]);
    let mut renderer = ForceRenderer::new(limits, mapping);
    let pc_damping = info.max_damping_n_s_per_m - limits.damping_n_s_per_m;
    let mut po = PassivityObserver::new(pc_damping, controller);
    let mut device = hand.map(|(dynamics, k, b)| {
        let grip = Hand {
            grip_stiffness_n_per_m: k,
            grip_damping_n_s_per_m: b,
            anchor: Some(trajectory.clone()),
            ..Hand::default()
        };
        SimulatedDevice::new(info.clone(), dynamics, grip).starting_at(trajectory.position_at(0.0), [0.0; 3]).manual()
    });
    let (hold_from, hold_to) = (2.05, 2.75);
    let mut out = Press {
        figures: Default::default(),
        hold_speed_max: 0.0,
        hold_ticks_out: 0,
        max_force: 0.0,
        rendered_stiffness: limits.max_stiffness_n_per_m,
    };
    let mut sent: Option<[f64; 3]> = None;
    let mut previous_z: Option<f64> = None;
    for n in 0..(3.6 / T) as u64 {
        let t = n as f64 * T;
        let x = match &mut device {
            Some(d) => d.read().unwrap().position_m,
            None => trajectory.position_at(t),
        };
        if n % 4 == 0 {
            // A core tick: feedback from the pose it had, then the newest pose goes to it.
            if let Some(p) = sent {
                let depth = (-p[1]).max(0.0);
                let mut fb = ContactFeedback { in_contact: u32::from(depth > 0.0), x_ref: p, ..Default::default() };
                if depth > 0.0 {
                    fb.force = [0.0, tissue.force(depth), 0.0];
                    fb.stiffness[1][1] = -STIFF_TISSUE;
                }
                renderer.accept_feedback(&fb, n * T_NS).unwrap();
            }
            sent = Some(mapping.to_model(x));
        }
        let rendered = renderer.render(x, n * T_NS);
        po.set_gain(rendered.gain);
        let f = po.tick(Some(x), n * T_NS, rendered.force_n, limits.max_force_n);
        out.max_force = out.max_force.max(f.iter().map(|c| c * c).sum::<f64>().sqrt());
        if (hold_from..hold_to).contains(&t) {
            if let Some(z0) = previous_z {
                out.hold_speed_max = out.hold_speed_max.max(((x[2] - z0) / T).abs());
            }
            out.hold_ticks_out += usize::from(!rendered.in_contact || x[2] >= 0.0);
        }
        previous_z = Some(x[2]);
        if let Some(d) = &mut device {
            d.write_force(f).unwrap();
            d.advance(T);
        }
    }
    out.figures = *po.figures();
    out
}

/// The living limb's press (`config/scenes/limb-in-vivo.toml`: contact stiffness 30 kN/m,
/// 7.5 N at 8 mm) and an elastic wall of the same 30 kN/m, pressed 12 mm deep along
/// `demo_press_pull.csv` on an omega-class device (stiffness rendered 14.5 kN/m, its ceiling;
/// 12 N), by a position source and by a simulated device (0.2 kg, 0.05 N s/m) in a light grip
/// (400 N/m, 3 N s/m) and a firm one (1000 N/m, 10 N s/m).
///
/// The limb's local model, stiffer than its response, gains no energy at all. The wall does:
/// between core ticks the model holds the force of a pose 1-2 ms old, and the force it lacks
/// above 14.5 kN/m comes back at 1 kHz; in the light grip the handle bounces off the wall
/// through the hold. With the passivity controller no grip leaves the wall, the handle's speed
/// over the hold falls, the lowest observed energy is a few percent of what it was at most,
/// and the energy the controller pays back leaves the run's account at zero. A position
/// source cannot be slowed: there the energy the lagging model gives on the way out, at most
/// the force limit times two core periods of travel (12 N × 27.5 mm/s × 2 ms), is paid back
/// after the release.
#[test]
fn press_at_the_living_limb_stiffness_gains_no_energy_works() {
    let dynamics = DeviceDynamics { mass_kg: M, damping_n_s_per_m: 0.05 };
    let hands = [
        ("scripted (position source)", None),
        ("grip 400 N/m, 3 N s/m", Some((dynamics, 400.0, 3.0))),
        ("grip 1000 N/m, 10 N s/m", Some((dynamics, 1000.0, 10.0))),
    ];
    println!(
        "| tissue | hand | controller | rendered stiffness, N/m | to the hand, J | from the hand, J | observed at the end, J | lowest observed, J | dissipated, J | controller ticks (at ceiling) | hold: max speed, m/s | hold: ticks out of contact | max force, N |"
    );
    for tissue in [Tissue::Limb, Tissue::Wall] {
        for (name, hand) in hands {
            let [off, on] = [false, true].map(|controller| {
                let p = press(tissue, hand, controller);
                let f = &p.figures;
                println!(
                    "| {tissue:?} | {name} | {controller} | {:.0} | {:.4e} | {:.4e} | {:.3e} | {:.3e} | {:.3e} | {} ({}) | {:.3e} | {} | {:.3} |",
                    p.rendered_stiffness,
                    f.energy_to_hand_j,
                    f.energy_from_hand_j,
                    f.observed_energy_j,
                    f.min_observed_energy_j,
                    f.dissipated_j,
                    f.controller_ticks,
                    f.controller_saturated_ticks,
                    p.hold_speed_max,
                    p.hold_ticks_out,
                    p.max_force
                );
                p
            });
            let what = format!("{tissue:?}, {name}");
            assert_eq!(on.rendered_stiffness, 14_500.0, "the omega class's ceiling");
            assert_eq!(on.hold_ticks_out, 0, "{what}: the handle stays in contact through the hold");
            assert!(on.figures.observed_energy_j >= -1e-6, "{what}: paid back: {:?}", on.figures);
            match (tissue, hand) {
                (Tissue::Limb, _) => {
                    for p in [&off, &on] {
                        assert!(p.figures.min_observed_energy_j >= 0.0, "{what}: no energy gained: {:?}", p.figures);
                        assert_eq!(p.hold_ticks_out, 0, "{what}");
                    }
                }
                (Tissue::Wall, None) => {
                    let bound = 12.0 * 0.0275 * 0.002;
                    for p in [&off, &on] {
                        assert!(p.figures.min_observed_energy_j >= -bound, "{what}: {:?}, bound {bound} J", p.figures);
                    }
                    assert!(off.figures.observed_energy_j < -1e-5, "{what}: without the controller the gain stays");
                }
                (Tissue::Wall, Some(_)) => {
                    let (a, b) = (on.figures.min_observed_energy_j, off.figures.min_observed_energy_j);
                    assert!(a >= 0.05 * b, "{what}: lowest observed {a:.3e} J with the controller, {b:.3e} J without");
                    assert!(
                        on.hold_speed_max < 0.5 * off.hold_speed_max,
                        "{what}: {} m/s, {} m/s without",
                        on.hold_speed_max,
                        off.hold_speed_max
                    );
                }
            }
        }
    }
    let light = press(Tissue::Wall, hands[1].1, false);
    assert!(light.hold_ticks_out > 100, "the light grip bounces off the wall without the controller: {light:?}");
}

/// `lamina-haptics --device simulated:FILE.csv` against a stand-in core's 30 kN/m wall: the
/// grip presses the handle 8 mm in and lets go; the report's passivity figures add up (the
/// observed energy is what the hand gave less what it got) and the summary says them. Bad
/// `--device-args` are refused naming the key, the value and the range.
#[test]
fn simulated_device_process_reports_its_passivity_figures_works() {
    use common::{WallCore, haptics, prefix, scratch, stderr, stdout};
    let dir = scratch();
    let csv = dir.join("simulated_press.csv");
    std::fs::write(&csv, "t_s,x_m,y_m,z_m\n0,0,0,0.005\n1.0,0,0,-0.008\n1.5,0,0,-0.008\n2.0,0,0,0.005\n").unwrap();
    let device = format!("simulated:{}", csv.display());
    let p = prefix("simulated");
    let report = dir.join(format!("{p}.json"));
    let core = WallCore::start(&p, STIFF_TISSUE);
    let r = report.display().to_string();
    let out = haptics(&[
        "--prefix",
        &p,
        "--device",
        &device,
        "--device-args",
        "grip_n_per_m=1000,grip_n_s_per_m=10",
        "--origin",
        "0,0,0",
        "--seconds",
        "2.2",
        "--quiet",
        "--report",
        &r,
    ]);
    drop(core);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("passivity: energy to the hand"), "{}", stdout(&out));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let f = |k: &str| json["passivity"][k].as_f64().unwrap_or_else(|| panic!("passivity.{k} in {json}"));
    assert_eq!(json["passivity"]["controller_on"], true);
    let (to, from, observed, lowest) =
        (f("energy_to_hand_j"), f("energy_from_hand_j"), f("observed_energy_j"), f("min_observed_energy_j"));
    eprintln!(
        "simulated press on a 30 kN/m wall: to the hand {to:.4e} J, from it {from:.4e} J, lowest observed {lowest:.3e} J, dissipated {:.3e} J in {} ticks",
        f("dissipated_j"),
        json["passivity"]["controller_ticks"]
    );
    assert!(to > 0.0 && from > 0.0, "the grip pressed and the wall pushed back: {json}");
    assert!((observed - (from - to)).abs() <= 1e-9 * from, "observed {observed} J, from − to {} J", from - to);
    assert!(lowest <= observed.min(0.0), "the lowest ({lowest} J) is at most the end and 0");
    for (arg, want) in [
        ("mass_kg=0", "mass_kg '0' must be a number above 0 to 100 kg"),
        ("grip_n_per_m=-1", "grip_n_per_m '-1' must be a number from 0 to 1e6 N/m"),
        ("damping_n_s_per_m=nan", "damping_n_s_per_m 'nan' must be a number from 0 to 10000 N s/m"),
        ("stiffness=3", "unknown 'stiffness'"),
    ] {
        let out = haptics(&["--device", &device, "--device-args", arg, "--origin", "0,0,0", "--seconds", "0.1"]);
        assert_eq!(out.status.code(), Some(2), "{arg} is refused");
        assert!(stderr(&out).contains(want), "{arg}: {}", stderr(&out));
    }
}
