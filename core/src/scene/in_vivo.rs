//! The scene's `[in_vivo]` table: what a living limb has that excised tissue has not. The
//! skin's pre-tension and the muscle's tone, applied to the model when the scene builds it.
//!
//! ```toml
//! [in_vivo]
//! skin_prestrain = 0.05         # unitless: in-plane skin rest lengths 1/(1 + 0.05) of the geometry's
//! muscle_tone = "relaxed"       # or "active": muscle springs times active_muscle_factor
//! active_muscle_factor = 2.0    # unitless, default 2.0
//! ```
//!
//! 1. **Skin pre-tension.** Living skin is stretched over the body: excised, it retracts. Each
//!    in-plane skin spring (both ends on the outer skin surface, or both on the skin's inner
//!    face `skin_fat`) gets a rest length `L / (1 + skin_prestrain)`, so the generated
//!    geometry holds it at a strain of `skin_prestrain`. Flynn et al. 2011 (Ann Biomed Eng
//!    39:1935) identified in-vivo pre-stresses of 28-92 kPa in human skin; over skin's
//!    initial modulus of 1.18 MPa (Ní Annaidh et al. 2012, J Mech Behav Biomed Mater 5:139)
//!    that is a pre-strain of 0.024-0.078. Default 0 (no pre-tension).
//! 2. **Muscle tone.** Contracted muscle indents about twice as stiff as relaxed muscle
//!    (Zheng, Mak & Lue 1999, J Rehabil Res Dev 36:71, forearm). `"active"` multiplies every
//!    muscle spring's stiffnesses by `active_muscle_factor`. Default `"relaxed"`.
//! 3. **Settling.** A pre-strained skin is not in equilibrium on the generated geometry: it
//!    pulls inward on the fat. [`InVivo::apply`] solves the model to static equilibrium
//!    (implicit Euler steps of 1 s under strong viscous damping, bone held, skin volume as the
//!    scene has it) and writes the settled positions into the model, so the first tick starts
//!    at rest. The springs keep their pre-strained rest lengths: the skin stays in tension, and
//!    a cut through it opens.

use super::section::FieldError;
use crate::law::SpringLaw;
use crate::model::{Model, Tissue};
use crate::solver::{Effects, IntegrationParameters, IntegratorKind, Simulation, SimulationBuildError, Substeps};
use serde::Deserialize;

/// Largest skin pre-strain a scene may ask for (unitless): beyond it the skin's first
/// (toe) phase would be used up at rest.
pub const MAX_SKIN_PRESTRAIN: f64 = 0.25;

/// Largest muscle tone factor a scene may ask for (unitless).
pub const MAX_ACTIVE_MUSCLE_FACTOR: f64 = 10.0;

/// Relaxed or contracted muscle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MuscleTone {
    /// Passive muscle: the springs as fitted. The default.
    #[default]
    Relaxed,
    /// Contracted muscle: the springs times [`InVivo::active_muscle_factor`].
    Active,
}

/// The living limb's settings (`[in_vivo]`). Default: no pre-tension, relaxed muscle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InVivo {
    /// In-plane skin pre-strain, unitless, 0 to [`MAX_SKIN_PRESTRAIN`]. Default 0.
    pub skin_prestrain: f64,
    /// Muscle tone. Default relaxed.
    pub muscle_tone: MuscleTone,
    /// Stiffness factor of active over relaxed muscle, unitless, 1 to
    /// [`MAX_ACTIVE_MUSCLE_FACTOR`]. Default 2.
    pub active_muscle_factor: f64,
}

impl Default for InVivo {
    fn default() -> Self {
        Self { skin_prestrain: 0.0, muscle_tone: MuscleTone::Relaxed, active_muscle_factor: 2.0 }
    }
}

/// Why the in-vivo settings could not be applied to a model.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InVivoApplyError {
    /// A pre-strain was asked for and the model has no in-plane skin springs.
    #[error(
        "in_vivo.skin_prestrain: the model has no in-plane skin springs (no \"skin_outer\" surface over a skin layer)"
    )]
    NoSkin,
    /// The settling simulation could not be built.
    #[error("in_vivo: settling the pre-strained model: {0}")]
    Simulation(#[from] SimulationBuildError),
    /// The settling did not reach equilibrium.
    #[error(
        "in_vivo: the pre-strained model did not settle in {steps} steps (last step moved a node {moved_mm:.3e} mm)"
    )]
    NotSettled {
        /// Steps taken.
        steps: u32,
        /// Largest node motion in the last step, mm.
        moved_mm: f64,
    },
}

/// What [`InVivo::apply`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InVivoReport {
    /// In-plane skin springs pre-strained.
    pub prestrained_springs: usize,
    /// Muscle springs scaled by the tone factor.
    pub toned_springs: usize,
    /// Settling steps taken (0: nothing to settle).
    pub settle_steps: u32,
    /// Largest node displacement from the generated geometry to the settled one, m.
    pub settle_displacement: f64,
}

