//! The `[scalpel]` table: the blade a scene's tool can become, and the tissue's resistance
//! to it (`docs/scene-format.md`, [`ScalpelSettings`]).

use super::section::FieldError;
use crate::incision::{ScalpelSettings, Toughness};
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScalpel {
    blade_length: Option<f64>,
    puncture_force: Option<f64>,
    skin_toughness: Option<f64>,
    fat_toughness: Option<f64>,
    muscle_toughness: Option<f64>,
    force_speed: Option<f64>,
}

/// Longest cutting edge, m.
pub const MAX_BLADE_LENGTH_M: f64 = 0.05;
/// Shortest cutting edge, m.
pub const MIN_BLADE_LENGTH_M: f64 = 0.001;

fn bounded(field: &str, value: Option<f64>, default: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, FieldError> {
    let v = value.unwrap_or(default);
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(FieldError::new(format!("scalpel.{field}"), format!("{v} is outside {lo} to {hi} {unit}")))
    }
}

/// Checks a `[scalpel]` table (`None`: absent, the scene has no scalpel).
pub(super) fn scalpel(raw: Option<RawScalpel>) -> Result<Option<ScalpelSettings>, FieldError> {
    let Some(raw) = raw else { return Ok(None) };
    let d = ScalpelSettings::default();
    let t = Toughness::default();
    Ok(Some(ScalpelSettings {
        blade_length: bounded(
            "blade_length",
            raw.blade_length,
            d.blade_length,
            MIN_BLADE_LENGTH_M,
            MAX_BLADE_LENGTH_M,
            "m",
        )?,
        puncture_force: bounded("puncture_force", raw.puncture_force, d.puncture_force, 0.01, 200.0, "N")?,
        toughness: Toughness {
            skin: bounded("skin_toughness", raw.skin_toughness, t.skin, 0.0, 1e5, "J/m2")?,
            fat: bounded("fat_toughness", raw.fat_toughness, t.fat, 0.0, 1e5, "J/m2")?,
            muscle: bounded("muscle_toughness", raw.muscle_toughness, t.muscle, 0.0, 1e5, "J/m2")?,
        },
        force_speed: bounded("force_speed", raw.force_speed, d.force_speed, 1e-4, 1.0, "m/s")?,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Option<ScalpelSettings>, FieldError> {
        #[derive(Deserialize)]
        struct Wrap {
            scalpel: Option<RawScalpel>,
        }
        scalpel(toml::from_str::<Wrap>(text).expect("well-formed").scalpel)
    }

    #[test]
    fn scalpel_table_defaults_and_values_works() {
        assert_eq!(parse(""), Ok(None));
        assert_eq!(parse("[scalpel]\n"), Ok(Some(ScalpelSettings::default())));
        let s = parse("[scalpel]\nblade_length = 0.02\npuncture_force = 1.22\n").unwrap().unwrap();
        assert_eq!((s.blade_length, s.puncture_force), (0.02, 1.22));
    }

    #[test]
    fn scalpel_table_refuses_out_of_range_values_fails() {
        for (body, field) in [
            ("blade_length = 0.0", "scalpel.blade_length"),
            ("blade_length = 1.0", "scalpel.blade_length"),
            ("puncture_force = nan", "scalpel.puncture_force"),
            ("skin_toughness = -1.0", "scalpel.skin_toughness"),
            ("force_speed = inf", "scalpel.force_speed"),
        ] {
            let e = parse(&format!("[scalpel]\n{body}\n")).expect_err(body);
            assert_eq!(e.field, field, "{body}");
            assert!(e.message.contains("outside"), "{}", e.message);
        }
    }
}
