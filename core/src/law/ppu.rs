//! The physics accelerator's (PPU) linear spring and the paper's bilinear decomposition.
//!
//! The paper's PPU (Ageia PhysX 2) describes a linear spring by five parameters, the ones
//! of PhysX's `setLinearSpring`: *CompForce*, *CompLen*, *RestLen*, *StretForce*,
//! *StretLen*. The force grows linearly from zero at *RestLen* to *StretForce* at
//! *StretLen* and to *CompForce* (pushing) at *CompLen*, and **saturates** beyond those
//! lengths. A bilinear spring is two such springs in parallel:
//!
//! * spring 1: `RestLen = L0`, `StretLen = TurnLen`, `StretForce = TurnForce`: it carries
//!   the first phase and saturates at the turning point;
//! * spring 2: `RestLen = TurnLen`, `StretLen = StretLen_BP`,
//!   `StretForce = StretForce_BP − TurnForce`: it switches on at the turning point with
//!   stiffness `k2`.
//!
//! The paper (Algorithm 1) splits *CompForce* half and half between the two springs. With
//! saturating springs that cannot be exact: spring 2 is "compressed" whenever
//! `L < TurnLen`, so any compression force on it would add stiffness in the first phase.
//! We give the whole compression to spring 1 and `CompForce = 0` to spring 2; the pair then
//! reproduces the bilinear law exactly between `CompLen` and `StretLen_BP` (a property
//! test checks it at random lengths). Outside that range the pair saturates, as the PPU did.

use super::Bilinear;

/// One PPU linear spring (PhysX 2 `setLinearSpring`). Forces in N, lengths in m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpuLinearSpring {
    /// Pushing force reached at `comp_len` and held below it, N (≥ 0).
    pub comp_force: f64,
    /// Length at which the compression force saturates, m (≤ `rest_len`).
    pub comp_len: f64,
    /// Length of zero force, m.
    pub rest_len: f64,
    /// Tension reached at `stret_len` and held beyond it, N (≥ 0).
    pub stret_force: f64,
    /// Length at which the tension saturates, m (≥ `rest_len`).
    pub stret_len: f64,
}

impl PpuLinearSpring {
    /// Force at `length`, N (positive = tension), saturating outside `[comp_len, stret_len]`.
    pub fn force(&self, length: f64) -> f64 {
        if length >= self.rest_len {
            if self.stret_len <= self.rest_len {
                return 0.0;
            }
            let s = ((length - self.rest_len) / (self.stret_len - self.rest_len)).min(1.0);
            self.stret_force * s
        } else {
            if self.comp_len >= self.rest_len {
                return 0.0;
            }
            let s = ((self.rest_len - length) / (self.rest_len - self.comp_len)).min(1.0);
            -self.comp_force * s
        }
    }
}

/// A bilinear spring as two parallel PPU linear springs, with the paper's two extra
/// parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpuBilinearPair {
    /// Carries the first phase and the compression.
    pub first: PpuLinearSpring,
    /// Switches on at the turning length.
    pub second: PpuLinearSpring,
    /// Turning length, m.
    pub turn_len: f64,
    /// Tension at the turning length, N.
    pub turn_force: f64,
}

/// Why a PPU pair cannot be read back as a bilinear spring, or a bilinear spring cannot be
/// written as one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PpuDecomposeError {
    /// A parameter is NaN or infinite.
    #[error("a PPU spring parameter is NaN or infinite")]
    NonFinite,
    /// The lengths are not ordered `CompLen ≤ RestLen ≤ TurnLen < StretLen`.
    #[error("PPU lengths must satisfy CompLen <= RestLen <= TurnLen < StretLen")]
    LengthsOutOfOrder,
    /// The second spring carries compression, which would stiffen the first phase.
    #[error("the second PPU spring must have CompForce = 0")]
    SecondSpringCompresses,
    /// The first spring does not saturate at the turning point, or the second does not
    /// start there.
    #[error("the first PPU spring must saturate where the second one starts (TurnLen)")]
    NotJoinedAtTurn,
}

impl PpuBilinearPair {
    /// Writes `law` (rest length `rest_len`) as a PPU pair valid for lengths in
    /// `[comp_len, stret_len]`, m. Typical: `comp_len = 0` and `stret_len` a few rest lengths.
    pub fn from_bilinear(
        law: &Bilinear,
        rest_len: f64,
        comp_len: f64,
        stret_len: f64,
    ) -> Result<Self, PpuDecomposeError> {
        let all = [law.k1, law.k2, law.k_compression, law.turn_length, rest_len, comp_len, stret_len];
        if all.iter().any(|v| !v.is_finite()) {
            return Err(PpuDecomposeError::NonFinite);
        }
        if !(comp_len <= rest_len && rest_len <= law.turn_length && law.turn_length < stret_len) {
            return Err(PpuDecomposeError::LengthsOutOfOrder);
        }
        let turn_force = law.turn_force(rest_len);
        let stret_force_total = law.force(stret_len, rest_len);
        let comp_force = -law.force(comp_len, rest_len);
        let (first_stret_len, first_stret_force) =
            if law.turn_length > rest_len { (law.turn_length, turn_force) } else { (rest_len, 0.0) };
        Ok(Self {
            first: PpuLinearSpring {
                comp_force,
                comp_len,
                rest_len,
                stret_force: first_stret_force,
                stret_len: first_stret_len,
            },
            second: PpuLinearSpring {
                comp_force: 0.0,
                comp_len: law.turn_length,
                rest_len: law.turn_length,
                stret_force: stret_force_total - turn_force,
                stret_len,
            },
            turn_len: law.turn_length,
            turn_force,
        })
    }

