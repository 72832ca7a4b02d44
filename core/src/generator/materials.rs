//! Per-tissue spring laws, dashpots and densities of a generated model (defaults and
//! their sources on [`Materials`]).

use crate::law::{Bilinear, SpringLaw};
use crate::model::Tissue;

/// A spring law given relative to each spring's rest length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpringMaterial {
    /// `F = k (L − L0)`.
    Linear {
        /// Stiffness, N/m.
        stiffness: f64,
    },
    /// The paper's bilinear spring; turning length `L0 · (1 + turn_strain)`.
    Bilinear {
        /// First-phase stiffness, N/m.
        k1: f64,
        /// Second-phase stiffness, N/m.
        k2: f64,
        /// Strain at the turning point, unitless (≥ 0).
        turn_strain: f64,
        /// Compression stiffness, N/m.
        k_compression: f64,
    },
}

impl SpringMaterial {
    /// The law of a spring of rest length `rest_length` (m).
    pub fn law(&self, rest_length: f64) -> SpringLaw {
        match *self {
            SpringMaterial::Linear { stiffness } => SpringLaw::Linear { stiffness },
            SpringMaterial::Bilinear { k1, k2, turn_strain, k_compression } => {
                SpringLaw::Bilinear(Bilinear { k1, k2, turn_length: rest_length * (1.0 + turn_strain), k_compression })
            }
        }
    }

    /// All parameters finite and non-negative.
    pub fn is_valid(&self) -> bool {
        let values: &[f64] = match self {
            SpringMaterial::Linear { stiffness } => &[*stiffness],
            SpringMaterial::Bilinear { k1, k2, turn_strain, k_compression } => {
                &[*k1, *k2, *turn_strain, *k_compression]
            }
        };
        values.iter().all(|v| v.is_finite() && *v >= 0.0)
    }
}

/// What one tissue layer is made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TissueMaterial {
    /// Law of the layer's springs.
    pub spring: SpringMaterial,
    /// Dashpot along each spring, N·s/m (≥ 0).
    pub damping: f64,
    /// Density, kg/m³ (> 0): a node's mass is the density times its share of the layer's
    /// element volumes.
    pub density: f64,
}

impl TissueMaterial {
    /// Finite, non-negative parameters and a positive density.
    pub fn is_valid(&self) -> bool {
        self.spring.is_valid()
            && self.damping.is_finite()
            && self.damping >= 0.0
            && self.density.is_finite()
            && self.density > 0.0
    }
}

/// The materials of the three soft-tissue layers.
///
/// # Defaults and where they come from
///
/// The paper's Table 1 gives the fitted spring properties of its 39 × 10 limb (grid cells
/// about 1.5 cm × 1.6 cm) in "KPa": skin K1 0.118, K2 18.51, turning point at strain 0.41;
/// muscle K1 0.03, K2 2.53, turning strain 1.56; fat K 0.0009. Read as kN/m they agree
/// with `k ≈ E·A/L` estimates for springs of that size:
/// - skin, 2 mm thick, toe modulus E ≈ 0.1 MPa, linear-region modulus ≈ 15–20 MPa, per
///   spring `k ≈ E·t`: k1 ≈ 200 N/m, k2 ≈ 3·10⁴ N/m; Table 1 → **k1 = 118 N/m,
///   k2 = 18 510 N/m, turning strain 0.41**;
/// - passive muscle, toe modulus E ≈ 5–10 kPa, `k ≈ E·l` with l ≈ 0.5–1 cm: 25–100 N/m;
///   Table 1 → **k1 = 30 N/m, k2 = 2 530 N/m, turning strain 1.56**;
/// - fat, E ≈ 1–2 kPa, l ≈ 0.8 cm: 8–16 N/m. Table 1's 0.9 N/m would be ten times softer
///   than that; we take **10 N/m**, still by far the softest layer.
///
/// Compression stiffness is k1 (the paper splits CompForce evenly between the two
/// springs of a bilinear pair, i.e. compression is as soft as the first phase).
/// Dashpots are about 5 % of critical for a typical node of each layer: skin and muscle
/// 0.02 N·s/m, fat 0.01 N·s/m. Densities: skin 1100, fat 920, muscle 1060 kg/m³.
/// The fitting step (DESIGN.md §5) replaces the springs; these are starting values.
///
/// Per-spring stiffness depends on the grid (the paper's Table 2): these values are for
/// the default 39 × 10 limb, which under gravity with the bone held settles with at most
/// about 7 mm displacement. The same springs on an 18 × 5 grid (cells four times larger)
/// make a limb about three times softer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Materials {
    /// Skin: bilinear, k1 118 N/m, k2 18 510 N/m, turning strain 0.41, compression 118 N/m;
    /// 0.02 N·s/m; 1100 kg/m³.
    pub skin: TissueMaterial,
    /// Fat: linear 10 N/m; 0.01 N·s/m; 920 kg/m³.
    pub fat: TissueMaterial,
    /// Muscle: bilinear, k1 30 N/m, k2 2 530 N/m, turning strain 1.56, compression 30 N/m;
    /// 0.02 N·s/m; 1060 kg/m³.
    pub muscle: TissueMaterial,
}

impl Default for Materials {
    fn default() -> Self {
        Self {
            skin: TissueMaterial {
                spring: SpringMaterial::Bilinear { k1: 118.0, k2: 18_510.0, turn_strain: 0.41, k_compression: 118.0 },
                damping: 0.02,
                density: 1100.0,
            },
            fat: TissueMaterial { spring: SpringMaterial::Linear { stiffness: 10.0 }, damping: 0.01, density: 920.0 },
            muscle: TissueMaterial {
                spring: SpringMaterial::Bilinear { k1: 30.0, k2: 2_530.0, turn_strain: 1.56, k_compression: 30.0 },
                damping: 0.02,
                density: 1060.0,
            },
        }
    }
}

impl Materials {
    /// The material of spring layer `layer` (skin, fat or muscle; anything else is muscle).
    pub fn of_layer(&self, layer: u16) -> &TissueMaterial {
        match layer {
            super::layers::SKIN => &self.skin,
            super::layers::FAT => &self.fat,
            _ => &self.muscle,
        }
    }

    /// The first invalid tissue, if any.
    pub fn first_invalid(&self) -> Option<Tissue> {
        [(Tissue::Skin, &self.skin), (Tissue::Fat, &self.fat), (Tissue::Muscle, &self.muscle)]
            .into_iter()
            .find(|(_, m)| !m.is_valid())
            .map(|(t, _)| t)
    }
}
