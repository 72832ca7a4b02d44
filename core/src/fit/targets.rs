//! A tissue's measured tensile behaviour: the targets a layer's springs are fitted to
//! (`config/materials/*.toml`, one file per tissue, every value with its source).

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The macroscopic law a layer must reproduce.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TargetLaw {
    /// One modulus (layers of linear springs).
    Linear {
        /// Young's modulus, Pa.
        modulus_pa: f64,
    },
    /// Two moduli meeting at a turning strain (layers of bilinear springs).
    Bilinear {
        /// Slope of the first (toe) region, Pa.
        initial_modulus_pa: f64,
        /// Slope of the second (linear) region, Pa.
        final_modulus_pa: f64,
        /// Strain at the turning point, unitless.
        turn_strain: f64,
    },
}

/// Largest stress a targets file's law or curve may reach over the tested strains (up to
/// `max_strain`), Pa: 1e12 Pa, a thousand times the strength of steel, far beyond any tissue.
/// A curve beyond it (an exponent of 1e300 overflows to infinity) could not be fitted, measured
/// or plotted.
pub const MAX_TARGET_STRESS_PA: f64 = 1e12;

/// The tissue's stress-strain curve the targets stand for: what the fitted layer's error is
/// measured against, point by point (`[curve]` of a targets file).
#[derive(Clone, Debug, PartialEq)]
pub enum TargetCurve {
    /// The targets' own law ([`TargetLaw`]): the source gives moduli, not a curve.
    Law,
    /// σ = (E0/α)(exp(α ε) − 1), the exponential law of passive muscle (Gras et al. 2012).
    Exponential {
        /// Modulus at zero strain, Pa.
        e0_pa: f64,
        /// Exponent, unitless.
        alpha: f64,
    },
}

/// One tissue's targets.
#[derive(Clone, Debug, PartialEq)]
pub struct TissueTargets {
    /// Tissue name (`skin`, `fat`, `muscle`).
    pub name: String,
    /// What to reproduce.
    pub law: TargetLaw,
    /// The curve the law stands for (default [`TargetCurve::Law`]).
    pub curve: TargetCurve,
    /// What the curve is, for tables and plot legends (e.g. "exponential law of Gras et
    /// al. 2012, mu 30 kPa, alpha 20").
    pub curve_label: String,
    /// The virtual tensile test loads up to about this strain, unitless.
    pub max_strain: f64,
    /// Weights `w_i` of the objective, one per target value (in [`TargetLaw`] field order).
    pub weights: Vec<f64>,
    /// Literature source of each value, by key.
    pub sources: BTreeMap<String, String>,
    /// File the targets came from.
    pub path: PathBuf,
}

impl TissueTargets {
    /// The target values in objective order, with their names.
    pub fn values(&self) -> Vec<(&'static str, f64)> {
        match self.law {
            TargetLaw::Linear { modulus_pa } => vec![("modulus_pa", modulus_pa)],
            TargetLaw::Bilinear { initial_modulus_pa, final_modulus_pa, turn_strain } => vec![
                ("initial_modulus_pa", initial_modulus_pa),
                ("final_modulus_pa", final_modulus_pa),
                ("turn_strain", turn_strain),
            ],
        }
    }

    /// Stress of the tissue's curve ([`TargetCurve`]) at `strain`, Pa: what the fitted
    /// layer's pointwise error is measured against.
    pub fn curve_stress_at(&self, strain: f64) -> f64 {
        match self.curve {
            TargetCurve::Law => self.stress_at(strain),
            TargetCurve::Exponential { e0_pa, alpha } => e0_pa / alpha * (alpha * strain).exp_m1(),
        }
    }

    /// Stress the target law gives at `strain`, Pa (the two bilinear lines meet at the turn).
    pub fn stress_at(&self, strain: f64) -> f64 {
        match self.law {
            TargetLaw::Linear { modulus_pa } => modulus_pa * strain,
            TargetLaw::Bilinear { initial_modulus_pa: e1, final_modulus_pa: e2, turn_strain: t } => {
                if strain <= t {
                    e1 * strain
                } else {
                    e1 * t + e2 * (strain - t)
                }
            }
        }
    }
}

