//! In-vivo indentation targets (`config/materials/indentation.toml`): the force a living limb
//! gives under the haptic tool's sphere, as an acceptance band derived from published
//! lower-limb indentation, with the published entries it comes from.

use serde::Deserialize;
use std::path::{Path, PathBuf};

pub use super::targets::TargetsLoadError;

/// The acceptance band at one depth, and the stiffening asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct IndentationBand {
    /// Depth the band is set at, m.
    pub depth_m: f64,
    /// Smallest force accepted there, N.
    pub force_min_n: f64,
    /// Largest force accepted there, N.
    pub force_max_n: f64,
    /// Depth of the shallow secant stiffness, m.
    pub shallow_depth_m: f64,
    /// Smallest accepted ratio of the secant stiffness at `depth_m` over the one at
    /// `shallow_depth_m`, unitless.
    pub min_secant_ratio: f64,
    /// What the band stands for.
    pub label: String,
    /// `measured` or `derived`.
    pub kind: String,
}

/// One published indentation entry.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredIndentation {
    /// Reference.
    pub source: String,
    /// Body site and subjects.
    pub site: String,
    /// Indenter geometry.
    pub indenter: String,
    /// Loading rate.
    pub rate: String,
    /// What was reported.
    pub quantity: String,
    /// Range of the reported initial (low-load) modulus, Pa, when it has one.
    pub initial_modulus_pa: Option<[f64; 2]>,
    /// `measured` or `derived`.
    pub kind: String,
    /// How the entry is brought to Lamina's tool.
    pub brought_to_tool: String,
}

/// The indentation targets.
#[derive(Clone, Debug, PartialEq)]
pub struct IndentationTargets {
    /// Radius of the sphere the band is for, m.
    pub sphere_radius_m: f64,
    /// Poisson's ratio of the Hertz conversions, unitless.
    pub poisson: f64,
    /// The acceptance band.
    pub band: IndentationBand,
    /// The published entries.
    pub measured: Vec<MeasuredIndentation>,
    /// File the targets came from.
    pub path: PathBuf,
}

