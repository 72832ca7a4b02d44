//! The time-domain passivity observer and controller of the device port (Hannaford and Ryu
//! 2002): how much energy the rendered force has given the hand, and a variable damper that
//! takes back whatever the rendering would create.
//!
//! # Sign convention
//! The port is the handle: `F` is the force commanded to the device (N, device frame, the force
//! the device applies to the hand) and `x` the handle position read each tick. A commanded force
//! is held until the next tick (zero-order hold), so over the tick from `x(n−1)` to `x(n)` the
//! device does the work `F(n−1)·(x(n) − x(n−1))` on the hand, exactly. The observed energy is
//! the energy that flowed *into* the virtual environment from the hand:
//!
//! ```text
//! E(n) = −Σ_{k=1..n} F(k−1)·(x(k) − x(k−1))      (J)
//! ```
//!
//! The rendering is passive up to tick `n` when `E(n) ≥ 0`: the environment has given back at
//! most what the hand put in. A sampled wall is not: pressed in and let out again it returns
//! more than it took (the force lags the position by a tick both ways), and `E` goes negative.
//!
//! # The controller
//! When `E(n) < 0`, the force of the next tick gets a damper `−α v(n)`, `v(n) = (x(n) −
//! x(n−1)) / Δt`, of `α = −E(n) / (Δt |v(n)|²)` N·s/m: the damping that dissipates the deficit
//! over the next tick if the hand keeps its velocity. `α` is held to the device's damping
//! ceiling and the result to its force limit, so the controller may need several ticks to pay
//! a deficit; `E` counts what it actually dissipated, from the positions that follow.
//!
//! It allocates nothing and does no I/O: it runs inside the device loop.
//!
//! # Examples
//!
//! A 1 N force along z held while the hand is pushed 1 mm down: the hand put 1 mJ into the
//! environment.
//!
//! ```
//! use lamina_haptics::PassivityObserver;
//!
//! let mut po = PassivityObserver::new(10.0, true);
//! let _ = po.tick(Some([0.0, 0.0, 0.0]), 0, [0.0, 0.0, 1.0], 5.0);
//! let _ = po.tick(Some([0.0, 0.0, -0.001]), 250_000, [0.0, 0.0, 1.0], 5.0);
//! assert!((po.figures().observed_energy_j - 1e-3).abs() < 1e-15);
//! assert_eq!(po.figures().controller_ticks, 0);
//! ```

use crate::device::norm3;

/// What the passivity observer measured over a run (the haptics report's `passivity`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PassivityFigures {
    /// Whether the passivity controller was on (else the observer only measured).
    pub controller_on: bool,
    /// Energy the device gave the hand: the sum of the ticks' positive work `F·Δx`, J.
    pub energy_to_hand_j: f64,
    /// Energy the hand gave the device: the sum of the ticks' negative work, J.
    pub energy_from_hand_j: f64,
    /// The observed energy `E` at the end, J: `energy_from_hand_j − energy_to_hand_j`.
    pub observed_energy_j: f64,
    /// The most negative `E` seen (0 when it never went below 0), J.
    pub min_observed_energy_j: f64,
    /// Energy the controller's damper dissipated, J (its force times the displacement that
    /// followed).
    pub dissipated_j: f64,
    /// Ticks the controller acted (added a damper).
    pub controller_ticks: u64,
    /// Of these, ticks whose damper was held to the device's damping ceiling.
    pub controller_saturated_ticks: u64,
    /// Ticks with no usable pose (non-finite or beyond the workspace): no work observed, the
    /// force passed on unchanged.
    pub unobserved_ticks: u64,
}

/// The observer and controller of the device port (see the module docs).
#[derive(Debug, Clone)]
pub struct PassivityObserver {
    max_damping_n_s_per_m: f64,
    controller_on: bool,
    energy_j: f64,
    /// The previous tick's pose and time, while the chain of poses is unbroken.
    previous: Option<([f64; 3], u64)>,
    /// The force commanded at the previous tick, and the controller's part of it.
    last_force: [f64; 3],
    last_damper: [f64; 3],
    figures: PassivityFigures,
    /// The renderer's gain for the coming tick, 0 to 1.
    gain: f64,
}

impl PassivityObserver {
    /// An observer with nothing observed; with `controller_on`, its damper is held to
    /// `max_damping_n_s_per_m` (N·s/m, the device's damping ceiling).
    pub fn new(max_damping_n_s_per_m: f64, controller_on: bool) -> Self {
        Self {
            max_damping_n_s_per_m: max_damping_n_s_per_m.max(0.0),
            controller_on,
            energy_j: 0.0,
            previous: None,
            last_force: [0.0; 3],
            last_damper: [0.0; 3],
            figures: PassivityFigures { controller_on, ..PassivityFigures::default() },
            gain: 1.0,
        }
    }

