//! Fitting one layer: the objective ψ = Σ wᵢ ((pᵢ − qᵢ)/qᵢ)² between the macroscopic values
//! `p` measured by the virtual tensile test (and the regression) and the tissue's targets
//! `q`, minimised by simulated annealing over the layer's spring parameters.

use super::anneal::{AnnealResult, AnnealSettings, AnnealStep, AnnealStop, anneal};
use super::regression::{bilinear_regression, line_fit};
use super::targets::{TargetLaw, TissueTargets};
use super::tensile::{Specimen, TensileCurve, tensile_test};
use crate::generator::SpringMaterial;

/// How a layer is fitted, with the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitSettings {
    /// The annealing schedule.
    pub anneal: AnnealSettings,
    /// Load steps of each tensile test. Default 24.
    pub loads: usize,
    /// Annealing runs at most: a run that freezes above `psi_stop` is followed by another
    /// from the best point so far (reheated to `T0` of that point, next seed), unless that
    /// reheated run lowered the best ψ by less than 1 %. Default 4.
    pub restarts: usize,
    /// Correction steps from the first guess and after each annealing run: every parameter
    /// scaled by (target / achieved)^γ of the value it mostly sets, γ = 0.8 halved whenever
    /// a step does not improve ψ. Default 8.
    pub polish_steps: usize,
    /// Slab nodes along the pull. Default 6.
    pub slab_nx: usize,
    /// Slab nodes across. Default 3.
    pub slab_nz: usize,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self { anneal: AnnealSettings::default(), loads: 24, slab_nx: 6, slab_nz: 3, restarts: 4, polish_steps: 8 }
    }
}

impl FitSettings {
    /// Most evaluations of ψ one layer's fit can take: the moduli's search (correction steps
    /// from the first guess, then up to `restarts` annealing runs of at most
    /// `max_evaluations + 1` evaluations, each followed by correction steps) and, when that
    /// does not converge, the strains' search (up to `restarts` annealing runs). Most fits stop
    /// far sooner: ψ below the stop, or a reheated run gaining under 1 %.
    ///
    /// ```
    /// use lamina_core::fit::FitSettings;
    /// // 8 x 5 correction steps and 2 x 4 runs of 1,501 evaluations.
    /// assert_eq!(FitSettings::default().most_evaluations(), 12_048);
    /// ```
    pub fn most_evaluations(&self) -> usize {
        let run = self.anneal.max_evaluations + 1;
        self.polish_steps * (1 + self.restarts) + 2 * self.restarts * run
    }
}

/// The layer's geometry in the model being fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerGeometry {
    /// Grid spacing of the layer's springs, m.
    pub spacing_m: f64,
    /// Layer thickness, m.
    pub thickness_m: f64,
}

/// One target and what the fitted layer achieves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Achieved {
    /// Target name (`initial_modulus_pa`, ...).
    pub name: &'static str,
    /// Target value.
    pub target: f64,
    /// Value measured on the fitted layer.
    pub achieved: f64,
}

impl Achieved {
    /// Relative error, (achieved − target) / target.
    pub fn error(&self) -> f64 {
        (self.achieved - self.target) / self.target
    }
}

/// One layer's fit.
#[derive(Clone, Debug)]
pub struct LayerFit {
    /// Tissue name.
    pub tissue: String,
    /// The fitted springs.
    pub material: SpringMaterial,
    /// Targets against what the fitted springs achieve.
    pub achieved: Vec<Achieved>,
    /// What the springs were fitted to.
    pub objective: FitObjective,
    /// The smallest ψ over the moduli reached ([`FitObjective::Moduli`]), whichever objective
    /// the springs were fitted to.
    pub moduli_psi: f64,
    /// The fitted springs' value of their objective: ψ over the moduli, or ψ_ε over the
    /// strains ([`strain_psi`]).
    pub psi: f64,
    /// The annealing run (every evaluation).
    pub anneal: AnnealResult,
    /// Tensile curve of every evaluation, in order (empty curves where the test failed).
    pub curves: Vec<TensileCurve>,
    /// Tensile curve of the fitted springs.
    pub best_curve: TensileCurve,
    /// Macroscopic modulus of the slab with unit (1 N/m) linear springs, Pa: the scale
    /// that seeds the search.
    pub unit_modulus_pa: f64,
}

/// Why a layer could not be fitted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LayerFitError {
    /// The slab's tensile test failed with unit springs.
    #[error("tensile specimen: {0}")]
    Specimen(String),
    /// No parameters gave a usable curve.
    #[error("no parameters gave a usable tensile curve")]
    NoCurve,
}

