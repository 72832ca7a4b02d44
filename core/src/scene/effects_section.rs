//! The scene's `[effects]` table: gravity, damping, bone, loads, drag handles, the guard, the
//! skin volume term and the haptic tool (its own section reader, [`super::tool_section`]).

use super::section::{FieldError, finite3, non_negative};
use super::tool_section::{RawTool, tool_settings};
use super::tool_settings::ToolSettings;
use crate::solver::{BoneMotion, DragHandle, Effects, GuardSettings, PointLoad};
use serde::Deserialize;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEffects {
    gravity: Option<[f64; 3]>,
    viscous_damping: Option<f64>,
    #[serde(default)]
    spring_damping: bool,
    #[serde(default)]
    bone: bool,
    bone_motion: Option<RawBoneMotion>,
    #[serde(default)]
    loads: Vec<RawLoad>,
    #[serde(default)]
    handles: Vec<RawHandle>,
    /// `true`, `false` or a table of settings (read by [`guard`], so that an unknown key in
    /// the table is named).
    guard: Option<toml::Value>,
    tool: Option<RawTool>,
    skin_volume: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoneMotion {
    amplitude: [f64; 3],
    frequency_hz: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLoad {
    node: u32,
    force: [f64; 3],
    #[serde(default)]
    ramp_s: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHandle {
    node: u32,
    target: [f64; 3],
    stiffness: f64,
    #[serde(default)]
    damping: f64,
}

/// `guard = { ... }`: settings over the defaults.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGuardSettings {
    max_speed: Option<f64>,
    max_displacement: Option<f64>,
    retries: Option<u32>,
}

/// The `[effects]` table: the effects in the loop, and the haptic tool's settings when the
/// scene has one (a scripted tool is in the effects from the start; a haptics-driven one
/// enters the loop with the first command).
pub(super) fn effects(raw: RawEffects) -> Result<(Effects, Option<ToolSettings>), FieldError> {
    if raw.gravity.as_ref().is_some_and(|g| !finite3(g)) {
        return Err(FieldError::new("effects.gravity", "must be finite"));
    }
    let viscous_damping = non_negative(raw.viscous_damping, "effects.viscous_damping")?;
    if raw.skin_volume.is_some_and(|k| !(k.is_finite() && k > 0.0)) {
        return Err(FieldError::new("effects.skin_volume", "must be finite and positive (Pa)"));
    }
    let loads = raw.loads.iter().enumerate().map(load).collect::<Result<_, _>>()?;
    let handles = raw.handles.iter().enumerate().map(handle).collect::<Result<_, _>>()?;
    let bone_motion = raw.bone_motion.map(bone_motion).transpose()?;
    if bone_motion.is_some() && !raw.bone {
        return Err(FieldError::new("effects.bone_motion", "moves the bone: needs bone = true"));
    }
    let guard = raw.guard.map(guard).transpose()?.flatten();
    let tool = raw.tool.map(tool_settings).transpose()?;
    let effects = Effects {
        gravity: raw.gravity,
        viscous_damping,
        spring_damping: raw.spring_damping,
        bone: raw.bone,
        bone_motion,
        loads,
        handles,
        guard,
        tool: tool.and_then(|t| t.initial_sphere()),
        skin_volume: raw.skin_volume,
    };
    Ok((effects, tool))
}

fn bone_motion(m: RawBoneMotion) -> Result<BoneMotion, FieldError> {
    if !(finite3(&m.amplitude) && m.frequency_hz.is_finite()) {
        return Err(FieldError::new("effects.bone_motion", "must be finite"));
    }
    Ok(BoneMotion { amplitude: m.amplitude, frequency_hz: m.frequency_hz })
}

fn load((i, l): (usize, &RawLoad)) -> Result<PointLoad, FieldError> {
    if !(finite3(&l.force) && l.ramp_s.is_finite() && l.ramp_s >= 0.0) {
        return Err(FieldError::new(format!("effects.loads[{i}]"), "force must be finite and ramp_s finite, >= 0"));
    }
    Ok(PointLoad { node: l.node, force: l.force, ramp_s: l.ramp_s })
}

fn handle((i, h): (usize, &RawHandle)) -> Result<DragHandle, FieldError> {
    let ok = finite3(&h.target)
        && h.stiffness.is_finite()
        && h.stiffness >= 0.0
        && h.damping.is_finite()
        && h.damping >= 0.0;
    if !ok {
        return Err(FieldError::new(
            format!("effects.handles[{i}]"),
            "target, stiffness and damping must be finite, >= 0",
        ));
    }
    Ok(DragHandle { node: h.node, target: h.target, stiffness: h.stiffness, damping: h.damping })
}

/// `guard = true | false` or a table of settings over the defaults; `None` when off.
fn guard(raw: toml::Value) -> Result<Option<GuardSettings>, FieldError> {
    let settings: RawGuardSettings = match raw {
        toml::Value::Boolean(false) => return Ok(None),
        toml::Value::Boolean(true) => return Ok(Some(GuardSettings::default())),
        toml::Value::Table(t) => toml::Value::Table(t)
            .try_into()
            .map_err(|e: toml::de::Error| FieldError::new("effects.guard", e.message().trim()))?,
        _ => {
            return Err(FieldError::new(
                "effects.guard",
                "true, false or a table { max_speed, max_displacement, retries }",
            ));
        }
    };
    let d = GuardSettings::default();
    let g = GuardSettings {
        max_speed: settings.max_speed.unwrap_or(d.max_speed),
        max_displacement: settings.max_displacement.unwrap_or(d.max_displacement),
        retries: settings.retries.unwrap_or(d.retries),
    };
    if !(g.max_speed > 0.0 && g.max_displacement > 0.0) {
        return Err(FieldError::new("effects.guard", "max_speed and max_displacement must be positive"));
    }
    Ok(Some(g))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(body: &str) -> Result<(Effects, Option<ToolSettings>), FieldError> {
        effects(toml::from_str(body).expect("well-formed"))
    }

    #[test]
    fn effects_section_values_works() {
        let (e, tool) = parse("").unwrap();
        assert_eq!(e, Effects::default());
        assert!(tool.is_none());
        let text = "gravity = [0.0, -9.81, 0.0]\nviscous_damping = 0.5\nbone = true\nguard = { max_speed = 3.0 }\n\
                    [[loads]]\nnode = 4\nforce = [0.0, 1.0, 0.0]\n[[handles]]\nnode = 2\ntarget = [0.0, 0.1, 0.0]\nstiffness = 5.0\n";
        let (e, _) = parse(text).unwrap();
        assert_eq!(e.gravity, Some([0.0, -9.81, 0.0]));
        assert_eq!(e.viscous_damping, Some(0.5));
        assert!(e.bone);
        assert_eq!(e.guard, Some(GuardSettings { max_speed: 3.0, ..GuardSettings::default() }));
        assert_eq!(e.loads, vec![PointLoad { node: 4, force: [0.0, 1.0, 0.0], ramp_s: 0.0 }]);
        assert_eq!(e.handles, vec![DragHandle { node: 2, target: [0.0, 0.1, 0.0], stiffness: 5.0, damping: 0.0 }]);
        assert_eq!(parse("guard = false\n").unwrap().0.guard, None);
        assert_eq!(parse("guard = true\n").unwrap().0.guard, Some(GuardSettings::default()));
    }

    #[test]
    fn effects_section_bad_values_name_the_field_fails() {
        let cases = [
            ("gravity = [0.0, nan, 0.0]\n", "effects.gravity"),
            ("viscous_damping = -1.0\n", "effects.viscous_damping"),
            ("skin_volume = 0.0\n", "effects.skin_volume"),
            ("bone_motion = { amplitude = [0.0, inf, 0.0], frequency_hz = 1.0 }\n", "effects.bone_motion"),
            (
                "[[loads]]\nnode = 1\nforce = [0.0, 0.0, 0.0]\n[[loads]]\nnode = 1\nforce = [0.0, 0.0, 0.0]\nramp_s = -1.0\n",
                "effects.loads[1]",
            ),
            ("[[handles]]\nnode = 1\ntarget = [0.0, 0.0, 0.0]\nstiffness = -2.0\n", "effects.handles[0]"),
            ("guard = { max_speed = 0.0 }\n", "effects.guard"),
            ("guard = { max_speed = 3.0, bogus_key = 3 }\n", "effects.guard"),
            ("guard = 1\n", "effects.guard"),
        ];
        for (body, field) in cases {
            assert_eq!(parse(body).expect_err(body).field, field, "{body}");
        }
        let unknown = parse("guard = { max_speed = 3.0, bogus_key = 3 }\n").unwrap_err();
        assert!(unknown.message.contains("bogus_key"), "{}", unknown.message);
    }
}
