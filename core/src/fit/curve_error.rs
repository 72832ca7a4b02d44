//! How far a fitted layer's stress-strain curve is from the tissue's own curve
//! ([`TissueTargets::curve_stress_at`]), point by point over the tensile test's strains.

use super::targets::TissueTargets;
use super::tensile::TensileCurve;

/// A fitted layer's error against the tissue's curve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurveError {
    /// RMS of (achieved − target stress) over the RMS of the target stress, unitless.
    pub rms: f64,
    /// Largest |achieved − target stress| over the largest target stress, unitless.
    pub max: f64,
    /// (achieved − target) / target at the smallest strain tested, unitless: how the layer
    /// feels under a light touch.
    pub low_strain: f64,
    /// Every point compared: (strain, achieved stress Pa, target stress Pa).
    pub points: Vec<(f64, f64, f64)>,
}

/// The error of `curve` against `targets`' curve at every tested strain above zero; `None`
/// when the curve has no such point or the target stress is zero throughout.
///
/// ```
/// use lamina_core::fit::{TensileCurve, TissueTargets, curve_error};
/// let text = "name = \"fat\"\nlaw = \"linear\"\nmodulus_pa = 1.6e3\nmax_strain = 0.3\n\
///             [sources]\nmodulus_pa = \"a source\"\n";
/// let fat = TissueTargets::parse(text, "fat.toml".as_ref()).unwrap();
/// // A layer 10 % stiffer than the tissue everywhere is 10 % off by every measure.
/// let curve = TensileCurve {
///     strain: vec![0.0, 0.1, 0.2],
///     stress_pa: vec![0.0, 176.0, 352.0],
///     ..TensileCurve::default()
/// };
/// let e = curve_error(&fat, &curve).unwrap();
/// assert!((e.rms - 0.1).abs() < 1e-12 && (e.max - 0.1).abs() < 1e-12 && (e.low_strain - 0.1).abs() < 1e-12);
/// ```
pub fn curve_error(targets: &TissueTargets, curve: &TensileCurve) -> Option<CurveError> {
    let points: Vec<(f64, f64, f64)> = curve
        .strain
        .iter()
        .zip(&curve.stress_pa)
        .filter(|(e, s)| **e > 0.0 && e.is_finite() && s.is_finite())
        .map(|(&e, &s)| (e, s, targets.curve_stress_at(e)))
        .collect();
    let n = points.len() as f64;
    let target_rms = (points.iter().map(|p| p.2 * p.2).sum::<f64>() / n).sqrt();
    let target_peak = points.iter().map(|p| p.2.abs()).fold(0.0, f64::max);
    if points.is_empty() || target_rms.is_nan() || target_rms <= 0.0 {
        return None;
    }
    let error_rms = (points.iter().map(|p| (p.1 - p.2).powi(2)).sum::<f64>() / n).sqrt();
    let error_peak = points.iter().map(|p| (p.1 - p.2).abs()).fold(0.0, f64::max);
    let first = points.iter().min_by(|a, b| a.0.total_cmp(&b.0))?;
    let low_strain = if first.2 != 0.0 { (first.1 - first.2) / first.2 } else { f64::NAN };
    Some(CurveError { rms: error_rms / target_rms, max: error_peak / target_peak, low_strain, points })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn muscle_law() -> TissueTargets {
        let text = "name = \"muscle\"\nlaw = \"bilinear\"\ninitial_modulus_pa = 0.2e6\nfinal_modulus_pa = 1.08e6\n\
                    turn_strain = 0.0926\nmax_strain = 0.15\n[curve]\nlaw = \"exponential\"\ne0_pa = 90e3\nalpha = 20.0\n\
                    label = \"Gras\"\n[sources]\ninitial_modulus_pa = \"s\"\nfinal_modulus_pa = \"s\"\nturn_strain = \"s\"\ncurve = \"s\"\n";
        TissueTargets::parse(text, Path::new("muscle.toml")).unwrap()
    }

    #[test]
    fn exponential_curve_is_the_published_law_works() {
        let m = muscle_law();
        // sigma = (E0/alpha)(exp(alpha eps) - 1): 4500 Pa (e^3 - 1) at 15 %, slope E0 at zero.
        assert!((m.curve_stress_at(0.15) - 4500.0 * (3f64.exp() - 1.0)).abs() < 1e-6);
        assert!((m.curve_stress_at(1e-7) / 1e-7 - 90e3).abs() < 1.0);
        assert_eq!(m.curve_label, "Gras");
    }

    #[test]
    fn best_bilinear_of_the_exponential_is_about_seven_percent_off_works() {
        // The muscle targets' own bilinear law, sampled as a tensile test would, against the
        // exponential: 6.9 % RMS and 6.3 % of the peak (computed independently by a
        // least-squares fit over every 0.5 % of strain).
        let m = muscle_law();
        let strain: Vec<f64> = (0..=30).map(|i| 0.005 * i as f64).collect();
        let stress_pa = strain.iter().map(|&e| m.stress_at(e)).collect();
        let e = curve_error(&m, &TensileCurve { strain, stress_pa, ..TensileCurve::default() }).unwrap();
        assert!((e.rms - 0.069).abs() < 0.002, "rms {}", e.rms);
        assert!((e.max - 0.063).abs() < 0.002, "max {}", e.max);
        // At 0.5 % strain the exponential is still near its initial slope E0, half the line's.
        assert!(e.low_strain > 1.0, "low strain {}", e.low_strain);
        assert_eq!(e.points.len(), 30);
    }

    #[test]
    fn curve_error_without_points_is_none_works() {
        assert_eq!(curve_error(&muscle_law(), &TensileCurve::default()), None);
    }
}
