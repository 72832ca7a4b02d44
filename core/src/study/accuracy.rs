//! Accuracy against cost: for each integrator over a range of steps, the error against a
//! closed form (a damped spring; a hanging chain's static sag) or, for a model pressed and
//! released by the sphere tool, against an independent reference (the model's equations
//! integrated in f64 by adaptive Dormand–Prince 5(4), [`super::reference`]), and the wall
//! time per simulated second. For the model, every integrator is also run as the real-time
//! loop runs it: 1 ms frames with automatic sub-steps.
//!
//! An error within ten times the reference's own error (or, against a closed form, within
//! 1,000 ulps of the positions) is *at the floor*: it measures the reference, not the
//! integrator, and no order is computed from it.

use super::reference::{Reference, ReferenceError, max_distance};
use crate::law::SpringLaw;
use crate::model::{Layer, Model, NodeKind, Tissue};
use crate::real::Real;
use crate::solver::{
    Effects, IntegrationParameters, IntegratorKind, LateBuild, MultirateSettings, Simulation, SimulationBuildError,
    SphereTool, Substeps,
};
use serde::Serialize;
use std::time::Instant;

/// Which problem the errors are measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum AccuracyCase {
    /// One damped spring, `x(0.5 s)` against the closed form.
    SingleSpring,
    /// A ten-mass hanging chain after 2 s of settling, against the analytic static sag.
    HangingChain,
    /// A given model (the default scene's) pressed 4 mm by the sphere tool over the first
    /// half of the run and released over the second, `x(T)` against the adaptive reference.
    Model,
}

/// One integrator at one step.
#[derive(Clone, Debug, Serialize)]
pub struct AccuracyRow {
    /// Problem.
    pub case: AccuracyCase,
    /// Integrator name.
    pub integrator: &'static str,
    /// Step (sub-step), s.
    pub step_s: f64,
    /// `Some(n)` for a row run as the real-time loop runs: 1 ms frames of `n` automatic
    /// sub-steps; `None` for a fixed step.
    pub realtime_substeps: Option<u32>,
    /// Preconditioned CG iterations per step of `implicit_factored` (`None` for the others).
    pub pcg_iterations: Option<u32>,
    /// Step over the symplectic-Euler critical step.
    pub step_over_critical: f64,
    /// Largest node position error, m (NaN when the run blew up).
    pub error_m: f64,
    /// Wall time per simulated second, s/s (f32 for `Model`, f64 otherwise).
    pub cost_s_per_s: f64,
    /// log(error ratio)/log(step ratio) against the previous, larger step (`None` for the
    /// first step, a blown-up run, or when either error is at the floor).
    pub observed_order: Option<f64>,
    /// The error is within the floor: it measures the reference, not the integrator.
    pub at_floor: bool,
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

/// The studies' own models always build; only a multirate region can be refused.
const VALID: &str = "study models are valid";

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

/// The reference a study's errors are measured against.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceSummary {
    /// What it is.
    pub method: &'static str,
    /// Its own error estimate, m (0 for a closed form's round-off only).
    pub error_estimate_m: f64,
    /// Errors below this are at the floor, m.
    pub floor_m: f64,
    /// Accepted steps of the adaptive run (0 for a closed form).
    pub steps: u64,
}

/// One case's rows and the reference behind them.
#[derive(Clone, Debug, Serialize)]
pub struct AccuracyStudy {
    /// Fixed-step sweeps, then (model case) the real-time rows.
    pub rows: Vec<AccuracyRow>,
    /// The reference.
    pub reference: ReferenceSummary,
}

/// Depth of the model case's press, m.
pub const PRESS_DEPTH_M: f64 = 0.004;
/// Local error tolerance of the model case's reference (relative to 1 mm and 0.1 m/s).
pub const REFERENCE_TOLERANCE: f64 = 1e-10;

/// The tool's press: down `PRESS_DEPTH_M` over `[0, t_end/2]`, back up over the rest.
#[derive(Clone, Copy)]
struct Press {
    tool: SphereTool,
    turn_at: f64,
}

