//! The paper's fitting extended to the living limb: after each layer's springs are fitted to
//! its tensile curve ([`super::fit_layers`]), simulated annealing fits what tension cannot
//! see, how fat and muscle resist being *pressed*, to in-vivo indentation
//! ([`IndentationTargets`]), measured by a virtual indentation experiment on the scene's own
//! limb (as the tensile fit measures a virtual tensile test).
//!
//! # How it works
//! 1. The scene's model is generated once with the tensile-fitted springs.
//! 2. A candidate is two ratios: fat's compression stiffness over its tension stiffness, and
//!    muscle's over its first-phase stiffness. Tension is left as the tensile fit made it.
//! 3. Each candidate's model gets the scene's `[in_vivo]` settings (skin pre-tension, muscle
//!    tone) and is settled, then pressed by the scene's sphere at [`FIT_SITES`] sites around
//!    the limb ([`crate::study::indentation_of_model`]); ψ is the mean over the sites.
//! 4. ψ = w_band · b(F)² + w_stiffening · max(0, ln(1.05 · r_min / r))² + w_centre · ln(F / F_c)²,
//!    with F the force at the band's depth, b(F) how far F lies outside the band in log terms
//!    (0 inside), F_c the geometric centre of the band, r the secant ratio and r_min the
//!    band's (aimed 5 % past, [`STIFFENING_MARGIN`], so the fitted limb meets it at every
//!    site): outside the band or short of the stiffening costs the most, and among
//!    candidates that meet both the one nearest the band's centre wins. The weights are
//!    [`INDENTATION_WEIGHTS`].
//! 5. [`super::anneal()`] with the caller's settings, in log space.

use super::anneal::{AnnealSettings, AnnealStep, anneal};
use super::indentation_targets::{BandCheck, IndentationTargets};
use crate::law::{Bilinear, SpringLaw};
use crate::model::{Model, Tissue};
use crate::scene::{Scene, SceneLoadError, SceneSprings, fat_material};
use crate::study::{IndentationCurve, IndentationError, indentation_of_model};

/// Weights of ψ: (force outside the band, stiffening short of the band's, force off the
/// band's centre). Falling short of the stiffening costs ten times as much as lying outside
/// the band by the same factor (the band is wide, the stiffening a floor); the pull to the
/// centre only ranks candidates that meet both.
pub const INDENTATION_WEIGHTS: (f64, f64, f64) = (1.0, 10.0, 1e-4);

/// Sites pressed per candidate, spread around the limb at mid-length.
pub const FIT_SITES: usize = 3;

/// The stiffening the fit aims for, as a factor of the band's floor.
pub const STIFFENING_MARGIN: f64 = 1.05;

/// Search box of fat's compression-to-tension ratio, unitless.
pub const FAT_COMPRESSION_RATIO_RANGE: (f64, f64) = (1.0, 10_000.0);

/// Search box of muscle's compression-to-first-phase ratio, unitless.
pub const MUSCLE_COMPRESSION_RATIO_RANGE: (f64, f64) = (1.0, 100.0);

