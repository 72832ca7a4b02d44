//! Accuracy against cost: for each integrator over a range of steps, the error against a
//! closed form (a damped spring; a hanging chain's static sag) or against a converged
//! reference (a model stepped in f64 by RK4 at a twentieth of the critical step), and the
//! wall time per simulated second.

use crate::law::SpringLaw;
use crate::model::{Layer, Model, NodeKind, Tissue};
use crate::real::Real;
use crate::solver::{Effects, IntegrationParameters, IntegratorKind, Simulation, Substeps};
use serde::Serialize;
use std::time::Instant;

/// Which problem the errors are measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum AccuracyCase {
    /// One damped spring, `x(0.5 s)` against the closed form.
    SingleSpring,
    /// A ten-mass hanging chain after 2 s of settling, against the analytic static sag.
    HangingChain,
    /// A given model (the default scene's), `x(T)` against an f64 RK4 reference.
    Model,
}

/// One integrator at one step.
#[derive(Clone, Debug, Serialize)]
pub struct AccuracyRow {
    /// Problem.
    pub case: AccuracyCase,
    /// Integrator name.
    pub integrator: &'static str,
    /// Step, s.
    pub step_s: f64,
    /// Step over the symplectic-Euler critical step.
    pub step_over_critical: f64,
    /// Largest node position error, m (NaN when the run blew up).
    pub error_m: f64,
    /// Wall time per simulated second, s/s (f32 for `Model`, f64 otherwise).
    pub cost_s_per_s: f64,
    /// log(error ratio)/log(step ratio) against the previous, larger step.
    pub observed_order: Option<f64>,
    /// Theoretical order.
    pub theoretical_order: u32,
}

fn spring_model() -> Model {
    let mut m = Model::default();
    m.layers.push(Layer { name: "test".into(), tissue: Tissue::Other });
    m.nodes.push([0.0; 3], 1.0, NodeKind::Fixed, 0);
    m.nodes.push([0.06, 0.0, 0.0], 0.1, NodeKind::Free, 0);
    m.springs.push(0, 1, 0.05, SpringLaw::Linear { stiffness: 40.0 }, 0.4, 0);
    m
}

fn spring_exact(t: f64) -> f64 {
    let (m, k, c, a): (f64, f64, f64, f64) = (0.1, 40.0, 0.4, 0.01);
    let (omega, gamma) = ((k / m).sqrt(), c / (2.0 * m));
    let wd = (omega * omega - gamma * gamma).sqrt();
    a * (-gamma * t).exp() * ((wd * t).cos() + gamma / wd * (wd * t).sin())
}

const CHAIN_N: usize = 10;
const CHAIN_MASS: f64 = 0.01;
const CHAIN_REST: f64 = 0.02;
const CHAIN_K: f64 = 50.0;

fn chain_model() -> Model {
    let mut m = Model::default();
    m.layers.push(Layer { name: "chain".into(), tissue: Tissue::Other });
    m.nodes.push([0.0; 3], CHAIN_MASS, NodeKind::Fixed, 0);
    for i in 1..=CHAIN_N {
        m.nodes.push([0.0, -(i as f64) * CHAIN_REST, 0.0], CHAIN_MASS, NodeKind::Free, 0);
        m.springs.push((i - 1) as u32, i as u32, CHAIN_REST, SpringLaw::Linear { stiffness: CHAIN_K }, 0.0, 0);
    }
    m
}

fn chain_static() -> Vec<f64> {
    let mut y = 0.0;
    let mut out = vec![0.0];
    for j in 1..=CHAIN_N {
        y -= CHAIN_REST + (CHAIN_N - j + 1) as f64 * CHAIN_MASS * 9.81 / CHAIN_K;
        out.push(y);
    }
    out
}

