//! The scene's `[model.springs]` table: the skin, fat and muscle springs of a generated limb,
//! as `lamina fit --scene` fitted them to the tissue targets for this scene's grid.
//!
//! ```toml
//! [model.springs]
//! fit_seed = 2008
//! skin = { k1 = 304.06, k2 = 27974.5, turn_strain = 0.281 }   # N/m, N/m, unitless
//! fat = { k = 1.6666 }                                         # N/m
//! muscle = { k1 = 1100.6, k2 = 7939.4, turn_strain = 0.0964 }
//! ```

use super::section::FieldError;
use crate::generator::{Materials, SpringMaterial};
use serde::Deserialize;

/// A generated limb's springs, fitted by `lamina fit` (compression stiffness = k1, as the fit
/// tests them). Damping and density stay the generator's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSprings {
    /// Seed of the annealing that fitted them (`lamina fit --seed`).
    pub fit_seed: u64,
    /// Skin: bilinear.
    pub skin: SpringMaterial,
    /// Fat: linear.
    pub fat: SpringMaterial,
    /// Muscle: bilinear.
    pub muscle: SpringMaterial,
}

impl SceneSprings {
    /// The generator's materials with these springs.
    pub fn materials(&self) -> Materials {
        let mut m = Materials::default();
        m.skin.spring = self.skin;
        m.fat.spring = self.fat;
        m.muscle.spring = self.muscle;
        m
    }

    /// The `[model.springs]` table of these springs, as a scene file writes it.
    pub fn to_toml(&self) -> String {
        let law = |m: &SpringMaterial| match *m {
            SpringMaterial::Linear { stiffness } => format!("{{ k = {stiffness:.6} }}"),
            SpringMaterial::Bilinear { k1, k2, turn_strain, .. } => {
                format!("{{ k1 = {k1:.6}, k2 = {k2:.6}, turn_strain = {turn_strain:.6} }}")
            }
        };
        format!(
            "[model.springs]\nfit_seed = {}\nskin = {}\nfat = {}\nmuscle = {}\n",
            self.fit_seed,
            law(&self.skin),
            law(&self.fat),
            law(&self.muscle)
        )
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSprings {
    fit_seed: u64,
    skin: RawBilinear,
    fat: RawLinear,
    muscle: RawBilinear,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBilinear {
    k1: f64,
    k2: f64,
    turn_strain: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLinear {
    k: f64,
}

/// Checks a `[model.springs]` table: every stiffness and turning strain finite and positive.
pub(super) fn scene_springs(raw: RawSprings) -> Result<SceneSprings, FieldError> {
    let positive = |v: f64, field: &str| {
        if v.is_finite() && v > 0.0 { Ok(v) } else { Err(FieldError::new(field, "must be finite and positive")) }
    };
    let bilinear = |r: &RawBilinear, name: &str| -> Result<SpringMaterial, FieldError> {
        let k1 = positive(r.k1, &format!("model.springs.{name}"))?;
        Ok(SpringMaterial::Bilinear {
            k1,
            k2: positive(r.k2, &format!("model.springs.{name}"))?,
            turn_strain: positive(r.turn_strain, &format!("model.springs.{name}"))?,
            k_compression: k1,
        })
    };
    Ok(SceneSprings {
        fit_seed: raw.fit_seed,
        skin: bilinear(&raw.skin, "skin")?,
        fat: SpringMaterial::Linear { stiffness: positive(raw.fat.k, "model.springs.fat")? },
        muscle: bilinear(&raw.muscle, "muscle")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn springs_table_round_trips_and_sets_only_the_springs_works() {
        let s = SceneSprings {
            fit_seed: 7,
            skin: SpringMaterial::Bilinear { k1: 300.0, k2: 28_000.0, turn_strain: 0.28, k_compression: 300.0 },
            fat: SpringMaterial::Linear { stiffness: 1.5 },
            muscle: SpringMaterial::Bilinear { k1: 1_000.0, k2: 8_000.0, turn_strain: 0.1, k_compression: 1_000.0 },
        };
        #[derive(Deserialize)]
        struct Wrap {
            model: WrapModel,
        }
        #[derive(Deserialize)]
        struct WrapModel {
            springs: RawSprings,
        }
        let w: Wrap = toml::from_str(&s.to_toml()).unwrap();
        assert_eq!(scene_springs(w.model.springs), Ok(s));
        let m = s.materials();
        let d = Materials::default();
        assert_eq!((m.skin.spring, m.fat.spring, m.muscle.spring), (s.skin, s.fat, s.muscle));
        assert_eq!((m.skin.damping, m.fat.density), (d.skin.damping, d.fat.density));
    }

    #[test]
    fn springs_table_refuses_non_positive_values_fails() {
        let raw = RawSprings {
            fit_seed: 1,
            skin: RawBilinear { k1: 1.0, k2: 2.0, turn_strain: 0.1 },
            fat: RawLinear { k: f64::NAN },
            muscle: RawBilinear { k1: 1.0, k2: 2.0, turn_strain: 0.1 },
        };
        assert_eq!(scene_springs(raw).unwrap_err().field, "model.springs.fat");
    }
}
