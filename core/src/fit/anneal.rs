//! Simulated annealing on a continuous, positive parameter box (Press et al., *Numerical
//! Recipes*, ch. 10.12, which the paper cites), in log space since stiffnesses span decades.
//!
//! # Schedule
//! - Start at the given point with temperature `T0 = initial_temperature · ψ(x0)` (ψ's scale).
//! - A move multiplies every parameter by `exp(step · sqrt(T / T0) · N(0, 1))`, clamped to
//!   the box: moves shrink as the system cools.
//! - Metropolis acceptance: a better point always, a worse one with probability
//!   `exp(−Δψ / T)`.
//! - Geometric cooling: `T ← cooling · T` after every `moves_per_temperature` moves.
//! - Stop at the first of: best ψ below `psi_stop`; `max_evaluations`; `T < T0 · 1e-8`.
//!
//! The random stream is `XorShiftRng` seeded with `seed`: a run is reproducible bit for bit.

use rand_core::{Rng, SeedableRng};
use rand_xorshift::XorShiftRng;

/// Settings of one annealing run, with their defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnnealSettings {
    /// Seed of the random stream. Default 2008.
    pub seed: u64,
    /// `T0` as a fraction of the starting point's ψ. Default 0.5.
    pub initial_temperature: f64,
    /// Geometric cooling factor per temperature level. Default 0.85.
    pub cooling: f64,
    /// Moves per temperature level. Default 12.
    pub moves_per_temperature: usize,
    /// Standard deviation of a move in log space at `T0`. Default 0.25.
    pub step: f64,
    /// Stop when the best ψ is below this. Default 1e-5.
    pub psi_stop: f64,
    /// Stop after this many evaluations of ψ. Default 1500.
    pub max_evaluations: usize,
}

impl Default for AnnealSettings {
    fn default() -> Self {
        Self {
            seed: 2008,
            initial_temperature: 0.5,
            cooling: 0.85,
            moves_per_temperature: 12,
            step: 0.25,
            psi_stop: 1e-5,
            max_evaluations: 1500,
        }
    }
}

/// Why the annealing stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnnealStop {
    /// The best ψ fell below `psi_stop`.
    Converged,
    /// `max_evaluations` reached.
    Evaluations,
    /// The temperature fell below `T0 · 1e-8`.
    Frozen,
}

/// One evaluation of ψ.
#[derive(Clone, Debug, PartialEq)]
pub struct AnnealStep {
    /// Evaluation number (0 = the starting point).
    pub evaluation: usize,
    /// Temperature at the evaluation.
    pub temperature: f64,
    /// The parameters evaluated.
    pub params: Vec<f64>,
    /// ψ there.
    pub psi: f64,
    /// Whether the move was accepted.
    pub accepted: bool,
}

/// The outcome of [`anneal`].
#[derive(Clone, Debug, PartialEq)]
pub struct AnnealResult {
    /// Best parameters found.
    pub best: Vec<f64>,
    /// ψ at `best`.
    pub best_psi: f64,
    /// Every evaluation, in order.
    pub history: Vec<AnnealStep>,
    /// Why it stopped.
    pub stop: AnnealStop,
}

fn uniform(rng: &mut XorShiftRng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn normal(rng: &mut XorShiftRng) -> f64 {
    // Box-Muller; 1 - u keeps the logarithm finite.
    let (u1, u2) = (1.0 - uniform(rng), uniform(rng));
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Minimises `psi` over the box `[lower, upper]` (all bounds > 0) from `x0`; `on_step` sees
/// every evaluation (for progress bars). A non-finite ψ counts as +∞.
pub fn anneal(
    x0: &[f64],
    lower: &[f64],
    upper: &[f64],
    settings: &AnnealSettings,
    mut psi: impl FnMut(&[f64]) -> f64,
    mut on_step: impl FnMut(&AnnealStep),
) -> AnnealResult {
    let mut rng = XorShiftRng::seed_from_u64(settings.seed);
    let clamp = |x: Vec<f64>| -> Vec<f64> { x.iter().enumerate().map(|(i, v)| v.clamp(lower[i], upper[i])).collect() };
    let eval = |psi: &mut dyn FnMut(&[f64]) -> f64, x: &[f64]| {
        let v = psi(x);
        if v.is_finite() { v } else { f64::INFINITY }
    };
    let mut current = clamp(x0.to_vec());
    let mut current_psi = eval(&mut psi, &current);
    let t0 = (settings.initial_temperature * current_psi).max(1e-12);
    let mut temperature = t0;
    let first = AnnealStep { evaluation: 0, temperature, params: current.clone(), psi: current_psi, accepted: true };
    on_step(&first);
    let mut history = vec![first];
    let (mut best, mut best_psi) = (current.clone(), current_psi);
    let mut evaluation = 0;
    let stop = loop {
        if best_psi < settings.psi_stop {
            break AnnealStop::Converged;
        }
        if evaluation >= settings.max_evaluations {
            break AnnealStop::Evaluations;
        }
        if temperature < t0 * 1e-8 {
            break AnnealStop::Frozen;
        }
        for _ in 0..settings.moves_per_temperature {
            evaluation += 1;
            let sigma = settings.step * (temperature / t0).sqrt();
            let trial = clamp(current.iter().map(|v| v * (sigma * normal(&mut rng)).exp()).collect());
            let trial_psi = eval(&mut psi, &trial);
            let delta = trial_psi - current_psi;
            let accepted = delta <= 0.0 || uniform(&mut rng) < (-delta / temperature).exp();
            let step = AnnealStep { evaluation, temperature, params: trial.clone(), psi: trial_psi, accepted };
            on_step(&step);
            history.push(step);
            if accepted {
                current = trial;
                current_psi = trial_psi;
                if current_psi < best_psi {
                    best = current.clone();
                    best_psi = current_psi;
                }
            }
            if best_psi < settings.psi_stop || evaluation >= settings.max_evaluations {
                break;
            }
        }
        temperature *= settings.cooling;
    };
    AnnealResult { best, best_psi, history, stop }
}