fn run<T: Real>(
    model: &Model,
    effects: &Effects,
    integrator: IntegratorKind,
    h: f64,
    t_end: f64,
) -> (Vec<[f64; 3]>, f64) {
    let params = IntegrationParameters {
        dt: h,
        integrator,
        substeps: Substeps::Fixed(1),
        cg_tolerance: if T::NAME == "f64" { 1e-10 } else { 1e-6 },
        cg_max_iterations: 1000,
        ..IntegrationParameters::default()
    };
    let mut sim = Simulation::<T>::new(model, params, effects.clone()).expect("study models are valid");
    let steps = (t_end / h).round().max(1.0) as usize;
    debug_assert!((steps as f64 * h - t_end).abs() < 1e-9 * t_end, "the step divides the run");
    let start = Instant::now();
    for _ in 0..steps {
        sim.step();
    }
    let wall = start.elapsed().as_secs_f64();
    let x = (0..model.nodes.len()).map(|i| sim.state().x.get_f64(i)).collect();
    (x, wall / (steps as f64 * h))
}

fn max_error(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let mut e: f64 = 0.0;
    for (p, q) in a.iter().zip(b) {
        let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        if !d.is_finite() {
            return f64::NAN;
        }
        e = e.max(d);
    }
    e
}

/// Steps to try, as multiples of the critical step, per integrator.
fn step_factors(integrator: IntegratorKind, quick: bool) -> Vec<f64> {
    let explicit = [0.8, 0.4, 0.2, 0.1, 0.05, 0.025];
    let implicit = [16.0, 4.0, 1.0, 0.4, 0.1, 0.025];
    let list: &[f64] = if integrator.is_explicit() { &explicit } else { &implicit };
    let n = if quick { 4 } else { list.len() };
    list[..n].to_vec()
}

/// Runs the study for `case`; `model` is used by [`AccuracyCase::Model`] (with `effects`,
/// over `t_end` seconds). `quick` tries fewer steps.
pub fn accuracy_study(
    case: AccuracyCase,
    model: &Model,
    effects: &Effects,
    t_end: f64,
    quick: bool,
) -> Vec<AccuracyRow> {
    let (model, effects, t_end) = match case {
        AccuracyCase::SingleSpring => {
            (spring_model(), Effects { bone: true, spring_damping: true, ..Effects::default() }, 0.5)
        }
        AccuracyCase::HangingChain => (
            chain_model(),
            Effects { bone: true, gravity: Some([0.0, -9.81, 0.0]), viscous_damping: Some(20.0), ..Effects::default() },
            2.0,
        ),
        AccuracyCase::Model => (model.clone(), effects.clone(), t_end),
    };
    let critical = Simulation::<f64>::new(&model, IntegrationParameters::default(), effects.clone())
        .expect("study models are valid")
        .stability()
        .critical_step(IntegratorKind::SymplecticEuler);
    let reference: Vec<[f64; 3]> = match case {
        AccuracyCase::SingleSpring => {
            let mut r = model.nodes.position.clone();
            r[1][0] = 0.05 + spring_exact(t_end);
            r
        }
        AccuracyCase::HangingChain => chain_static().iter().map(|&y| [0.0, y, 0.0]).collect(),
        AccuracyCase::Model => {
            let n = (t_end / (critical / 20.0)).ceil();
            run::<f64>(&model, &effects, IntegratorKind::Rk4, t_end / n, t_end).0
        }
    };
    let mut rows = Vec::new();
    for integrator in IntegratorKind::ALL {
        let mut previous: Option<(f64, f64)> = None;
        for factor in step_factors(integrator, quick) {
            // A whole number of steps ends every run exactly at t_end.
            let n = (t_end / (critical * factor)).round().max(4.0);
            let h = t_end / n;
            if previous.is_some_and(|(h0, _)| h0 == h) {
                continue;
            }
            let (x, cost64) = run::<f64>(&model, &effects, integrator, h, t_end);
            let error = max_error(&x, &reference);
            let cost =
                if case == AccuracyCase::Model { run::<f32>(&model, &effects, integrator, h, t_end).1 } else { cost64 };
            // The chain's error is the static sag after settling: it has no order in the step.
            let observed = previous.filter(|_| case != AccuracyCase::HangingChain).and_then(|(h0, e0)| {
                (e0.is_finite() && error.is_finite() && e0 > 0.0 && error > 0.0)
                    .then(|| (e0 / error).ln() / (h0 / h).ln())
            });
            rows.push(AccuracyRow {
                case,
                integrator: integrator.name(),
                step_s: h,
                step_over_critical: h / critical,
                error_m: error,
                cost_s_per_s: cost,
                observed_order: observed,
                theoretical_order: integrator.order(),
            });
            previous = Some((h, error));
        }
    }
    rows
}
