//! Bilinear regression as the paper does it: every data point is tried as the turning point,
//! a least-squares line is fitted on each side, and the split with the least total squared
//! error is kept.

/// A least-squares line `y = slope · x + intercept`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFit {
    /// Slope (Pa per unit strain for stress-strain data).
    pub slope: f64,
    /// Intercept.
    pub intercept: f64,
    /// Sum of squared residuals.
    pub sse: f64,
}

/// Least-squares line through `(x, y)`; `None` with fewer than two distinct `x`.
pub fn line_fit(x: &[f64], y: &[f64]) -> Option<LineFit> {
    let n = x.len().min(y.len()) as f64;
    if n < 2.0 {
        return None;
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let sse = x.iter().zip(y).map(|(a, b)| (b - slope * a - intercept).powi(2)).sum();
    Some(LineFit { slope, intercept, sse })
}

/// The macroscopic bilinear behaviour found in a curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilinearFit {
    /// Slope of the first line (initial modulus), Pa.
    pub initial_modulus: f64,
    /// Slope of the second line (final modulus), Pa.
    pub final_modulus: f64,
    /// Turning strain: where the two lines cross, kept between the turning point's
    /// neighbours (the data point itself when the lines are parallel).
    pub turn_strain: f64,
    /// Index of the data point taken as turning point (it belongs to both lines).
    pub turn_index: usize,
    /// Total squared error of the two lines.
    pub sse: f64,
    /// The two lines.
    pub lines: [LineFit; 2],
}

/// Tries every point `k` (with at least two points on each side, `k` shared) as the turning
/// point and keeps the split with the least total squared error. `None` with fewer than
/// three points.
pub fn bilinear_regression(strain: &[f64], stress: &[f64]) -> Option<BilinearFit> {
    let n = strain.len().min(stress.len());
    let mut best: Option<BilinearFit> = None;
    for k in 1..n.saturating_sub(1) {
        let (Some(a), Some(b)) = (line_fit(&strain[..=k], &stress[..=k]), line_fit(&strain[k..n], &stress[k..n]))
        else {
            continue;
        };
        let sse = a.sse + b.sse;
        if best.is_some_and(|f| f.sse <= sse) {
            continue;
        }
        let crossing = if (a.slope - b.slope).abs() > 1e-12 * a.slope.abs().max(b.slope.abs()) {
            (b.intercept - a.intercept) / (a.slope - b.slope)
        } else {
            strain[k]
        };
        let turn = crossing.clamp(strain[k - 1], strain[(k + 1).min(n - 1)]);
        best = Some(BilinearFit {
            initial_modulus: a.slope,
            final_modulus: b.slope,
            turn_strain: turn,
            turn_index: k,
            sse,
            lines: [a, b],
        });
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_exact_line_works() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = x.map(|v| 2.5 * v - 1.0);
        let f = line_fit(&x, &y).unwrap();
        assert!((f.slope - 2.5).abs() < 1e-12 && (f.intercept + 1.0).abs() < 1e-12 && f.sse < 1e-20);
        assert!(line_fit(&[1.0, 1.0], &[0.0, 1.0]).is_none());
    }
}