    /// Sets the renderer's staleness and onset gain for the next [`tick`](Self::tick)'s
    /// damper (clamped to 0..=1; NaN is 0).
    pub fn set_gain(&mut self, gain: f64) {
        self.gain = if gain.is_nan() { 0.0 } else { gain.clamp(0.0, 1.0) };
    }

    /// The observed energy `E` now, J.
    pub fn energy_j(&self) -> f64 {
        self.energy_j
    }

    /// The figures so far.
    pub fn figures(&self) -> &PassivityFigures {
        &self.figures
    }

    /// One device tick: `pose` is the handle position read this tick (m, device frame; `None`
    /// when it is not usable), `now_ns` its time, `rendered_n` the force the renderer asks for
    /// (N, device frame, finite), `max_force_n` the force limit. Books the work of the force
    /// held since the previous tick, and returns the force to command: `rendered_n` plus the
    /// controller's damper, within `max_force_n`. The damper is scaled by the renderer's
    /// staleness and onset gain (`RenderedForce::gain`, 0 to 1, set with
    /// [`set_gain`](Self::set_gain); 1 until set), so that the zero force of a quiet core
    /// stays zero.
    pub fn tick(&mut self, pose: Option<[f64; 3]>, now_ns: u64, rendered_n: [f64; 3], max_force_n: f64) -> [f64; 3] {
        let Some(x) = pose.filter(|p| p.iter().all(|c| c.is_finite())) else {
            // No pose: the work over this tick cannot be known; start a new chain.
            self.figures.unobserved_ticks += 1;
            self.previous = None;
            self.last_force = rendered_n;
            self.last_damper = [0.0; 3];
            return rendered_n;
        };
        let mut velocity = None;
        if let Some((p, t)) = self.previous {
            let dx = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
            let work = dot(self.last_force, dx);
            if work > 0.0 {
                self.figures.energy_to_hand_j += work;
            } else {
                self.figures.energy_from_hand_j -= work;
            }
            self.energy_j -= work;
            self.figures.dissipated_j -= dot(self.last_damper, dx);
            self.figures.min_observed_energy_j = self.figures.min_observed_energy_j.min(self.energy_j);
            if now_ns > t {
                velocity = Some((dx, (now_ns - t) as f64 * 1e-9));
            }
        }
        self.figures.observed_energy_j = self.energy_j;
        let mut force = rendered_n;
        if self.controller_on
            && self.energy_j < 0.0
            && let Some((dx, dt)) = velocity
        {
            let dx2 = dot(dx, dx);
            if dx2 > 0.0 {
                // α = −E / (Δt |v|²) with v = Δx / Δt.
                let wanted = -self.energy_j * dt / dx2;
                let alpha = wanted.min(self.max_damping_n_s_per_m) * self.gain;
                if alpha > 0.0 {
                    self.figures.controller_ticks += 1;
                    if wanted > self.max_damping_n_s_per_m {
                        self.figures.controller_saturated_ticks += 1;
                    }
                    for c in 0..3 {
                        force[c] -= alpha * dx[c] / dt;
                    }
                }
            }
        }
        let force = within(force, max_force_n);
        // The controller's part: what it changed in the force the limit lets through.
        let rendered = within(rendered_n, max_force_n);
        self.last_damper = [force[0] - rendered[0], force[1] - rendered[1], force[2] - rendered[2]];
        self.last_force = force;
        self.previous = Some((x, now_ns));
        force
    }
}