impl Press {
    /// Touching the model's topmost node from above, moving down.
    fn over(model: &Model, effects: &Effects, t_end: f64) -> Press {
        let (radius, stiffness) = effects.tool.map_or((0.012, 300.0), |t| (t.radius, t.stiffness));
        let top = model.nodes.position.iter().copied().max_by(|a, b| a[1].total_cmp(&b[1])).unwrap_or([0.0; 3]);
        let speed = PRESS_DEPTH_M / (0.5 * t_end);
        Press {
            tool: SphereTool {
                radius,
                stiffness,
                start: [top[0], top[1] + radius, top[2]],
                velocity: [0.0, -speed, 0.0],
            },
            turn_at: 0.5 * t_end,
        }
    }

    /// The tool moving back up from where it turned.
    fn released(&self) -> SphereTool {
        let at = self.tool.centre(self.turn_at);
        let velocity = self.tool.velocity.map(|c| -c);
        SphereTool { start: [0, 1, 2].map(|c| at[c] - velocity[c] * self.turn_at), velocity, ..self.tool }
    }
}

/// How one run steps: integrator, frame, sub-steps and (implicit_factored) PCG iterations.
#[derive(Clone, Copy)]
struct Stepping {
    integrator: IntegratorKind,
    dt: f64,
    substeps: Substeps,
    pcg_iterations: u32,
    multirate: Option<MultirateSettings>,
}

impl Stepping {
    /// One fixed step of `h` per frame.
    fn fixed(integrator: IntegratorKind, h: f64) -> Self {
        Stepping { integrator, dt: h, substeps: Substeps::Fixed(1), pcg_iterations: 1, multirate: None }
    }
}

/// Runs `t_end` seconds in frames of `dt` (a whole number of them, even with a press);
/// returns the final positions, wall time per simulated second and sub-steps per frame.
fn run<T: Real>(
    model: &Model,
    effects: &Effects,
    stepping: Stepping,
    t_end: f64,
    press: Option<Press>,
) -> Result<(Vec<[f64; 3]>, f64, u32), SimulationBuildError> {
    let Stepping { integrator, dt, substeps, pcg_iterations, multirate } = stepping;
    let params = IntegrationParameters {
        dt,
        integrator,
        substeps,
        factored_iterations: pcg_iterations,
        cg_tolerance: if T::NAME == "f64" { 1e-10 } else { 1e-6 },
        cg_max_iterations: 1000,
        multirate,
        ..IntegrationParameters::default()
    };
    let mut effects = effects.clone();
    effects.tool = press.map(|p| p.tool);
    let mut sim = Simulation::<T>::new(model, params, effects)?;
    let steps = (t_end / dt).round().max(1.0) as usize;
    let start = Instant::now();
    for k in 0..steps {
        if let Some(p) = press.filter(|_| 2 * k == steps) {
            sim.effects_mut().tool = Some(p.released());
        }
        sim.step();
    }
    let wall = start.elapsed().as_secs_f64();
    let x = (0..model.nodes.len()).map(|i| sim.state().x.get_f64(i)).collect();
    Ok((x, wall / (steps as f64 * dt), sim.substeps()))
}

