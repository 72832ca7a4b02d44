//! The incision study: a 5 cm cut through skin and fat along the top of a living limb, drawn
//! by the scalpel at the core's tick as a hand would, and how the wound gapes.
//!
//! The blade enters point-first 2 mm above the skin at mid-length, goes down to its depth,
//! is drawn along the limb's axis, comes out, and the limb settles. The wound's opening is
//! measured on the outer skin: each cut spring between two outer-skin nodes, its length
//! after the settling less its length before the incision. Pre-strained skin (the scene's
//! `[in_vivo] skin_prestrain`) pulls the edges apart; without pre-strain the wound stays shut.
//!
//! The closed form it is set against: a straight cut of length `L` in a sheet under
//! equi-biaxial pre-strain `ε` opens at its middle by `δ = 4 σ a / E = 2 L ε / (1 − ν)`
//! (Griffith's crack in plane stress, `a = L/2`, `σ = E ε / (1 − ν)`), `2 L ε` to `3 L ε` for
//! `ν` from 0 to 1/3. The skin of the limb is held by the fat beneath and its settled
//! pre-strain is below the one asked, so the closed form is an upper bound.

use crate::hand_tool::HandTool;
use crate::incision::{Blade, BladeState, EdgeInTissue, Scalpel, ScalpelSettings};
use crate::model::{Model, Tissue};
use crate::scene::Scene;
use crate::solver::{CutError, FactorSwap, MultirateStatus, RefactorStatus, Simulation, SimulationBuildError};

/// Ticks after a cut at which the study takes the factor of the cut model (waiting for it if
/// need be, so the study gives the same bits run to run).
pub const INCISION_FACTOR_TICKS: u32 = 20;
use std::time::Instant;

/// The cut the study draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IncisionCase {
    /// Length of the cut along the limb, m. Default 0.05.
    pub length_m: f64,
    /// Depth of the tip below the outer skin, m. Default 0.008 (the 2 mm skin and 6 mm of the
    /// 8 mm fat of the shipped limbs).
    pub depth_m: f64,
    /// Speed of the blade, m/s. Default 0.02.
    pub speed_m_s: f64,
    /// Time the limb settles before and after the cut, s. Default 0.5.
    pub settle_s: f64,
}

impl Default for IncisionCase {
    fn default() -> Self {
        Self { length_m: 0.05, depth_m: 0.008, speed_m_s: 0.02, settle_s: 0.5 }
    }
}

/// What the study measured.
#[derive(Clone, Debug, PartialEq)]
pub struct IncisionResult {
    /// Springs cut per tissue: skin, fat, muscle.
    pub springs_cut: [u64; 3],
    /// Deepest edge length in each tissue while cutting, m.
    pub deepest: EdgeInTissue,
    /// Largest cutting force on the blade, N.
    pub peak_cutting_force: f64,
    /// Largest press force before the skin gave, N.
    pub peak_press_force: f64,
    /// Times the skin gave.
    pub punctures: u64,
    /// Distance the tip travelled while cutting, m.
    pub cut_length_m: f64,
    /// Per cut outer-skin spring: its midpoint's position along the axis (m) and how much
    /// longer it is after the settling than before the incision (m).
    pub gaps: Vec<(f64, f64)>,
    /// The skin pre-strain the scene asked for (unitless).
    pub skin_prestrain: f64,
    /// The closed form's opening at the middle for `ν` = 0 and 1/3, m.
    pub closed_form_gap_m: (f64, f64),
    /// Mean relative PCG residual per tick: before the first cut, after a cut with a factor
    /// that lacks it, and with the factor of the model as cut.
    pub residuals: (f64, f64, f64),
    /// The off-loop factor builds (taken [`INCISION_FACTOR_TICKS`] ticks after each ask);
    /// single-rate only.
    pub refactor: RefactorStatus,
    /// With multirate stepping, the coupling at the end: its regions built again after cuts
    /// ([`MultirateStatus::cuts_in_factor`]) and about the moving tip.
    pub multirate: Option<MultirateStatus>,
    /// Compute time per tick of the ticks that cut and of the others, s (for the printout:
    /// the study's own loop, not a pinned real-time one).
    pub tick_seconds_cutting: Vec<f64>,
    /// Compute time per tick of the ticks that neither cut nor took a factor, s.
    pub tick_seconds_other: Vec<f64>,
    /// Time of the ticks that took a factor of the cut model, s (waiting for its build).
    pub tick_seconds_taking: Vec<f64>,
    /// Every node's final position, bit for bit (the study is deterministic).
    pub final_positions: Vec<[f64; 3]>,
    /// Whether every published state was finite.
    pub finite: bool,
}