/// The spring law of parameter vector `p` for `targets`' kind of layer.
pub fn material_of(targets: &TissueTargets, p: &[f64]) -> SpringMaterial {
    match targets.law {
        TargetLaw::Linear { .. } => SpringMaterial::Linear { stiffness: p[0] },
        TargetLaw::Bilinear { .. } => {
            SpringMaterial::Bilinear { k1: p[0], k2: p[1], turn_strain: p[2], k_compression: p[0] }
        }
    }
}

/// Macroscopic values of a tensile curve in `targets`' order (modulus; or initial modulus,
/// final modulus, turning strain).
pub fn macroscopic(targets: &TissueTargets, curve: &TensileCurve) -> Option<Vec<f64>> {
    match targets.law {
        TargetLaw::Linear { .. } => line_fit(&curve.strain, &curve.stress_pa).map(|l| vec![l.slope]),
        TargetLaw::Bilinear { .. } => bilinear_regression(&curve.strain, &curve.stress_pa)
            .map(|b| vec![b.initial_modulus, b.final_modulus, b.turn_strain]),
    }
}

/// A reheated annealing run must lower the best ψ by at least this fraction, or the search
/// under that objective ends.
const RUN_GAIN: f64 = 0.01;

/// What a layer's springs are fitted to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitObjective {
    /// The paper's: [`psi`] over the bilinear regression's moduli and turning strain of the
    /// slab's curve. Tried first for every layer.
    Moduli,
    /// [`strain_psi`]: the slab's strain under each load against the strain at which the
    /// tissue's law carries that load. Used when the moduli's ψ does not reach the stop
    /// (`psi_stop`): on cells a few times the layer's thickness the springs across it turn
    /// at other strains than those along the pull, the slab's knee is rounded, and the
    /// regression reads the knee's points as a first phase up to twice as stiff as the
    /// slab's (skin on the 96x24 limb: 5.7 mm cells, 2 mm thick).
    Strain,
}

impl FitObjective {
    /// Name in tables: `moduli` or `strain`.
    pub fn name(self) -> &'static str {
        match self {
            FitObjective::Moduli => "moduli",
            FitObjective::Strain => "strain",
        }
    }
}

/// ψ_ε = (1/n) Σᵢ ((εᵢ − εᵢ*)/εᵢ*)² over the `loads` loads of [`test_loads`]: εᵢ the strain the
/// slab reaches under load i, εᵢ* = i · max_strain / n the strain at which the tissue's law
/// carries it. Infinite for a curve without every load (a failed test).
///
/// ```
/// use lamina_core::fit::{TensileCurve, TissueTargets, strain_psi};
/// let text = "name = \"fat\"\nlaw = \"linear\"\nmodulus_pa = 1.6e3\nmax_strain = 0.3\n\
///             [sources]\nmodulus_pa = \"a source\"\n";
/// let fat = TissueTargets::parse(text, "fat.toml".as_ref()).unwrap();
/// // Two loads, reached at strains 10 % above and 10 % below the tissue's 0.15 and 0.3.
/// let curve = TensileCurve { strain: vec![0.0, 0.165, 0.27], stress_pa: vec![0.0, 240.0, 480.0], ..TensileCurve::default() };
/// assert!((strain_psi(&fat, &curve, 2) - 0.01).abs() < 1e-12);
/// assert!(strain_psi(&fat, &curve, 3).is_infinite());
/// ```
pub fn strain_psi(targets: &TissueTargets, curve: &TensileCurve, loads: usize) -> f64 {
    if loads == 0 || curve.strain.len() != loads + 1 {
        return f64::INFINITY;
    }
    let sum: f64 = (1..=loads)
        .map(|i| {
            let expected = targets.max_strain * i as f64 / loads as f64;
            ((curve.strain[i] - expected) / expected).powi(2)
        })
        .sum();
    let value = sum / loads as f64;
    if value.is_finite() { value } else { f64::INFINITY }
}

/// ψ = Σ wᵢ ((pᵢ − qᵢ)/qᵢ)²: relative errors, so moduli in Pa and strains weigh alike.
pub fn psi(targets: &TissueTargets, achieved: &[f64]) -> f64 {
    targets.values().iter().zip(achieved).zip(&targets.weights).map(|(((_, q), p), w)| w * ((p - q) / q).powi(2)).sum()
}

