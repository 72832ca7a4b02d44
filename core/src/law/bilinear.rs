//! The bilinear spring of the paper: stiffness `k1` from the rest length up to the turning
//! length, `k2` beyond it, and its own stiffness in compression.

/// A bilinear spring law. All stiffnesses in N/m, lengths in m.
///
/// ```text
///            ⎧ kc·(L − L0)                    L < L0        (compression)
///   F(L) =   ⎨ k1·(L − L0)                    L0 ≤ L ≤ Lt   (first phase)
///            ⎩ k1·(Lt − L0) + k2·(L − Lt)     L > Lt        (second phase)
/// ```
/// `F(Lt)` is the paper's *TurnForce*. Soft tissue has `k2 ≫ k1` (the toe region of a
/// collagen network, then the stiff linear region).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bilinear {
    /// First-phase stiffness, N/m.
    pub k1: f64,
    /// Second-phase stiffness beyond the turning length, N/m.
    pub k2: f64,
    /// Turning length `Lt`, m (absolute length, not strain; `Lt ≥ L0`).
    pub turn_length: f64,
    /// Stiffness in compression (`L < L0`), N/m.
    pub k_compression: f64,
}

impl Bilinear {
    /// Force in N (positive = tension) at `length`, with rest length `rest_length`.
    #[inline]
    pub fn force(&self, length: f64, rest_length: f64) -> f64 {
        let stretch = length - rest_length;
        if stretch < 0.0 {
            self.k_compression * stretch
        } else {
            let turn = self.turn_length - rest_length;
            if stretch <= turn { self.k1 * stretch } else { self.k1 * turn + self.k2 * (stretch - turn) }
        }
    }

    /// Tangent stiffness dF/dL in N/m (at a kink: the stiffness of the phase being entered).
    #[inline]
    pub fn tangent(&self, length: f64, rest_length: f64) -> f64 {
        if length < rest_length {
            self.k_compression
        } else if length <= self.turn_length {
            self.k1
        } else {
            self.k2
        }
    }

    /// The paper's TurnForce: the tension at the turning length, N.
    pub fn turn_force(&self, rest_length: f64) -> f64 {
        self.k1 * (self.turn_length - rest_length)
    }

    /// Finite, non-negative stiffnesses and `turn_length ≥ rest_length`.
    pub fn is_valid(&self, rest_length: f64) -> bool {
        [self.k1, self.k2, self.k_compression, self.turn_length].iter().all(|v| v.is_finite() && *v >= 0.0)
            && self.turn_length >= rest_length
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_phases_match_piecewise_definition_works() {
        let law = Bilinear { k1: 2.0, k2: 50.0, turn_length: 1.5, k_compression: 7.0 };
        assert_eq!(law.force(1.0, 1.0), 0.0);
        assert_eq!(law.force(0.5, 1.0), -3.5);
        assert_eq!(law.force(1.25, 1.0), 0.5);
        assert_eq!(law.force(1.5, 1.0), 1.0);
        assert_eq!(law.force(2.0, 1.0), 1.0 + 25.0);
        assert_eq!(law.turn_force(1.0), 1.0);
        assert_eq!(law.tangent(1.6, 1.0), 50.0);
        assert_eq!(law.tangent(0.9, 1.0), 7.0);
    }

    #[test]
    fn spring_energy_is_integral_of_force_works() {
        // Trapezoid rule on a fine grid against the closed-form energy, across both kinks.
        let law =
            super::super::SpringLaw::Bilinear(Bilinear { k1: 2.0, k2: 50.0, turn_length: 1.5, k_compression: 7.0 });
        let (rest, n) = (1.0, 200_000);
        for end in [0.3, 1.2, 1.5, 2.7] {
            let h = (end - rest) / n as f64;
            let mut w = 0.0;
            for i in 0..n {
                let (a, b) = (rest + i as f64 * h, rest + (i + 1) as f64 * h);
                w += 0.5 * (law.force(a, rest) + law.force(b, rest)) * h;
            }
            let e = law.energy(end, rest);
            assert!((w - e).abs() <= 1e-6 * e.abs().max(1e-12), "L={end}: {w} vs {e}");
        }
    }
}
