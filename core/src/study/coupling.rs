//! Where multirate stepping follows the single-rate solver on a hard case: the region's radius
//! and the bulk's ratio swept, each run beside single-rate `implicit_factored` on the same case.
//!
//! The region and the bulk exchange states every `ratio` ticks, and the region's ring holds the
//! bulk's state between exchanges; where the skin is far stiffer than the fat under it and the
//! region's edge cuts it, the exchange can keep the two halves apart. This sweep shows where.

use super::energy::mechanical_energy;
use super::stability::{StabilityCase, multirate_settings};
use crate::generator::vec3::distance;
use crate::solver::{IntegrationParameters, IntegratorKind, MultirateSettings, Simulation};
use serde::Serialize;

/// One radius and ratio of [`coupling_sweep`].
#[derive(Clone, Debug, Serialize)]
pub struct CouplingRow {
    /// Case name.
    pub case: &'static str,
    /// Region radius, m.
    pub radius_m: f64,
    /// Ticks per bulk step.
    pub ratio: u32,
    /// Over the second half of the run: the largest distance of a node from where single-rate
    /// `implicit_factored` has it, m.
    pub late_deviation_m: f64,
    /// Over the second half of the run: the largest coupling gap the multirate run reported
    /// ([`MultirateStatus::coupling_gap_m`](crate::solver::MultirateStatus::coupling_gap_m)),
    /// m: what a run without a single-rate run beside it sees of the deviation.
    pub late_coupling_gap_m: f64,
    /// Over the second half of the run: the largest kinetic energy of the multirate run, J.
    pub late_kinetic_j: f64,
    /// The same for the single-rate run, J.
    pub single_late_kinetic_j: f64,
    /// The single-rate run's largest node displacement from rest, m (the deviation's scale).
    pub single_max_displacement_m: f64,
}

/// Runs `case` for `seconds` with single-rate `implicit_factored` and, beside it, with
/// multirate stepping at every `radii` × `ratios` (the region about the block's top centre,
/// [`multirate_settings`]), in `f32`. Settings whose region cannot be built are left out.
pub fn coupling_sweep(case: &StabilityCase, radii: &[f64], ratios: &[u32], seconds: f64) -> Vec<CouplingRow> {
    let (model, params, effects) = case.setup(IntegratorKind::ImplicitFactored);
    let mut single = Simulation::<f32>::new(&model, params.clone(), effects.clone()).expect("hard cases are valid");
    let mut runs: Vec<(f64, u32, Simulation<f32>)> = Vec::new();
    for &radius in radii {
        for &ratio in ratios {
            let settings = MultirateSettings { radius, ratio, ..multirate_settings(&model) };
            let p = IntegrationParameters { multirate: Some(settings), ..params.clone() };
            if let Ok(sim) = Simulation::<f32>::new(&model, p, effects.clone()) {
                runs.push((radius, ratio, sim));
            }
        }
    }
    let frames = (seconds / params.dt).round() as usize;
    let mut deviation = vec![0.0f64; runs.len()];
    let mut kinetic = vec![0.0f64; runs.len()];
    let mut gap = vec![0.0f64; runs.len()];
    let (mut single_kinetic, mut single_displacement) = (0.0f64, 0.0f64);
    for frame in 0..frames {
        single.step();
        let xs = &single.state().x;
        for i in 0..model.nodes.len() {
            single_displacement = single_displacement.max(distance(xs.get_f64(i), model.nodes.position[i]));
        }
        let late = frame >= frames / 2;
        if late {
            single_kinetic = single_kinetic.max(mechanical_energy(&model, &single).kinetic);
        }
        for (k, (_, _, sim)) in runs.iter_mut().enumerate() {
            sim.step();
            if late {
                kinetic[k] = kinetic[k].max(mechanical_energy(&model, sim).kinetic);
                gap[k] = gap[k].max(sim.multirate_status().map_or(0.0, |m| m.coupling_gap_m));
                let x = &sim.state().x;
                for i in 0..model.nodes.len() {
                    deviation[k] = deviation[k].max(distance(x.get_f64(i), xs.get_f64(i)));
                }
            }
        }
    }
    runs.iter()
        .enumerate()
        .map(|(k, &(radius_m, ratio, _))| CouplingRow {
            case: case.name,
            radius_m,
            ratio,
            late_deviation_m: deviation[k],
            late_coupling_gap_m: gap[k],
            late_kinetic_j: kinetic[k],
            single_late_kinetic_j: single_kinetic,
            single_max_displacement_m: single_displacement,
        })
        .collect()
}