/// The loads of a layer's tensile test, Pa: the target curve's stress at `loads` equally
/// spaced strains up to `max_strain`, so both phases of a stiff bilinear tissue get points
/// (equal force steps would put none in skin's toe region: its two moduli differ 70-fold).
pub fn test_loads(targets: &TissueTargets, loads: usize) -> Vec<f64> {
    (1..=loads).map(|i| targets.stress_at(targets.max_strain * i as f64 / loads as f64)).collect()
}

/// The tensile test of `material` on `spec` for `targets`.
pub fn test_layer(
    targets: &TissueTargets,
    spec: &Specimen,
    material: &SpringMaterial,
    loads: usize,
) -> Result<TensileCurve, super::tensile::TensileTestError> {
    tensile_test(spec, material, &test_loads(targets, loads), 3.0 * targets.max_strain)
}

/// Fits the springs of a layer of `geometry` to `targets`; `on_step` sees every evaluation.
pub fn fit_layer(
    targets: &TissueTargets,
    geometry: LayerGeometry,
    settings: &FitSettings,
    mut on_step: impl FnMut(&AnnealStep),
) -> Result<LayerFit, LayerFitError> {
    let spec = Specimen::layer_slab(geometry.spacing_m, geometry.thickness_m, settings.slab_nx, settings.slab_nz);
    // Scale: the slab's modulus with unit linear springs at a small strain (about 1e-4).
    let probe_stress = 1e-4 * geometry.spacing_m * spec.pulled.len() as f64 / spec.area_m2;
    let unit = tensile_test(&spec, &SpringMaterial::Linear { stiffness: 1.0 }, &[probe_stress], 1.0)
        .map_err(|e| LayerFitError::Specimen(e.to_string()))?;
    let unit_modulus = unit.stress_pa[1] / unit.strain[1];
    let (x0, lower, upper): (Vec<f64>, Vec<f64>, Vec<f64>) = match targets.law {
        TargetLaw::Linear { modulus_pa } => {
            let k = modulus_pa / unit_modulus;
            (vec![k], vec![k / 30.0], vec![k * 30.0])
        }
        TargetLaw::Bilinear { initial_modulus_pa, final_modulus_pa, turn_strain } => {
            let (k1, k2) = (initial_modulus_pa / unit_modulus, final_modulus_pa / unit_modulus);
            (
                vec![k1, k2, turn_strain],
                vec![k1 / 30.0, k2 / 30.0, turn_strain / 5.0],
                vec![k1 * 30.0, k2 * 30.0, (turn_strain * 3.0).min(0.95 * targets.max_strain)],
            )
        }
    };
    let mut curves: Vec<TensileCurve> = Vec::new();
    let mut history: Vec<AnnealStep> = Vec::new();
    // The objective's value and the macroscopic values at `p`, keeping the curve.
    let evaluate = |p: &[f64], objective: FitObjective, curves: &mut Vec<TensileCurve>| -> (f64, Option<Vec<f64>>) {
        let curve = test_layer(targets, &spec, &material_of(targets, p), settings.loads).unwrap_or_default();
        let values = macroscopic(targets, &curve);
        let value = match objective {
            FitObjective::Moduli => values.as_ref().map_or(f64::INFINITY, |a| psi(targets, a)),
            FitObjective::Strain => strain_psi(targets, &curve, settings.loads),
        };
        curves.push(curve);
        (value, values)
    };
    // Correction steps: each parameter scaled by target / achieved of the value it mostly
    // sets (k1 the initial modulus, k2 the final one, TurnLen the turning strain).
    let polish = |start: Vec<f64>,
                  curves: &mut Vec<TensileCurve>,
                  history: &mut Vec<AnnealStep>,
                  on_step: &mut dyn FnMut(&AnnealStep)|
     -> Vec<f64> {
        let mut p = start;
        let mut best: (f64, Vec<f64>, Option<Vec<f64>>) = (f64::INFINITY, p.clone(), None);
        // Damped: p ← p · (q / achieved)^gamma from the best point so far; gamma halves
        // whenever a step does not improve ψ.
        let mut gamma = 0.8;
        for _ in 0..settings.polish_steps {
            let (value, achieved) = evaluate(&p, FitObjective::Moduli, curves);
            let step = AnnealStep {
                evaluation: history.len(),
                temperature: 0.0,
                params: p.clone(),
                psi: value,
                accepted: true,
            };
            on_step(&step);
            history.push(step);
            if value < best.0 {
                best = (value, p.clone(), achieved);
            } else {
                gamma *= 0.5;
            }
            if best.0 < settings.anneal.psi_stop {
                break;
            }
            let Some(a) = &best.2 else { break };
            p = best
                .1
                .iter()
                .zip(targets.values())
                .zip(a)
                .enumerate()
                .map(|(i, ((v, (_, q)), got))| (v * (q / got).powf(gamma)).clamp(lower[i], upper[i]))
                .collect();
        }
        best.1
    };
    // Annealing runs from `start` under `objective` (each followed by correction steps for
    // the moduli), while ψ is above the stop; the best point of the runs, its ψ and why the
    // last run stopped.
    let mut search = |objective: FitObjective,
                      start: Vec<f64>,
                      curves: &mut Vec<TensileCurve>,
                      history: &mut Vec<AnnealStep>|
     -> (Vec<f64>, f64, AnnealStop) {
        let first = history.len();
        let mut best = start;
        if objective == FitObjective::Moduli {
            best = polish(best, curves, history, &mut on_step);
        }
        let best_of = |history: &[AnnealStep]| history[first..].iter().min_by(|a, b| a.psi.total_cmp(&b.psi)).cloned();
        let mut best_psi = best_of(history).map_or(f64::INFINITY, |h| h.psi);
        let mut stop = AnnealStop::Converged;
        for run in 0..settings.restarts {
            if best_psi < settings.anneal.psi_stop {
                break;
            }
            let anneal_settings =
                AnnealSettings { seed: settings.anneal.seed.wrapping_add(run as u64), ..settings.anneal };
            let offset = history.len();
            let this = anneal(
                &best,
                &lower,
                &upper,
                &anneal_settings,
                |p| evaluate(p, objective, curves).0,
                |step| {
                    let mut s = step.clone();
                    s.evaluation += offset;
                    on_step(&s);
                },
            );
            history.extend(this.history.into_iter().map(|mut s| {
                s.evaluation += offset;
                s
            }));
            stop = this.stop;
            best = this.best;
            if objective == FitObjective::Moduli {
                polish(best.clone(), curves, history, &mut on_step);
            }
            // The best point of every run and correction so far.
            let before = best_psi;
            if let Some(h) = best_of(history) {
                best = h.params;
                best_psi = h.psi;
            }
            if run > 0 && best_psi > (1.0 - RUN_GAIN) * before {
                // A reheated run that no longer improves ψ ends the search.
                break;
            }
        }
        if best_psi < settings.anneal.psi_stop {
            stop = AnnealStop::Converged;
        }
        (best, best_psi, stop)
    };
    // The paper's objective first. Correction steps from the scaled guess; while ψ is above
    // the stop, anneal from the best point (reheated, next seed), each run followed by
    // correction steps. Annealing first was tried: on skin it settles in a local minimum
    // (k1 ≈ 120 N/m, the regression's turning point one load too early) that the corrections
    // then cannot leave.
    let (mut best, mut best_psi, mut stop) = search(FitObjective::Moduli, x0.clone(), &mut curves, &mut history);
    let moduli_psi = best_psi;
    let mut objective = FitObjective::Moduli;
    if best_psi >= settings.anneal.psi_stop || best_psi.is_nan() {
        // The regression found no springs that give the tissue's moduli (a knee rounded by
        // springs turning at different strains reads as a stiffer first phase): fit the
        // strains under the loads instead, annealing from the scaled guess.
        objective = FitObjective::Strain;
        (best, best_psi, stop) = search(objective, x0, &mut curves, &mut history);
    }
    let result = AnnealResult { best, best_psi, history, stop };
    if !result.best_psi.is_finite() {
        return Err(LayerFitError::NoCurve);
    }
    let material = material_of(targets, &result.best);
    let best_curve = test_layer(targets, &spec, &material, settings.loads).map_err(|_| LayerFitError::NoCurve)?;
    let values = macroscopic(targets, &best_curve).ok_or(LayerFitError::NoCurve)?;
    let achieved = targets
        .values()
        .iter()
        .zip(&values)
        .map(|((name, target), achieved)| Achieved { name, target: *target, achieved: *achieved })
        .collect();
    Ok(LayerFit {
        tissue: targets.name.clone(),
        material,
        achieved,
        objective,
        moduli_psi,
        psi: result.best_psi,
        anneal: result,
        curves,
        best_curve,
        unit_modulus_pa: unit_modulus,
    })
}

impl LayerFit {
    /// Whether the annealing met its ψ target.
    pub fn converged(&self) -> bool {
        self.anneal.stop == AnnealStop::Converged
    }
}