    /// Reads the pair back as a bilinear law; returns it with the rest length, m.
    pub fn to_bilinear(&self) -> Result<(Bilinear, f64), PpuDecomposeError> {
        let p = [
            self.first.comp_force,
            self.first.comp_len,
            self.first.rest_len,
            self.first.stret_force,
            self.first.stret_len,
            self.second.comp_force,
            self.second.comp_len,
            self.second.rest_len,
            self.second.stret_force,
            self.second.stret_len,
            self.turn_len,
            self.turn_force,
        ];
        if p.iter().any(|v| !v.is_finite()) {
            return Err(PpuDecomposeError::NonFinite);
        }
        if self.second.comp_force != 0.0 {
            return Err(PpuDecomposeError::SecondSpringCompresses);
        }
        let rest = self.first.rest_len;
        if !(self.first.comp_len <= rest && rest <= self.turn_len && self.turn_len < self.second.stret_len) {
            return Err(PpuDecomposeError::LengthsOutOfOrder);
        }
        if self.second.rest_len != self.turn_len || (self.turn_len > rest && self.first.stret_len != self.turn_len) {
            return Err(PpuDecomposeError::NotJoinedAtTurn);
        }
        let k1 = if self.turn_len > rest { self.first.stret_force / (self.turn_len - rest) } else { 0.0 };
        let k2 = self.second.stret_force / (self.second.stret_len - self.turn_len);
        let k_compression =
            if rest > self.first.comp_len { self.first.comp_force / (rest - self.first.comp_len) } else { 0.0 };
        Ok((Bilinear { k1, k2, turn_length: self.turn_len, k_compression }, rest))
    }

    /// Force of the pair at `length`, N: the sum of the two springs.
    pub fn force(&self, length: f64) -> f64 {
        self.first.force(length) + self.second.force(length)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn law_strategy() -> impl Strategy<Value = (Bilinear, f64)> {
        (1e-3f64..0.05, 0.0f64..2.0, 1e-2f64..1e3, 1e-1f64..1e5, 1e-2f64..1e4).prop_map(
            |(rest, turn_strain, k1, k2, kc)| {
                (Bilinear { k1, k2, turn_length: rest * (1.0 + turn_strain), k_compression: kc }, rest)
            },
        )
    }

    proptest! {
        /// The pair reproduces the bilinear law at every length of its range to round-off.
        #[test]
        fn ppu_pair_reproduces_bilinear_law_works((law, rest) in law_strategy(), t in 0.0f64..1.0) {
            let stret_len = law.turn_length.max(rest) * 4.0;
            let pair = PpuBilinearPair::from_bilinear(&law, rest, 0.0, stret_len).unwrap();
            let length = t * stret_len;
            let expect = law.force(length, rest);
            let got = pair.force(length);
            let scale = law.force(stret_len, rest).abs().max(law.force(0.0, rest).abs()).max(1e-300);
            prop_assert!((got - expect).abs() <= 1e-12 * scale, "L={length} expect {expect} got {got}");
        }

        /// Export then import gives the same law back to round-off.
        #[test]
        fn ppu_pair_round_trips_works((law, rest) in law_strategy()) {
            let pair = PpuBilinearPair::from_bilinear(&law, rest, 0.0, law.turn_length * 4.0).unwrap();
            let (back, back_rest) = pair.to_bilinear().unwrap();
            prop_assert_eq!(back_rest, rest);
            prop_assert!((back.k1 - law.k1).abs() <= 1e-9 * law.k1);
            prop_assert!((back.k2 - law.k2).abs() <= 1e-9 * law.k2);
            prop_assert!((back.k_compression - law.k_compression).abs() <= 1e-9 * law.k_compression);
            prop_assert_eq!(back.turn_length, law.turn_length);
        }
    }

    #[test]
    fn ppu_pair_second_spring_compressing_fails() {
        let law = Bilinear { k1: 1.0, k2: 10.0, turn_length: 1.2, k_compression: 1.0 };
        let mut pair = PpuBilinearPair::from_bilinear(&law, 1.0, 0.0, 3.0).unwrap();
        pair.second.comp_force = 0.5;
        assert_eq!(pair.to_bilinear(), Err(PpuDecomposeError::SecondSpringCompresses));
    }

    #[test]
    fn ppu_pair_saturates_beyond_range_works() {
        let law = Bilinear { k1: 1.0, k2: 10.0, turn_length: 1.2, k_compression: 2.0 };
        let pair = PpuBilinearPair::from_bilinear(&law, 1.0, 0.5, 3.0).unwrap();
        assert!((pair.force(5.0) - law.force(3.0, 1.0)).abs() < 1e-12);
        assert!((pair.force(0.1) - law.force(0.5, 1.0)).abs() < 1e-12);
    }
}