/// Settling: first implicit Euler step, s; halved whenever a step moves the model more than
/// the one before (a linearised step across a spring's kink, fat's 1 : 2500 tension to
/// compression, overshoots), down to [`SETTLE_MIN_DT`].
const SETTLE_DT: f64 = 1.0;
/// Settling: smallest step, s.
const SETTLE_MIN_DT: f64 = 1e-3;
/// Settling: viscous damping, 1/s (overdamped at every mode of the limbs).
const SETTLE_DAMPING: f64 = 1.0;
/// Settling stops when no node moved more than this in a step of [`SETTLE_DT`], m (in
/// proportion in a shorter step: a speed of 0.1 µm/s).
const SETTLE_TOLERANCE: f64 = 1e-7;
/// Settling gives up after this many steps.
const SETTLE_MAX_STEPS: u32 = 2000;

impl InVivo {
    /// True when the settings change nothing.
    pub fn is_identity(&self) -> bool {
        self.skin_prestrain == 0.0 && self.muscle_tone == MuscleTone::Relaxed
    }

    /// The stiffness factor the muscle springs get: 1 relaxed, `active_muscle_factor` active.
    pub fn muscle_factor(&self) -> f64 {
        match self.muscle_tone {
            MuscleTone::Relaxed => 1.0,
            MuscleTone::Active => self.active_muscle_factor,
        }
    }

    /// Pre-strains the skin, tones the muscle and settles `model` to static equilibrium
    /// (skin tetrahedra keeping their volume at `skin_volume` Pa when given, as the scene's
    /// effects do).
    ///
    /// # Errors
    /// A pre-strain on a model without in-plane skin springs, or a model that does not settle.
    pub fn apply(&self, model: &mut Model, skin_volume: Option<f64>) -> Result<InVivoReport, InVivoApplyError> {
        let mut report =
            InVivoReport { prestrained_springs: 0, toned_springs: 0, settle_steps: 0, settle_displacement: 0.0 };
        if self.is_identity() {
            return Ok(report);
        }
        let factor = self.muscle_factor();
        if factor != 1.0 {
            for i in 0..model.springs.len() {
                if model.layers[model.springs.layer[i] as usize].tissue == Tissue::Muscle {
                    model.springs.law[i] = scaled(model.springs.law[i], factor);
                    report.toned_springs += 1;
                }
            }
        }
        if self.skin_prestrain > 0.0 {
            let in_plane = in_plane_skin_springs(model);
            if in_plane.is_empty() {
                return Err(InVivoApplyError::NoSkin);
            }
            for &i in &in_plane {
                let length = model.springs.rest_length[i];
                let rest = length / (1.0 + self.skin_prestrain);
                model.springs.rest_length[i] = rest;
                // Bilinear turning lengths are absolute: keep each at the same strain of the new rest length.
                if let SpringLaw::Bilinear(b) = &mut model.springs.law[i] {
                    b.turn_length = rest * (b.turn_length / length);
                }
            }
            report.prestrained_springs = in_plane.len();
            let (steps, moved) = settle(model, skin_volume)?;
            report.settle_steps = steps;
            report.settle_displacement = moved;
        }
        Ok(report)
    }
}

fn scaled(law: SpringLaw, factor: f64) -> SpringLaw {
    match law {
        SpringLaw::Linear { stiffness } => SpringLaw::Linear { stiffness: stiffness * factor },
        SpringLaw::Bilinear(mut b) => {
            b.k1 *= factor;
            b.k2 *= factor;
            b.k_compression *= factor;
            SpringLaw::Bilinear(b)
        }
    }
}

/// Skin-layer springs with both ends on the outer skin surface, or both on the skin's inner
/// face (`skin_fat`): the springs that carry the skin's in-plane tension.
pub fn in_plane_skin_springs(model: &Model) -> Vec<usize> {
    let n = model.nodes.len();
    let mut face = vec![0u8; n];
    for (bit, name) in [(1u8, "skin_outer"), (2u8, "skin_fat")] {
        for s in model.surfaces.iter().filter(|s| s.name == name) {
            for &v in s.triangles.iter().flatten() {
                face[v as usize] |= bit;
            }
        }
    }
    (0..model.springs.len())
        .filter(|&i| {
            let (a, b) = (model.springs.a[i] as usize, model.springs.b[i] as usize);
            model.layers[model.springs.layer[i] as usize].tissue == Tissue::Skin && face[a] & face[b] != 0
        })
        .collect()
}