/// Why the fit could not run.
#[derive(Debug, thiserror::Error)]
pub enum IndentationFitError {
    /// The scene's model could not be built.
    #[error(transparent)]
    Scene(#[from] SceneLoadError),
    /// The scene's model has no fat layer to fit.
    #[error("the scene's model has no fat layer")]
    NoFat,
    /// The scene is not a generated limb whose springs a scene file can carry.
    #[error("the scene is not a generated limb (cylinder_limb or anatomy): its springs cannot be written back")]
    NotGenerated,
    /// Pressing the best candidate failed.
    #[error(transparent)]
    Indentation(#[from] IndentationError),
}

/// The outcome of [`fit_indentation`].
#[derive(Clone, Debug)]
pub struct IndentationFit {
    /// The springs: the tensile fit's, with fat's and muscle's compression fitted.
    pub springs: SceneSprings,
    /// Fat's compression-to-tension ratio found.
    pub fat_compression_ratio: f64,
    /// Muscle's compression-to-first-phase ratio found.
    pub muscle_compression_ratio: f64,
    /// The best candidate's force-depth curve at each site.
    pub curves: Vec<IndentationCurve>,
    /// The best candidate against the band, per site.
    pub checks: Vec<Option<BandCheck>>,
    /// ψ at the best candidate.
    pub psi: f64,
    /// Every evaluation, in order.
    pub steps: Vec<AnnealStep>,
}

/// Deepest press of the virtual indentation, mm: the band's depth rounded up.
fn press_depth_mm(targets: &IndentationTargets) -> u32 {
    (targets.band.depth_m * 1e3).ceil() as u32
}

/// `model`'s fat and muscle springs with compression stiffness `ratio ×` their tension
/// stiffness (fat: its linear k; muscle: its first-phase k1).
pub fn with_compression_ratios(model: &Model, fat_ratio: f64, muscle_ratio: f64) -> Model {
    let mut m = model.clone();
    for i in 0..m.springs.len() {
        let rest = m.springs.rest_length[i];
        let tissue = m.layers[m.springs.layer[i] as usize].tissue;
        let law = m.springs.law[i];
        m.springs.law[i] = match (tissue, law) {
            (Tissue::Fat, SpringLaw::Linear { stiffness: k }) => fat_material(k, Some(fat_ratio * k)).law(rest),
            (Tissue::Fat, SpringLaw::Bilinear(b)) => {
                SpringLaw::Bilinear(Bilinear { k1: b.k1, k2: b.k1, turn_length: rest, k_compression: fat_ratio * b.k1 })
            }
            (Tissue::Muscle, SpringLaw::Bilinear(b)) => {
                SpringLaw::Bilinear(Bilinear { k_compression: muscle_ratio * b.k1, ..b })
            }
            (Tissue::Muscle, SpringLaw::Linear { stiffness: k }) => {
                SpringLaw::Bilinear(Bilinear { k1: k, k2: k, turn_length: rest, k_compression: muscle_ratio * k })
            }
            (_, law) => law,
        };
    }
    m
}

/// Presses the candidate `(fat_ratio, muscle_ratio)` of `generated` (the scene's model as
/// generated) with the scene's in-vivo settings at `sites` sites.
///
/// # Errors
/// A candidate that does not settle or press.
pub fn press_candidate(
    scene: &Scene,
    generated: &Model,
    fat_ratio: f64,
    muscle_ratio: f64,
    sites: usize,
    depth_mm: u32,
) -> Result<Vec<IndentationCurve>, IndentationFitError> {
    let mut m = with_compression_ratios(generated, fat_ratio, muscle_ratio);
    scene.in_vivo.apply(&mut m, scene.effects.skin_volume).map_err(|e| {
        IndentationFitError::Scene(SceneLoadError::Model {
            path: scene.path.clone().unwrap_or_default(),
            message: e.to_string(),
        })
    })?;
    let (_, curves) = indentation_of_model(scene, &m, sites, depth_mm)?;
    Ok(curves)
}

/// ψ of a pressed curve against the targets ([`INDENTATION_WEIGHTS`]); infinite when the
/// curve does not reach the band's depth or has a non-positive force.
pub fn indentation_psi(targets: &IndentationTargets, curve: &IndentationCurve) -> f64 {
    let band = &targets.band;
    let Some(c) = band.check(&curve.depth_m, &curve.force_n) else { return f64::INFINITY };
    if !(c.force_n > 0.0 && c.secant_ratio > 0.0) {
        return f64::INFINITY;
    }
    let centre = (band.force_min_n * band.force_max_n).sqrt();
    let (w_band, w_stiffening, w_centre) = INDENTATION_WEIGHTS;
    let outside = (band.force_min_n / c.force_n).ln().max(0.0) + (c.force_n / band.force_max_n).ln().max(0.0);
    let shortfall = (STIFFENING_MARGIN * band.min_secant_ratio / c.secant_ratio).ln().max(0.0);
    w_band * outside * outside + w_stiffening * shortfall * shortfall + w_centre * (c.force_n / centre).ln().powi(2)
}

/// Fits fat's and muscle's compression stiffness of `scene` (whose springs are `tensile`, the
/// tensile fit's) to `targets`, calling `on_step` after every evaluation.
///
/// # Errors
/// A scene that is not a generated limb, has no fat, or whose best candidate does not press.
pub fn fit_indentation(
    scene: &Scene,
    tensile: SceneSprings,
    targets: &IndentationTargets,
    settings: &AnnealSettings,
    mut on_step: impl FnMut(&AnnealStep),
) -> Result<IndentationFit, IndentationFitError> {
    let mut base = scene.clone();
    match &mut base.model {
        crate::scene::ModelSource::CylinderLimb { springs, .. } => *springs = Some(tensile),
        crate::scene::ModelSource::Anatomy(spec) => spec.materials = tensile.materials(),
        _ => return Err(IndentationFitError::NotGenerated),
    }
    let generated = base.build_generated_model()?;
    if !generated.layers.iter().any(|l| l.tissue == Tissue::Fat) {
        return Err(IndentationFitError::NoFat);
    }
    let depth = press_depth_mm(targets);
    let mean_psi = |curves: &[IndentationCurve]| {
        curves.iter().map(|c| indentation_psi(targets, c)).sum::<f64>() / curves.len().max(1) as f64
    };
    let psi = |p: &[f64]| match press_candidate(&base, &generated, p[0], p[1], FIT_SITES, depth) {
        Ok(curves) => mean_psi(&curves),
        Err(_) => f64::INFINITY,
    };
    let lower = [FAT_COMPRESSION_RATIO_RANGE.0, MUSCLE_COMPRESSION_RATIO_RANGE.0];
    let upper = [FAT_COMPRESSION_RATIO_RANGE.1, MUSCLE_COMPRESSION_RATIO_RANGE.1];
    let result = anneal(&[300.0, 3.0], &lower, &upper, settings, psi, |s| on_step(s));
    let (fat_ratio, muscle_ratio) = (result.best[0], result.best[1]);
    let curves = press_candidate(&base, &generated, fat_ratio, muscle_ratio, FIT_SITES, depth)?;
    let fat_k = match tensile.fat {
        crate::generator::SpringMaterial::Linear { stiffness } => stiffness,
        crate::generator::SpringMaterial::Bilinear { k1, .. } => k1,
    };
    let muscle = match tensile.muscle {
        crate::generator::SpringMaterial::Bilinear { k1, k2, turn_strain, .. } => {
            crate::generator::SpringMaterial::Bilinear { k1, k2, turn_strain, k_compression: muscle_ratio * k1 }
        }
        linear => linear,
    };
    Ok(IndentationFit {
        springs: SceneSprings { fat: fat_material(fat_k, Some(fat_ratio * fat_k)), muscle, ..tensile },
        fat_compression_ratio: fat_ratio,
        muscle_compression_ratio: muscle_ratio,
        checks: curves.iter().map(|c| targets.band.check(&c.depth_m, &c.force_n)).collect(),
        psi: mean_psi(&curves),
        curves,
        steps: result.history,
    })
}
