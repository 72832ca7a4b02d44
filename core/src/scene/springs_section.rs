//! The scene's `[model.springs]` table: the skin, fat and muscle springs of a generated limb,
//! as `lamina fit --scene` fitted them to the tissue targets for this scene's grid.
//!
//! ```toml
//! [model.springs]
//! fit_seed = 2008
//! skin = { k1 = 304.06, k2 = 27974.5, turn_strain = 0.281 }   # N/m, N/m, unitless
//! fat = { k = 1.6666, k_compression = 60.0 }                   # N/m; k_compression optional
//! muscle = { k1 = 1100.6, k2 = 7939.4, turn_strain = 0.0964 }   # k_compression optional (default k1)
//! ```

use super::section::FieldError;
use crate::generator::{Materials, SpringMaterial};
use serde::Deserialize;

/// A generated limb's springs, fitted by `lamina fit` (compression stiffness = k1, as the
/// tensile fit tests them; fat may have its own, fitted to in-vivo indentation). Damping and
/// density stay the generator's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSprings {
    /// Seed of the annealing that fitted them (`lamina fit --seed`).
    pub fit_seed: u64,
    /// Skin: bilinear.
    pub skin: SpringMaterial,
    /// Fat: linear in tension, with its own compression stiffness when fitted to indentation
    /// ([`fat_material`]).
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
            SpringMaterial::Bilinear { k1, k2, turn_strain, k_compression } if k1 == k2 && turn_strain == 0.0 => {
                format!("{{ k = {k1:.6}, k_compression = {k_compression:.6} }}")
            }
            SpringMaterial::Bilinear { k1, k2, turn_strain, k_compression } if k_compression == k1 => {
                format!("{{ k1 = {k1:.6}, k2 = {k2:.6}, turn_strain = {turn_strain:.6} }}")
            }
            SpringMaterial::Bilinear { k1, k2, turn_strain, k_compression } => format!(
                "{{ k1 = {k1:.6}, k2 = {k2:.6}, turn_strain = {turn_strain:.6}, k_compression = {k_compression:.6} }}"
            ),
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
    k_compression: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLinear {
    k: f64,
    k_compression: Option<f64>,
}

/// Fat's spring: `k` N/m in tension; in compression `k_compression` N/m when given (fat held
/// by its septa and fascia resists being pressed more than being pulled), else `k`.
pub fn fat_material(k: f64, k_compression: Option<f64>) -> SpringMaterial {
    match k_compression {
        None => SpringMaterial::Linear { stiffness: k },
        Some(kc) => SpringMaterial::Bilinear { k1: k, k2: k, turn_strain: 0.0, k_compression: kc },
    }
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
            k_compression: r.k_compression.map_or(Ok(k1), |kc| positive(kc, &format!("model.springs.{name}")))?,
        })
    };
    Ok(SceneSprings {
        fit_seed: raw.fit_seed,
        skin: bilinear(&raw.skin, "skin")?,
        fat: fat_material(
            positive(raw.fat.k, "model.springs.fat")?,
            raw.fat.k_compression.map(|kc| positive(kc, "model.springs.fat")).transpose()?,
        ),
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
        // Fat with its own compression stiffness round-trips as `{ k, k_compression }`.
        let muscle = SpringMaterial::Bilinear { k1: 1_000.0, k2: 8_000.0, turn_strain: 0.1, k_compression: 9_000.0 };
        let confined = SceneSprings { fat: fat_material(1.5, Some(60.0)), muscle, ..s };
        assert!(confined.to_toml().contains("fat = { k = 1.500000, k_compression = 60.000000 }"));
        let w: Wrap = toml::from_str(&confined.to_toml()).unwrap();
        assert_eq!(scene_springs(w.model.springs), Ok(confined));
    }

    #[test]
    fn fat_with_compression_stiffness_pulls_at_k_and_pushes_at_kc_works() {
        let law = fat_material(2.0, Some(70.0)).law(1.0);
        assert_eq!(law.force(1.5, 1.0), 2.0 * 0.5);
        assert_eq!(law.force(0.5, 1.0), -70.0 * 0.5);
        assert_eq!(law.tangent(1.5, 1.0), 2.0);
        assert_eq!(fat_material(2.0, None).law(1.0).force(0.5, 1.0), -2.0 * 0.5);
    }

    #[test]
    fn springs_table_refuses_non_positive_values_fails() {
        let raw = RawSprings {
            fit_seed: 1,
            skin: RawBilinear { k1: 1.0, k2: 2.0, turn_strain: 0.1, k_compression: None },
            fat: RawLinear { k: f64::NAN, k_compression: None },
            muscle: RawBilinear { k1: 1.0, k2: 2.0, turn_strain: 0.1, k_compression: None },
        };
        assert_eq!(scene_springs(raw).unwrap_err().field, "model.springs.fat");
    }
}
