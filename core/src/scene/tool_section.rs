//! The scene's `[effects.tool]` table: the haptic tool, scripted or driven by the haptics
//! process.

use super::section::{FieldError, finite3};
use super::tool_settings::{ToolSettings, ToolSource};
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTool {
    radius: f64,
    stiffness: Option<f64>,
    stiffness_per_area: Option<f64>,
    source: String,
    start: Option<[f64; 3]>,
    velocity: Option<[f64; 3]>,
    device_origin: Option<[f64; 3]>,
    timeout_ms: Option<f64>,
    min_radius: Option<f64>,
    device_scale: Option<f64>,
    force_scale: Option<f64>,
}

/// The `[effects.tool]` table. Given `stiffness_per_area`, the per-node `stiffness` is left 0
/// for the scene's reader to set once it has the model ([`ToolSettings::stiffness_per_area`]).
pub(super) fn tool_settings(t: RawTool) -> Result<ToolSettings, FieldError> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let (stiffness, stiffness_per_area) = match (t.stiffness, t.stiffness_per_area) {
        (Some(k), None) => (k, None),
        (None, Some(kappa)) => (0.0, Some(kappa)),
        (Some(_), Some(_)) => {
            return Err(FieldError::new(
                "effects.tool.stiffness_per_area",
                "give stiffness or stiffness_per_area, not both",
            ));
        }
        (None, None) => {
            return Err(FieldError::new("effects.tool.stiffness", "required (or stiffness_per_area)"));
        }
    };
    if !(positive(t.radius)
        && stiffness_per_area.is_none_or(positive)
        && (stiffness_per_area.is_some() || positive(stiffness)))
    {
        return Err(FieldError::new("effects.tool", "radius and stiffness must be finite and positive"));
    }
    let source = match t.source.as_str() {
        "scripted" => scripted(&t)?,
        "haptics" => haptics(&t)?,
        _ => return Err(FieldError::new("effects.tool.source", "\"scripted\" or \"haptics\"")),
    };
    Ok(ToolSettings { radius: t.radius, stiffness, stiffness_per_area, source })
}

fn scripted(t: &RawTool) -> Result<ToolSource, FieldError> {
    for (key, given) in [
        ("min_radius", t.min_radius.is_some()),
        ("device_scale", t.device_scale.is_some()),
        ("force_scale", t.force_scale.is_some()),
    ] {
        if given {
            return Err(FieldError::new(format!("effects.tool.{key}"), "only for source = \"haptics\""));
        }
    }
    let start = t.start.ok_or_else(|| FieldError::new("effects.tool.start", "required when scripted"))?;
    let velocity = t.velocity.unwrap_or([0.0; 3]);
    if !(finite3(&start) && finite3(&velocity)) {
        return Err(FieldError::new("effects.tool", "start and velocity must be finite"));
    }
    Ok(ToolSource::Scripted { start, velocity })
}

fn haptics(t: &RawTool) -> Result<ToolSource, FieldError> {
    let device_origin = t
        .device_origin
        .ok_or_else(|| FieldError::new("effects.tool.device_origin", "required when source = \"haptics\""))?;
    let timeout_s = t.timeout_ms.unwrap_or(100.0) * 1e-3;
    if !(finite3(&device_origin) && timeout_s.is_finite() && timeout_s > 0.0) {
        return Err(FieldError::new("effects.tool", "device_origin finite and timeout_ms positive"));
    }
    let min_radius = t.min_radius.unwrap_or(t.radius);
    if !(min_radius.is_finite() && min_radius > 0.0 && min_radius <= t.radius) {
        return Err(FieldError::new("effects.tool.min_radius", "finite, positive and at most radius"));
    }
    let (device_scale, force_scale) = (t.device_scale.unwrap_or(1.0), t.force_scale.unwrap_or(1.0));
    for (key, value) in [("device_scale", device_scale), ("force_scale", force_scale)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(FieldError::new(format!("effects.tool.{key}"), "finite and positive"));
        }
    }
    Ok(ToolSource::Haptics { device_origin, timeout_s, min_radius, device_scale, force_scale })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tool_section_bad_values_name_the_field_fails() {
        let cases = [
            ("source = \"haptics\"\nradius = 0.01\nstiffness = 200.0\n", "effects.tool.device_origin"),
            ("source = \"scripted\"\nradius = 0.01\nstiffness = 200.0\n", "effects.tool.start"),
            ("source = \"wand\"\nradius = 0.01\nstiffness = 200.0\n", "effects.tool.source"),
            ("source = \"scripted\"\nradius = -0.01\nstiffness = 200.0\nstart = [0.0, 0.0, 0.0]\n", "effects.tool"),
            ("source = \"scripted\"\nradius = nan\nstiffness = 200.0\nstart = [0.0, 0.0, 0.0]\n", "effects.tool"),
            (
                "source = \"haptics\"\nradius = 0.01\nstiffness = 200.0\ndevice_origin = [0.0, 0.0, 0.0]\nmin_radius = 0.02\n",
                "effects.tool.min_radius",
            ),
            (
                "source = \"haptics\"\nradius = 0.01\nstiffness = 200.0\ndevice_origin = [0.0, 0.0, 0.0]\nmin_radius = 0.0\n",
                "effects.tool.min_radius",
            ),
            (
                "source = \"scripted\"\nradius = 0.01\nstiffness = 200.0\nstart = [0.0, 0.0, 0.0]\nmin_radius = 0.005\n",
                "effects.tool.min_radius",
            ),
            (
                "source = \"scripted\"\nradius = 0.01\nstiffness = 200.0\nstart = [0.0, 0.0, 0.0]\ndevice_scale = 2.0\n",
                "effects.tool.device_scale",
            ),
            (
                "source = \"haptics\"\nradius = 0.01\nstiffness = 200.0\ndevice_origin = [0.0, 0.0, 0.0]\ndevice_scale = 0.0\n",
                "effects.tool.device_scale",
            ),
            (
                "source = \"haptics\"\nradius = 0.01\nstiffness = 200.0\ndevice_origin = [0.0, 0.0, 0.0]\nforce_scale = inf\n",
                "effects.tool.force_scale",
            ),
            ("source = \"scripted\"\nradius = 0.01\nstart = [0.0, 0.0, 0.0]\n", "effects.tool.stiffness"),
            (
                "source = \"scripted\"\nradius = 0.01\nstiffness = 200.0\nstiffness_per_area = 9e6\nstart = [0.0, 0.0, 0.0]\n",
                "effects.tool.stiffness_per_area",
            ),
            (
                "source = \"scripted\"\nradius = 0.01\nstiffness_per_area = -9e6\nstart = [0.0, 0.0, 0.0]\n",
                "effects.tool",
            ),
            (
                "source = \"scripted\"\nradius = 0.01\nstiffness_per_area = nan\nstart = [0.0, 0.0, 0.0]\n",
                "effects.tool",
            ),
        ];
        for (body, field) in cases {
            let raw: RawTool = toml::from_str(body).expect("well-formed");
            assert_eq!(tool_settings(raw).expect_err(body).field, field, "{body}");
        }
    }
}