/// The shipped targets, compiled in.
pub const SHIPPED_INDENTATION_TARGETS: &str = include_str!("../../../config/materials/indentation.toml");

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawIndentation {
    #[allow(dead_code)]
    name: String,
    sphere_radius_m: f64,
    poisson: f64,
    band: RawBand,
    #[serde(default)]
    measured: Vec<MeasuredIndentation>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBand {
    depth_m: f64,
    force_min_n: f64,
    force_max_n: f64,
    shallow_depth_m: f64,
    min_secant_ratio: f64,
    label: String,
    kind: String,
}

/// Hertz contact of a rigid sphere of `radius_m` pressed `depth_m` into a half-space of
/// Young's modulus `modulus_pa` and Poisson's ratio `poisson`: F = 4/3 · E/(1 − ν²) · √R · d^{3/2}, N.
///
/// ```
/// use lamina_core::fit::hertz_sphere_force;
/// // 26 kPa tissue (nu 0.49), 12 mm sphere, 8 mm deep: about 3.6 N.
/// let f = hertz_sphere_force(26e3, 0.49, 0.012, 0.008);
/// assert!((f - 3.58).abs() < 0.01);
/// ```
pub fn hertz_sphere_force(modulus_pa: f64, poisson: f64, radius_m: f64, depth_m: f64) -> f64 {
    4.0 / 3.0 * modulus_pa / (1.0 - poisson * poisson) * radius_m.sqrt() * depth_m.max(0.0).powf(1.5)
}

impl IndentationTargets {
    /// The shipped targets.
    pub fn shipped() -> Self {
        Self::parse(SHIPPED_INDENTATION_TARGETS, Path::new("<built-in config/materials/indentation.toml>"))
            .expect("the shipped indentation targets are valid")
    }

    /// Reads a targets file.
    pub fn load(path: &Path) -> Result<Self, TargetsLoadError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| TargetsLoadError::Io { path: path.to_path_buf(), message: e.to_string() })?;
        Self::parse(&text, path)
    }

    /// Parses targets text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, TargetsLoadError> {
        let raw: RawIndentation = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((0, 0), |s| crate::scene::line_column(text, s.start));
            TargetsLoadError::Syntax { path: path.to_path_buf(), line, column, message: e.message().to_string() }
        })?;
        let bad = |field: &str, message: String| TargetsLoadError::Value {
            path: path.to_path_buf(),
            field: field.into(),
            message,
        };
        let within = |v: f64, field: &str, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && v > lo && v <= hi {
                Ok(v)
            } else {
                Err(bad(field, format!("{v} is outside ({lo}, {hi}] {unit}")))
            }
        };
        let b = &raw.band;
        within(raw.sphere_radius_m, "sphere_radius_m", 0.0, 1.0, "m")?;
        within(raw.poisson, "poisson", 0.0, 0.5, "")?;
        within(b.depth_m, "band.depth_m", 0.0, 0.1, "m")?;
        within(b.shallow_depth_m, "band.shallow_depth_m", 0.0, b.depth_m, "m (up to band.depth_m)")?;
        within(b.force_max_n, "band.force_max_n", 0.0, 1e4, "N")?;
        within(b.force_min_n, "band.force_min_n", 0.0, b.force_max_n, "N (up to band.force_max_n)")?;
        within(b.min_secant_ratio, "band.min_secant_ratio", 0.0, 100.0, "")?;
        for (i, m) in raw.measured.iter().enumerate() {
            if let Some([lo, hi]) = m.initial_modulus_pa
                && !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo <= hi)
            {
                return Err(bad(
                    &format!("measured[{i}].initial_modulus_pa"),
                    "two finite moduli, 0 < low <= high Pa".into(),
                ));
            }
            if !matches!(m.kind.as_str(), "measured" | "derived") {
                return Err(bad(
                    &format!("measured[{i}].kind"),
                    format!("\"{}\": \"measured\" or \"derived\"", m.kind),
                ));
            }
        }
        if !matches!(b.kind.as_str(), "measured" | "derived") {
            return Err(bad("band.kind", format!("\"{}\": \"measured\" or \"derived\"", b.kind)));
        }
        Ok(Self {
            sphere_radius_m: raw.sphere_radius_m,
            poisson: raw.poisson,
            band: IndentationBand {
                depth_m: b.depth_m,
                force_min_n: b.force_min_n,
                force_max_n: b.force_max_n,
                shallow_depth_m: b.shallow_depth_m,
                min_secant_ratio: b.min_secant_ratio,
                label: b.label.clone(),
                kind: b.kind.clone(),
            },
            measured: raw.measured,
            path: path.to_path_buf(),
        })
    }

    /// The modulus whose Hertz force at `depth_m` is `force_n`, Pa.
    pub fn effective_modulus(&self, force_n: f64, depth_m: f64) -> f64 {
        force_n / hertz_sphere_force(1.0, self.poisson, self.sphere_radius_m, depth_m)
    }
}

/// A force-depth curve checked against the band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandCheck {
    /// Force at the band's depth, N.
    pub force_n: f64,
    /// Secant stiffness at the band's depth over the one at its shallow depth, unitless.
    pub secant_ratio: f64,
    /// The force lies in the band.
    pub force_in_band: bool,
    /// The secant ratio is at least the band's.
    pub stiffens: bool,
}

impl BandCheck {
    /// One word for tables: `in band`, `force out`, `too linear` or `both out`.
    pub fn verdict(&self) -> &'static str {
        match (self.force_in_band, self.stiffens) {
            (true, true) => "in band",
            (false, true) => "force out",
            (true, false) => "too linear",
            (false, false) => "both out",
        }
    }
}

impl IndentationBand {
    /// The Hertz curve (F ∝ d^{3/2}) through `force_n` at the band's depth, at `depth_mm`, N:
    /// how the band's ends are drawn beside a measured curve.
    pub fn hertz_through(&self, force_n: f64, depth_mm: f64) -> f64 {
        force_n * (depth_mm * 1e-3 / self.depth_m).powf(1.5)
    }