/// Why a targets file could not be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TargetsLoadError {
    /// Unreadable file.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// OS error text.
        message: String,
    },
    /// Malformed TOML or a wrong field.
    #[error("{path}:{line}:{column}: {message}")]
    Syntax {
        /// The file.
        path: PathBuf,
        /// 1-based line (0 when unknown).
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A value out of range or missing.
    #[error("{path}: {field}: {message}")]
    Value {
        /// The file.
        path: PathBuf,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTargets {
    name: String,
    law: String,
    modulus_pa: Option<f64>,
    reference_final_modulus_pa: Option<f64>,
    initial_modulus_pa: Option<f64>,
    final_modulus_pa: Option<f64>,
    turn_strain: Option<f64>,
    max_strain: f64,
    weights: Option<Vec<f64>>,
    curve: Option<RawCurve>,
    #[serde(default)]
    sources: BTreeMap<String, String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCurve {
    law: String,
    e0_pa: Option<f64>,
    alpha: Option<f64>,
    label: String,
}

impl TissueTargets {
    /// Reads a targets file.
    pub fn load(path: &Path) -> Result<Self, TargetsLoadError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| TargetsLoadError::Io { path: path.to_path_buf(), message: e.to_string() })?;
        Self::parse(&text, path)
    }

    /// Parses targets text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, TargetsLoadError> {
        let raw: RawTargets = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((0, 0), |s| crate::scene::line_column(text, s.start));
            TargetsLoadError::Syntax { path: path.to_path_buf(), line, column, message: e.message().to_string() }
        })?;
        let value_err = |field: &str, message: &str| TargetsLoadError::Value {
            path: path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        };
        let need = |v: Option<f64>, field: &str| -> Result<f64, TargetsLoadError> {
            match v {
                Some(x) if x.is_finite() && x > 0.0 => Ok(x),
                Some(_) => Err(value_err(field, "must be finite and positive")),
                None => Err(value_err(field, &format!("required when law = \"{}\"", raw.law))),
            }
        };
        let law = match raw.law.as_str() {
            "linear" => TargetLaw::Linear { modulus_pa: need(raw.modulus_pa, "modulus_pa")? },
            "bilinear" => TargetLaw::Bilinear {
                initial_modulus_pa: need(raw.initial_modulus_pa, "initial_modulus_pa")?,
                final_modulus_pa: need(raw.final_modulus_pa, "final_modulus_pa")?,
                turn_strain: need(raw.turn_strain, "turn_strain")?,
            },
            _ => return Err(value_err("law", "\"linear\" or \"bilinear\"")),
        };
        if raw.reference_final_modulus_pa.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
            return Err(value_err("reference_final_modulus_pa", "must be finite and positive"));
        }
        let max_strain = need(Some(raw.max_strain), "max_strain")?;
        let exp_param = |v: Option<f64>, field: &str| {
            v.filter(|x| x.is_finite() && *x > 0.0)
                .ok_or_else(|| value_err(field, "required, finite and positive, when curve.law = \"exponential\""))
        };
        let (curve, curve_label) = match &raw.curve {
            None => (TargetCurve::Law, format!("{} law of the targets", raw.law)),
            Some(c) => match c.law.as_str() {
                "exponential" => (
                    TargetCurve::Exponential {
                        e0_pa: exp_param(c.e0_pa, "curve.e0_pa")?,
                        alpha: exp_param(c.alpha, "curve.alpha")?,
                    },
                    c.label.clone(),
                ),
                "targets" => (TargetCurve::Law, c.label.clone()),
                _ => return Err(value_err("curve.law", "\"exponential\" or \"targets\"")),
            },
        };
        if let TargetLaw::Bilinear { turn_strain, .. } = law
            && turn_strain >= max_strain
        {
            return Err(value_err("turn_strain", "must be below max_strain (the test must reach the second phase)"));
        }
        let targets = Self {
            name: raw.name.clone(),
            law,
            curve,
            curve_label,
            max_strain,
            weights: Vec::new(),
            sources: raw.sources,
            path: path.to_path_buf(),
        };
        for (field, stress) in [("law", targets.stress_at(max_strain)), ("curve", targets.curve_stress_at(max_strain))]
        {
            if !(stress.is_finite() && stress <= MAX_TARGET_STRESS_PA) {
                let what = if field == "curve" { "the curve's" } else { "the law's" };
                return Err(value_err(
                    field,
                    &format!("{what} stress at max_strain is {stress:e} Pa, beyond {MAX_TARGET_STRESS_PA:e} Pa"),
                ));
            }
        }
        let n = targets.values().len();
        let weights = raw.weights.unwrap_or_else(|| vec![1.0; n]);
        if weights.len() != n || weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(value_err("weights", &format!("{n} finite, non-negative weights")));
        }
        if weights.iter().all(|&w| w == 0.0) {
            // Every target ignored: the annealing would accept any springs.
            return Err(value_err("weights", "at least one weight must be positive"));
        }
        let curve_key = (targets.curve != TargetCurve::Law).then_some("curve");
        for key in targets.values().into_iter().map(|(k, _)| k).chain(curve_key) {
            if !targets.sources.contains_key(key) {
                return Err(value_err("sources", &format!("no source given for {key}")));
            }
        }
        Ok(Self { weights, ..targets })
    }
}