/// Steps `model` to rest and writes the settled positions back: (steps, largest displacement m).
fn settle(model: &mut Model, skin_volume: Option<f64>) -> Result<(u32, f64), InVivoApplyError> {
    let params = IntegrationParameters {
        dt: SETTLE_DT,
        integrator: IntegratorKind::ImplicitEuler,
        substeps: Substeps::Fixed(1),
        cg_tolerance: 1e-9,
        cg_max_iterations: 5_000,
        ..IntegrationParameters::default()
    };
    let effects = Effects { viscous_damping: Some(SETTLE_DAMPING), bone: true, skin_volume, ..Effects::default() };
    let mut sim = Simulation::<f64>::new(model, params.clone(), effects.clone())?;
    let n = model.nodes.len();
    let mut last: Vec<[f64; 3]> = (0..n).map(|i| sim.state().x.get_f64(i)).collect();
    let mut moved = f64::INFINITY;
    let mut dt = SETTLE_DT;
    for step in 1..=SETTLE_MAX_STEPS {
        sim.step();
        let previous = moved;
        moved = 0.0f64;
        for (i, before) in last.iter_mut().enumerate() {
            let now = sim.state().x.get_f64(i);
            let d = ((now[0] - before[0]).powi(2) + (now[1] - before[1]).powi(2) + (now[2] - before[2]).powi(2)).sqrt();
            moved = if d.is_finite() { moved.max(d) } else { f64::INFINITY };
            *before = now;
        }
        // Halve the step when it moved the model more than the one before: near rest a long
        // linearised step overshoots across fat's kink, and does so again if lengthened.
        if moved > previous && dt > SETTLE_MIN_DT {
            // Restart from the positions reached, at rest, with half the step.
            dt = (dt * 0.5).max(SETTLE_MIN_DT);
            let mut at = model.clone();
            at.nodes.position.clone_from(&last);
            sim = Simulation::<f64>::new(&at, IntegrationParameters { dt, ..params.clone() }, effects.clone())?;
        }
        if moved < SETTLE_TOLERANCE * dt / SETTLE_DT {
            let mut displacement = 0.0f64;
            for (i, p) in model.nodes.position.iter_mut().enumerate() {
                let d = (0..3).map(|c| (last[i][c] - p[c]).powi(2)).sum::<f64>().sqrt();
                displacement = displacement.max(d);
                *p = last[i];
            }
            return Ok((step, displacement));
        }
    }
    Err(InVivoApplyError::NotSettled { steps: SETTLE_MAX_STEPS, moved_mm: moved * 1e3 })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInVivo {
    skin_prestrain: Option<f64>,
    muscle_tone: Option<String>,
    active_muscle_factor: Option<f64>,
}

/// Checks an `[in_vivo]` table (`None`: absent, the default).
pub(super) fn in_vivo(raw: Option<RawInVivo>) -> Result<InVivo, FieldError> {
    let d = InVivo::default();
    let Some(raw) = raw else { return Ok(d) };
    let skin_prestrain = raw.skin_prestrain.unwrap_or(d.skin_prestrain);
    if !(skin_prestrain.is_finite() && (0.0..=MAX_SKIN_PRESTRAIN).contains(&skin_prestrain)) {
        return Err(FieldError::new(
            "in_vivo.skin_prestrain",
            format!("{skin_prestrain} is outside 0 to {MAX_SKIN_PRESTRAIN} (unitless strain)"),
        ));
    }
    let muscle_tone = match raw.muscle_tone.as_deref() {
        None | Some("relaxed") => MuscleTone::Relaxed,
        Some("active") => MuscleTone::Active,
        Some(other) => {
            return Err(FieldError::new(
                "in_vivo.muscle_tone",
                format!("\"{other}\": must be \"relaxed\" or \"active\""),
            ));
        }
    };
    let active_muscle_factor = raw.active_muscle_factor.unwrap_or(d.active_muscle_factor);
    if !(active_muscle_factor.is_finite() && (1.0..=MAX_ACTIVE_MUSCLE_FACTOR).contains(&active_muscle_factor)) {
        return Err(FieldError::new(
            "in_vivo.active_muscle_factor",
            format!("{active_muscle_factor} is outside 1 to {MAX_ACTIVE_MUSCLE_FACTOR}"),
        ));
    }
    Ok(InVivo { skin_prestrain, muscle_tone, active_muscle_factor })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<InVivo, FieldError> {
        #[derive(Deserialize)]
        struct Wrap {
            in_vivo: Option<RawInVivo>,
        }
        in_vivo(toml::from_str::<Wrap>(text).expect("well-formed").in_vivo)
    }

    #[test]
    fn in_vivo_table_defaults_and_values_works() {
        assert_eq!(parse(""), Ok(InVivo::default()));
        let v = parse("[in_vivo]\nskin_prestrain = 0.05\nmuscle_tone = \"active\"\n").unwrap();
        assert_eq!((v.skin_prestrain, v.muscle_tone, v.muscle_factor()), (0.05, MuscleTone::Active, 2.0));
        assert!(InVivo::default().is_identity());
    }

    #[test]
    fn in_vivo_table_refuses_out_of_range_values_fails() {
        for (body, field) in [
            ("skin_prestrain = -0.01", "in_vivo.skin_prestrain"),
            ("skin_prestrain = nan", "in_vivo.skin_prestrain"),
            ("skin_prestrain = 0.5", "in_vivo.skin_prestrain"),
            ("muscle_tone = \"tense\"", "in_vivo.muscle_tone"),
            ("active_muscle_factor = 0.5", "in_vivo.active_muscle_factor"),
            ("active_muscle_factor = inf", "in_vivo.active_muscle_factor"),
        ] {
            let e = parse(&format!("[in_vivo]\n{body}\n")).expect_err(body);
            assert_eq!(e.field, field, "{body}");
            assert!(e.message.contains("outside") || e.message.contains("must be"), "{}", e.message);
        }
    }
}