    /// Checks forces `force_n` at depths `depth_m` (m, increasing), reading the two depths by
    /// linear interpolation; `None` when the curve does not reach the band's depth.
    pub fn check(&self, depth_m: &[f64], force_n: &[f64]) -> Option<BandCheck> {
        let at = |d: f64| -> Option<f64> {
            let i = depth_m.iter().position(|x| *x >= d - 1e-12)?;
            if i == 0 {
                return Some(force_n[0] * d / depth_m[0]);
            }
            let t = (d - depth_m[i - 1]) / (depth_m[i] - depth_m[i - 1]);
            Some(force_n[i - 1] + t * (force_n[i] - force_n[i - 1]))
        };
        let (deep, shallow) = (at(self.depth_m)?, at(self.shallow_depth_m)?);
        let secant_ratio = (deep / self.depth_m) / (shallow / self.shallow_depth_m);
        Some(BandCheck {
            force_n: deep,
            secant_ratio,
            force_in_band: (self.force_min_n..=self.force_max_n).contains(&deep),
            stiffens: secant_ratio >= self.min_secant_ratio,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_band_is_hertz_of_15_to_60_kpa_works() {
        let t = IndentationTargets::shipped();
        let hertz = |e: f64| hertz_sphere_force(e, t.poisson, t.sphere_radius_m, t.band.depth_m);
        // The band's ends are the Hertz forces of 15 and 60-65 kPa, as the file says (derived).
        assert!((hertz(15e3) - 2.06).abs() < 0.01 && t.band.force_min_n <= hertz(15e3));
        assert!((hertz(60e3) - 8.25).abs() < 0.01 && t.band.force_max_n >= hertz(60e3));
        assert!(hertz(66e3) > t.band.force_max_n);
        assert_eq!(t.band.kind, "derived");
        // Isogai et al. 2022's low-load moduli land inside the band.
        let isogai = t.measured.iter().find(|m| m.source.starts_with("Isogai")).unwrap();
        for e in isogai.initial_modulus_pa.unwrap() {
            assert!((t.band.force_min_n..=t.band.force_max_n).contains(&hertz(e)), "{e} Pa");
        }
        assert!(t.measured.iter().all(|m| m.kind == "measured"));
    }

    #[test]
    fn band_check_reads_secant_ratio_of_a_hertz_curve_works() {
        // A Hertz curve F ~ d^1.5 has secant ratio sqrt(8/2) = 2 between 2 and 8 mm.
        let t = IndentationTargets::shipped();
        let d: Vec<f64> = (1..=10).map(|mm| f64::from(mm) * 1e-3).collect();
        let f: Vec<f64> = d.iter().map(|d| hertz_sphere_force(30e3, 0.49, 0.012, *d)).collect();
        let c = t.band.check(&d, &f).unwrap();
        assert!((c.secant_ratio - 2.0).abs() < 1e-9, "{}", c.secant_ratio);
        assert!(c.force_in_band && c.stiffens);
        // A linear spring does not stiffen.
        let linear: Vec<f64> = d.iter().map(|d| 100.0 * d).collect();
        let c = t.band.check(&d, &linear).unwrap();
        assert!((c.secant_ratio - 1.0).abs() < 1e-9 && !c.stiffens && !c.force_in_band);
        assert_eq!(t.band.check(&d[..5], &f[..5]), None);
    }

    #[test]
    fn indentation_targets_refuse_bad_values_fails() {
        let good = SHIPPED_INDENTATION_TARGETS;
        for (from, to, field) in [
            ("force_min_n = 2.0", "force_min_n = 20.0", "band.force_min_n"),
            ("sphere_radius_m = 0.012", "sphere_radius_m = nan", "sphere_radius_m"),
            ("shallow_depth_m = 0.002", "shallow_depth_m = 0.02", "band.shallow_depth_m"),
            (
                "initial_modulus_pa = [220.0, 58.4e3]",
                "initial_modulus_pa = [1e4, 1e3]",
                "measured[0].initial_modulus_pa",
            ),
        ] {
            let text = good.replacen(from, to, 1);
            assert_ne!(text, good, "{from}");
            match IndentationTargets::parse(&text, Path::new("t.toml")) {
                Err(TargetsLoadError::Value { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{to}: {other:?}"),
            }
        }
    }
}