/// `f` with its norm held to `max_n`.
fn within(f: [f64; 3], max_n: f64) -> [f64; 3] {
    let n = norm3(f);
    if n > max_n { f.map(|c| c * (max_n / n)) } else { f }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: u64 = 250_000;

    #[test]
    fn observer_books_the_held_force_times_the_displacement_works() {
        let mut po = PassivityObserver::new(10.0, false);
        // 2 N up held while the hand moves 1 mm up (the device gives 2 mJ), then 3 N up while
        // it moves 0.5 mm down (the hand gives 1.5 mJ back).
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 2.0], 10.0);
        po.tick(Some([0.0, 0.0, 0.001]), T, [0.0, 0.0, 3.0], 10.0);
        po.tick(Some([0.0, 0.0, 0.0005]), 2 * T, [0.0; 3], 10.0);
        let f = po.figures();
        assert!((f.energy_to_hand_j - 2e-3).abs() < 1e-15, "{f:?}");
        assert!((f.energy_from_hand_j - 1.5e-3).abs() < 1e-15, "{f:?}");
        assert!((f.observed_energy_j + 0.5e-3).abs() < 1e-15, "{f:?}");
        assert!((f.min_observed_energy_j + 2e-3).abs() < 1e-15, "{f:?}");
        assert_eq!((f.controller_ticks, f.dissipated_j), (0, 0.0), "the controller is off");
    }

    #[test]
    fn controller_adds_the_damper_that_pays_the_deficit_works() {
        let mut po = PassivityObserver::new(100.0, true);
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 1.0], 10.0);
        // The hand moved 1 mm up under 1 N: E = −1 mJ; v = 4 m/s; α = 1e-3 / (2.5e-4 · 16).
        let f = po.tick(Some([0.0, 0.0, 0.001]), T, [0.0, 0.0, 1.0], 10.0);
        let alpha = 1e-3 / (2.5e-4 * 16.0);
        assert!((f[2] - (1.0 - alpha * 4.0)).abs() < 1e-12, "force {f:?}, α {alpha}");
        // The hand keeps its velocity: the damper dissipates exactly the deficit, but the
        // rendered 1 N does 1 mJ more work over that tick.
        po.tick(Some([0.0, 0.0, 0.002]), 2 * T, [0.0; 3], 10.0);
        let fig = po.figures();
        assert!((fig.dissipated_j - 1e-3).abs() < 1e-15, "{fig:?}");
        assert!((fig.observed_energy_j + 1e-3).abs() < 1e-15, "{fig:?}");
        assert_eq!(fig.controller_ticks, 2, "and it acts again on that new deficit");
    }

    #[test]
    fn controller_is_held_to_the_damping_ceiling_and_force_limit_works() {
        // 3 N (10 N asked, the limit is 3 N) held over 1 mm up: E = −3 mJ, v = 4 m/s, the
        // damper wanted is 3e-3 · 2.5e-4 / 1e-6 = 0.75 N s/m.
        let mut po = PassivityObserver::new(2.0, true);
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 10.0], 3.0);
        let f = po.tick(Some([0.0, 0.0, 0.001]), T, [0.0, 0.0, 1.0], 3.0);
        assert!((f[2] - (1.0 - 0.75 * 4.0)).abs() < 1e-12, "within the 2 N s/m ceiling: {f:?}");
        assert_eq!(po.figures().controller_saturated_ticks, 0);
        let mut po = PassivityObserver::new(0.5, true);
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 3.0], 3.0);
        let f = po.tick(Some([0.0, 0.0, 0.001]), T, [0.0, 0.0, 1.0], 3.0);
        assert!((f[2] - (1.0 - 0.5 * 4.0)).abs() < 1e-12, "held to the 0.5 N s/m ceiling: {f:?}");
        assert_eq!(po.figures().controller_saturated_ticks, 1);
        // 30 mJ over 1 cm at 40 m/s: α = 0.075 N s/m, a 3 N damper; with 2 N rendered across
        // it the sum (3.6 N) is held to the 3 N limit.
        let mut po = PassivityObserver::new(100.0, true);
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 3.0], 3.0);
        let f = po.tick(Some([0.0, 0.0, 0.01]), T, [2.0, 0.0, 0.0], 3.0);
        assert!((norm3(f) - 3.0).abs() < 1e-12, "held to the 3 N limit: {f:?}");
        assert!((f[2] / f[0] + 1.5).abs() < 1e-12, "in the direction of the sum: {f:?}");
    }

    #[test]
    fn observer_skips_ticks_without_a_pose_works() {
        let mut po = PassivityObserver::new(10.0, true);
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 1.0], 10.0);
        let f = po.tick(None, T, [0.0, 0.0, 0.5], 10.0);
        assert_eq!(f, [0.0, 0.0, 0.5], "passed on unchanged");
        po.tick(Some([0.0, 0.0, 0.004]), 2 * T, [0.0; 3], 10.0);
        let fig = po.figures();
        assert_eq!((fig.observed_energy_j, fig.unobserved_ticks), (0.0, 1), "{fig:?}");
        let f = po.tick(Some([0.0, 0.0, f64::NAN]), 3 * T, [1.0, 0.0, 0.0], 10.0);
        assert_eq!((f, po.figures().unobserved_ticks), ([1.0, 0.0, 0.0], 2));
    }

    #[test]
    fn controller_leaves_a_quiet_cores_zero_force_at_zero_works() {
        let mut po = PassivityObserver::new(100.0, true);
        po.tick(Some([0.0; 3]), 0, [0.0, 0.0, 1.0], 10.0);
        po.set_gain(0.0);
        let f = po.tick(Some([0.0, 0.0, 0.001]), T, [0.0; 3], 10.0);
        assert_eq!(f, [0.0; 3], "a deficit (E = −1 mJ) but the core is quiet");
        po.set_gain(0.5);
        let f = po.tick(Some([0.0, 0.0, 0.002]), 2 * T, [0.0; 3], 10.0);
        // E = −1 mJ, v = 4 m/s: α = 0.25 N s/m at full gain, half of it here.
        assert!((f[2] + 0.5 * 0.25 * 4.0).abs() < 1e-12, "{f:?}");
    }
}