impl IncisionResult {
    /// The widest opening, m (0 with no cut outer-skin spring).
    pub fn max_gap(&self) -> f64 {
        self.gaps.iter().map(|g| g.1).fold(0.0, f64::max)
    }

    /// The mean opening over the cut outer-skin springs, m.
    pub fn mean_gap(&self) -> f64 {
        if self.gaps.is_empty() { 0.0 } else { self.gaps.iter().map(|g| g.1).sum::<f64>() / self.gaps.len() as f64 }
    }
}

/// Why the study cannot run on a scene.
#[derive(Debug, thiserror::Error)]
pub enum IncisionError {
    /// The scene has no haptic tool to become the blade.
    #[error("the scene has no [effects.tool] to become the scalpel")]
    NoTool,
    /// The model did not build.
    #[error("{0}")]
    Model(String),
    /// The simulation did not build.
    #[error(transparent)]
    Build(#[from] SimulationBuildError),
    /// The simulation cannot be cut.
    #[error(transparent)]
    Cut(#[from] CutError),
    /// The model has no outer skin to cut.
    #[error("the model has no skin_outer surface")]
    NoSkin,
}

/// Runs `case` on `scene`'s limb (its axis along z, its skin facing +y at mid-length), with
/// the scene's `[scalpel]` or the defaults.
///
/// # Errors
/// [`IncisionError`] when the scene cannot be cut.
pub fn incision_study(scene: &Scene, case: &IncisionCase) -> Result<IncisionResult, IncisionError> {
    let tool = scene.tool.ok_or(IncisionError::NoTool)?;
    let model = scene.build_model().map_err(|e| IncisionError::Model(e.to_string()))?;
    let settings = scene.scalpel.unwrap_or_default();
    let (mut sim, _) = HandTool::simulation::<f64>(&model, scene.solver.clone(), scene.effects.clone(), tool)?;
    let mut scalpel = Scalpel::new(&model, &sim, &tool, settings)?;
    sim.prepare_cutting(&model, FactorSwap::AfterTicks(INCISION_FACTOR_TICKS))?;
    run(&model, scene, &mut sim, &mut scalpel, &settings, case)
}

fn run(
    model: &Model,
    scene: &Scene,
    sim: &mut Simulation<f64>,
    scalpel: &mut Scalpel,
    settings: &ScalpelSettings,
    case: &IncisionCase,
) -> Result<IncisionResult, IncisionError> {
    let skin = model.surfaces.iter().find(|s| s.name == "skin_outer").ok_or(IncisionError::NoSkin)?;
    let mut on_skin = vec![false; model.nodes.len()];
    for &i in skin.triangles.iter().flatten() {
        on_skin[i as usize] = true;
    }
    let dt = scene.solver.dt;
    let ticks = |s: f64| (s / dt).round().max(1.0) as usize;
    let mut finite = true;
    let mut step = |sim: &mut Simulation<f64>| {
        sim.step();
        let x = &sim.state().x;
        finite &= (0..x.len()).all(|i| x.get_f64(i).iter().all(|c| c.is_finite()));
    };
    for _ in 0..ticks(case.settle_s) {
        step(sim);
    }
    let before: Vec<[f64; 3]> = (0..sim.state().x.len()).map(|i| sim.state().x.get_f64(i)).collect();
    // Mid-length, half a grid column past the top so the edge runs between nodes.
    let z_mid = mid_length(model);
    let columns = skin.grid.as_ref().map_or(24, |g| (g.0 - 1).max(1));
    let angle = std::f64::consts::FRAC_PI_2 + std::f64::consts::PI / f64::from(columns);
    let radius = (0..model.nodes.len())
        .filter(|&i| on_skin[i] && (before[i][2] - z_mid).abs() < 0.5 * case.length_m)
        .map(|i| before[i][0].hypot(before[i][1]))
        .fold(0.0, f64::max);
    let turn = angle - std::f64::consts::FRAC_PI_2;
    let orientation = [0.0, 0.0, (0.5 * turn).sin(), (0.5 * turn).cos()];
    let blade_at =
        |r: f64, z: f64| Blade::from_pose([r * angle.cos(), r * angle.sin(), z], orientation, settings.blade_length);
    let (z0, z1) = (z_mid - 0.5 * case.length_m, z_mid + 0.5 * case.length_m);
    let (r_out, r_in) = (radius + 0.002, radius - case.depth_m);
    let mut path: Vec<(f64, f64)> = Vec::new();
    let mut leg = |from: (f64, f64), to: (f64, f64)| {
        let distance = (to.0 - from.0).hypot(to.1 - from.1);
        let n = ticks(distance / case.speed_m_s);
        path.extend((1..=n).map(|k| {
            let s = k as f64 / n as f64;
            (from.0 + s * (to.0 - from.0), from.1 + s * (to.1 - from.1))
        }));
    };
    leg((r_out, z0), (r_in, z0));
    leg((r_in, z0), (r_in, z1));
    leg((r_in, z1), (r_out, z1));
    let (mut res_before, mut res_old, mut res_new) = (Vec::new(), Vec::new(), Vec::new());
    let (mut cutting, mut other, mut taking) = (Vec::new(), Vec::new(), Vec::new());
    // Factors of the cut model taken so far, and the cuts the one in use holds: the off-loop
    // refactor's single-rate, the region's rebuilt about the tip with multirate.
    let factors = |sim: &Simulation<f64>| match (sim.refactor_status(), sim.multirate_status()) {
        (Some(r), _) => (r.taken, r.cuts_in_factor as u64),
        (None, Some(m)) => (m.recentres, m.cuts_in_factor as u64),
        (None, None) => (0, 0),
    };
    for &(r, z) in &path {
        let taken = factors(sim).0;
        let start = Instant::now();
        let tick = scalpel.move_to(sim, blade_at(r, z), dt);
        step(sim);
        let seconds = start.elapsed().as_secs_f64();
        let residual = sim.implicit_factored().map_or(0.0, |f| f.last_residual());
        let in_factor = factors(sim).1;
        match sim.cuts() {
            0 => res_before.push(residual),
            n if n > in_factor => res_old.push(residual),
            _ => res_new.push(residual),
        }
        if factors(sim).0 > taken {
            taking.push(seconds);
        } else if tick.springs_cut > 0 {
            cutting.push(seconds);
        } else {
            other.push(seconds);
        }
    }
    scalpel.lift(sim);
    for _ in 0..ticks(case.settle_s) {
        step(sim);
    }
    let x: Vec<[f64; 3]> = (0..sim.state().x.len()).map(|i| sim.state().x.get_f64(i)).collect();
    let length = |p: &[[f64; 3]], s: usize| {
        let (a, b) = (p[model.springs.a[s] as usize], p[model.springs.b[s] as usize]);
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let gaps = scalpel
        .cut_order()
        .iter()
        .map(|&s| s as usize)
        .filter(|&s| {
            let tissue = model.layers[model.springs.layer[s] as usize].tissue;
            tissue == Tissue::Skin && on_skin[model.springs.a[s] as usize] && on_skin[model.springs.b[s] as usize]
        })
        .map(|s| {
            let z = 0.5 * (before[model.springs.a[s] as usize][2] + before[model.springs.b[s] as usize][2]);
            (z, length(&x, s) - length(&before, s))
        })
        .collect();
    let mean = |v: &[f64]| if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 };
    let totals = scalpel.totals();
    let eps = scene.in_vivo.skin_prestrain;
    Ok(IncisionResult {
        springs_cut: totals.springs_cut,
        deepest: totals.deepest,
        peak_cutting_force: totals.peak_force,
        peak_press_force: totals.peak_press,
        punctures: totals.punctures,
        cut_length_m: totals.cut_length,
        gaps,
        skin_prestrain: eps,
        closed_form_gap_m: (2.0 * case.length_m * eps, 3.0 * case.length_m * eps),
        residuals: (mean(&res_before), mean(&res_old), mean(&res_new)),
        refactor: sim.refactor_status().unwrap_or_default(),
        multirate: sim.multirate_status(),
        tick_seconds_cutting: cutting,
        tick_seconds_other: other,
        tick_seconds_taking: taking,
        final_positions: x,
        finite: finite && scalpel.state() == BladeState::Outside,
    })
}

/// The middle of the model's extent along z, m.
fn mid_length(model: &Model) -> f64 {
    let (lo, hi) = model
        .nodes
        .position
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p[2]), hi.max(p[2])));
    0.5 * (lo + hi)
}