/// The press and release integrated by the adaptive reference at `tolerance`.
fn reference_run(
    model: &Model,
    effects: &Effects,
    press: Press,
    t_end: f64,
    tolerance: f64,
    h0: f64,
) -> Result<(Vec<[f64; 3]>, u64), ReferenceError> {
    let mut effects = effects.clone();
    effects.tool = Some(press.tool);
    let params = IntegrationParameters { integrator: IntegratorKind::Rk4, ..IntegrationParameters::default() };
    let mut sim = Simulation::<f64>::new(model, params, effects).expect("study models are valid");
    let mut reference = Reference::new(&sim, tolerance, 1e-3, 0.1, h0);
    reference.advance_to(&mut sim, press.turn_at)?;
    sim.effects_mut().tool = Some(press.released());
    reference.advance_to(&mut sim, t_end)?;
    Ok((reference.positions(), reference.accepted))
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
/// guard and bone motion off, over `t_end` seconds rounded to whole 2 ms). `quick` tries
/// fewer steps.
pub fn accuracy_study(
    case: AccuracyCase,
    model: &Model,
    effects: &Effects,
    t_end: f64,
    quick: bool,
) -> Result<AccuracyStudy, ReferenceError> {
    let (model, effects, t_end) = match case {
        AccuracyCase::SingleSpring => {
            (spring_model(), Effects { bone: true, spring_damping: true, ..Effects::default() }, 0.5)
        }
        AccuracyCase::HangingChain => (
            chain_model(),
            Effects { bone: true, gravity: Some([0.0, -9.81, 0.0]), viscous_damping: Some(20.0), ..Effects::default() },
            2.0,
        ),
        AccuracyCase::Model => {
            let effects = Effects { guard: None, bone_motion: None, ..effects.clone() };
            (model.clone(), effects, (t_end / 0.002).round().max(1.0) * 0.002)
        }
    };
    let critical = Simulation::<f64>::new(&model, IntegrationParameters::default(), effects.clone())
        .expect("study models are valid")
        .stability()
        .critical_step(IntegratorKind::SymplecticEuler);
    let press = (case == AccuracyCase::Model).then(|| Press::over(&model, &effects, t_end));
    let scale = model.nodes.position.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()));
    let round_off = 1e3 * f64::EPSILON * scale;
    let (reference, summary) = if let Some(press) = press {
        let h0 = 0.5 * critical;
        let (coarse, _) = reference_run(&model, &effects, press, t_end, 100.0 * REFERENCE_TOLERANCE, h0)?;
        let (fine, steps) = reference_run(&model, &effects, press, t_end, REFERENCE_TOLERANCE, h0)?;
        let estimate = max_distance(&coarse, &fine);
        let summary = ReferenceSummary {
            method: "adaptive Dormand-Prince 5(4), f64",
            error_estimate_m: estimate,
            floor_m: (10.0 * estimate).max(round_off),
            steps,
        };
        (fine, summary)
    } else if case == AccuracyCase::SingleSpring {
        let mut r = model.nodes.position.clone();
        r[1][0] = 0.05 + spring_exact(t_end);
        (r, ReferenceSummary { method: "closed form", error_estimate_m: 0.0, floor_m: round_off, steps: 0 })
    } else {
        (
            chain_static().iter().map(|&y| [0.0, y, 0.0]).collect(),
            ReferenceSummary { method: "analytic static sag", error_estimate_m: 0.0, floor_m: round_off, steps: 0 },
        )
    };
    let floor = summary.floor_m;
    let mut rows = Vec::new();
    for integrator in IntegratorKind::ALL {
        let mut previous: Option<(f64, f64)> = None;
        for factor in step_factors(integrator, quick) {
            // A whole, even number of steps ends every run exactly at t_end and turns the
            // press exactly at its middle.
            let n = ((t_end / (critical * factor)) / 2.0).round().max(2.0) * 2.0;
            let h = t_end / n;
            if previous.is_some_and(|(h0, _)| h0 == h) {
                continue;
            }
            let stepping = Stepping::fixed(integrator, h);
            let (x, cost64, _) = run::<f64>(&model, &effects, stepping, t_end, press).expect(VALID);
            let error = max_distance(&x, &reference);
            let cost = if case == AccuracyCase::Model {
                run::<f32>(&model, &effects, stepping, t_end, press).expect(VALID).1
            } else {
                cost64
            };
            let at_floor = error.is_finite() && error < floor;
            // The chain's error is the static sag after settling: it has no order in the step.
            let observed = previous.filter(|_| case != AccuracyCase::HangingChain && !at_floor).and_then(|(h0, e0)| {
                (e0.is_finite() && error.is_finite() && e0 >= floor).then(|| (e0 / error).ln() / (h0 / h).ln())
            });
            rows.push(AccuracyRow {
                case,
                integrator: integrator.name(),
                step_s: h,
                realtime_substeps: None,
                pcg_iterations: (integrator == IntegratorKind::ImplicitFactored).then_some(1),
                step_over_critical: h / critical,
                error_m: error,
                cost_s_per_s: cost,
                observed_order: observed,
                at_floor,
                theoretical_order: integrator.order(),
            });
            previous = Some((h, error));
        }
    }
    if case == AccuracyCase::Model {
        // As the real-time loop runs them: 1 ms frames, sub-steps as the critical step asks;
        // the real-time implicit step with 1 to 8 PCG iterations.
        let configurations = IntegratorKind::ALL.into_iter().flat_map(|k| {
            let iterations: &[u32] = if k == IntegratorKind::ImplicitFactored { &[1, 2, 4, 8] } else { &[1] };
            iterations.iter().map(move |&i| (k, i))
        });
        for (integrator, iterations) in configurations {
            let stepping = Stepping {
                integrator,
                dt: 1e-3,
                substeps: Substeps::Auto,
                pcg_iterations: iterations,
                multirate: None,
            };
            let (x, _, substeps) = run::<f64>(&model, &effects, stepping, t_end, press).expect(VALID);
            let error = max_distance(&x, &reference);
            let cost = run::<f32>(&model, &effects, stepping, t_end, press).expect(VALID).1;
            let h = 1e-3 / f64::from(substeps);
            rows.push(AccuracyRow {
                case,
                integrator: integrator.name(),
                step_s: h,
                realtime_substeps: Some(substeps),
                pcg_iterations: (integrator == IntegratorKind::ImplicitFactored).then_some(iterations),
                step_over_critical: h / critical,
                error_m: error,
                cost_s_per_s: cost,
                observed_order: None,
                at_floor: error.is_finite() && error < floor,
                theoretical_order: integrator.order(),
            });
        }
        // Multirate stepping as `lamina run` runs it: the region about the press every 1 ms
        // frame, the whole model every 8, both with 2 PCG iterations. Models too coarse for a
        // region of this radius (no node a spring inside its edge) get no row.
        let multirate = MultirateSettings {
            centre: press.map_or([0.0; 3], |p| p.tool.start),
            late_build: LateBuild::Wait,
            ..MultirateSettings::default()
        };
        let integrator = IntegratorKind::ImplicitFactored;
        let stepping =
            Stepping { integrator, dt: 1e-3, substeps: Substeps::Auto, pcg_iterations: 2, multirate: Some(multirate) };
        let runs = press.and_then(|_| {
            let (x, _, _) = run::<f64>(&model, &effects, stepping, t_end, press).ok()?;
            Some((x, run::<f32>(&model, &effects, stepping, t_end, press).ok()?.1))
        });
        if let Some((x, cost)) = runs {
            let error = max_distance(&x, &reference);
            rows.push(AccuracyRow {
                case,
                integrator: "multirate (1 ms region, 8 ms bulk)",
                step_s: 1e-3,
                realtime_substeps: Some(1),
                pcg_iterations: Some(2),
                step_over_critical: 1e-3 / critical,
                error_m: error,
                cost_s_per_s: cost,
                observed_order: None,
                at_floor: error.is_finite() && error < floor,
                theoretical_order: 1,
            });
        }
    }
    Ok(AccuracyStudy { rows, reference: summary })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_matches_the_damped_spring_closed_form_works() {
        // The adaptive reference on the one-spring model against its closed form: an
        // independent check of the reference itself.
        let model = spring_model();
        let effects = Effects { bone: true, spring_damping: true, ..Effects::default() };
        let params = IntegrationParameters::default();
        let mut sim = Simulation::<f64>::new(&model, params, effects).unwrap();
        let mut reference = Reference::new(&sim, 1e-10, 1e-3, 0.1, 1e-4);
        reference.advance_to(&mut sim, 0.5).unwrap();
        let x = reference.positions()[1][0];
        let exact = 0.05 + spring_exact(0.5);
        assert!((x - exact).abs() < 1e-11, "reference {x}, closed form {exact}");
        assert!(reference.accepted > 10 && reference.time() == 0.5);
    }

    #[test]
    fn press_turns_back_where_it_went_down_works() {
        let model = spring_model();
        let press = Press::over(&model, &Effects::default(), 0.1);
        let (down, up) = (press.tool, press.released());
        let turn = down.centre(0.05);
        assert!((turn[1] - (0.012 - PRESS_DEPTH_M)).abs() < 1e-15, "{turn:?}");
        assert_eq!(up.centre(0.05), turn);
        assert!((up.centre(0.1)[1] - 0.012).abs() < 1e-15);
    }
}
