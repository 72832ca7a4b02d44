//! The scene file (TOML) and its loading, with errors that name file, line and column. Each
//! table has its own reader (`model_section.rs`, `solver_section.rs`, `effects_section.rs`,
//! `tool_section.rs`, `realtime_section.rs`); this file puts them together.

use super::effects_section::{RawEffects, effects};
use super::in_vivo::{InVivo, RawInVivo, in_vivo};
use super::model_section::{ModelSource, RawModel, model_source};
use super::realtime_section::{RawRealtime, RealtimeSettings, realtime_settings};
use super::scalpel_section::{RawScalpel, scalpel};
use super::section::FieldError;
use super::solver_section::{RawSolver, solver_parameters};
use super::tool_settings::ToolSettings;
use super::visual_section::{RawVisual, VisualSection, visual_section};
use crate::model::{Model, NodeKind};
use crate::solver::{Effects, IntegrationParameters};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The built-in default scene, also shipped as `config/scenes/default.toml`.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../../../config/scenes/default.toml");

/// Floating-point precision of the simulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// `f32`: the real-time default.
    F32,
    /// `f64`: reference runs.
    F64,
}

/// A loaded scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Display name.
    pub name: String,
    /// Tick rate of the core loop, Hz. Default 1000.
    pub rate_hz: u32,
    /// Precision. Default f32.
    pub precision: Precision,
    /// Model source.
    pub model: ModelSource,
    /// Solver settings (`dt = 1 / rate_hz`).
    pub solver: IntegrationParameters,
    /// Effects in the loop.
    pub effects: Effects,
    /// Real-time settings.
    pub realtime: RealtimeSettings,
    /// The haptic tool (`[effects.tool]`), when the scene has one. A scripted tool is also in
    /// `effects.tool`; a haptics-driven one enters the loop with the first command.
    pub tool: Option<ToolSettings>,
    /// How the viewer draws the tissue (`[visual]`), when the scene says.
    pub visual: Option<VisualSection>,
    /// The living limb's skin pre-tension and muscle tone (`[in_vivo]`), applied when the
    /// model is built. Default: none.
    pub in_vivo: InVivo,
    /// The scalpel the scene's tool can become (`[scalpel]`); `None` when the scene has none.
    pub scalpel: Option<crate::incision::ScalpelSettings>,
    /// File the scene was read from (`None` for the built-in one).
    pub path: Option<PathBuf>,
}

/// Why a scene could not be loaded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SceneLoadError {
    /// The file could not be read.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: PathBuf,
        /// OS error text.
        message: String,
    },
    /// The TOML is malformed or a field has the wrong type or name.
    #[error("{path}:{line}:{column}: {message}")]
    Syntax {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A value is out of range.
    #[error("{path}{}: {field}: {message}", .line.map(|l| format!(":{l}")).unwrap_or_default())]
    Value {
        /// File.
        path: PathBuf,
        /// 1-based line of the field's key (or of the nearest enclosing one), when found.
        line: Option<usize>,
        /// Field, e.g. `effects.loads[2]`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The model named by the scene could not be built or read.
    #[error("{path}: model: {message}")]
    Model {
        /// File.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: Option<String>,
    rate_hz: Option<u32>,
    precision: Option<String>,
    model: Option<RawModel>,
    #[serde(default)]
    solver: RawSolver,
    #[serde(default)]
    effects: RawEffects,
    #[serde(default)]
    realtime: RawRealtime,
    visual: Option<RawVisual>,
    in_vivo: Option<RawInVivo>,
    scalpel: Option<RawScalpel>,
}

/// 1-based line and column of byte `offset` in `text` (for TOML errors).
pub(crate) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// `rate_hz`: the core loop's tick rate, Hz (default 1000).
fn rate(raw: Option<u32>) -> Result<u32, FieldError> {
    match raw.unwrap_or(1000) {
        r @ 1..=100_000 => Ok(r),
        _ => Err(FieldError::new("rate_hz", "must be between 1 and 100000 Hz")),
    }
}

/// `precision`: `"f32"` (default) or `"f64"`.
fn precision(raw: Option<&str>) -> Result<Precision, FieldError> {
    match raw.unwrap_or("f32") {
        "f32" => Ok(Precision::F32),
        "f64" => Ok(Precision::F64),
        _ => Err(FieldError::new("precision", "must be \"f32\" or \"f64\"")),
    }
}

/// 1-based line of dotted `field` (`effects.loads[2]`, `solver.threads`) in scene `text`:
/// the line of its key, or of the nearest enclosing key or array element found.
fn field_line(text: &str, field: &str) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let mut table = root.get_ref();
    let mut span = None;
    for part in field.split('.') {
        let (key, index) = match part.split_once('[') {
            Some((k, i)) => (k, i.trim_end_matches(']').parse::<usize>().ok()),
            None => (part, None),
        };
        let Some((k, v)) = table.get_key_value(key) else { break };
        span = Some(k.span());
        let mut value = v.get_ref();
        if let (Some(i), DeValue::Array(items)) = (index, value) {
            let Some(item) = items.get(i) else { break };
            span = Some(item.span());
            value = item.get_ref();
        }
        match value {
            DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    span.map(|s| line_column(text, s.start).0)
}

impl Scene {
    /// The built-in default scene.
    pub fn builtin_default() -> Self {
        Self::from_toml_str(DEFAULT_SCENE_TOML, None).expect("the built-in default scene is valid")
    }

    /// Reads a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneLoadError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneLoadError::Io { path: path.to_path_buf(), message: e.to_string() })?;
        Self::from_toml_str(&text, Some(path))
    }

    /// Parses scene text; `path` names it in errors and anchors relative model paths.
    pub fn from_toml_str(text: &str, path: Option<&Path>) -> Result<Self, SceneLoadError> {
        let file = path.map_or_else(|| PathBuf::from("<built-in default scene>"), Path::to_path_buf);
        let raw: RawScene = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((0, 0), |s| line_column(text, s.start));
            SceneLoadError::Syntax { path: file.clone(), line, column, message: e.message().to_string() }
        })?;
        let located = |e: FieldError| SceneLoadError::Value {
            path: file.clone(),
            line: field_line(text, &e.field),
            field: e.field,
            message: e.message,
        };
        let rate_hz = rate(raw.rate_hz).map_err(located)?;
        let precision = precision(raw.precision.as_deref()).map_err(located)?;
        let base = path.and_then(Path::parent).unwrap_or(Path::new("."));
        let model = model_source(raw.model, base).map_err(located)?;
        let (effects, tool) = effects(raw.effects).map_err(located)?;
        let tool_centre = tool.map(|t| match t.source {
            super::ToolSource::Scripted { start, .. } => start,
            super::ToolSource::Haptics { device_origin, .. } => device_origin,
        });
        let solver = solver_parameters(raw.solver, rate_hz, tool_centre).map_err(located)?;
        let realtime = realtime_settings(raw.realtime).map_err(located)?;
        let visual = visual_section(raw.visual, base).map_err(located)?;
        let in_vivo = in_vivo(raw.in_vivo).map_err(located)?;
        let scalpel = scalpel(raw.scalpel).map_err(located)?;
        let mut scene = Self {
            name: raw.name.unwrap_or_else(|| "unnamed".into()),
            rate_hz,
            precision,
            model,
            solver,
            effects,
            realtime,
            tool,
            visual,
            in_vivo,
            scalpel,
            path: path.map(Path::to_path_buf),
        };
        if let Some(per_area) = scene.tool.and_then(|t| t.stiffness_per_area) {
            // The per-node stiffness needs the model's skin: built here (as generated, before the
            // in-vivo settling moves it by a fraction of a millimetre), only for this key.
            let area = crate::solver::largest_skin_node_area(&scene.build_generated_model()?);
            let field = "effects.tool.stiffness_per_area";
            let stiffness = match area.map(|a| (a, per_area * a)) {
                None => Err(FieldError::new(
                    field,
                    "needs a model with an outer skin surface (\"skin_outer\") of some area",
                )),
                Some((a, k)) if !(k.is_finite() && k > 0.0) => Err(FieldError::new(
                    field,
                    format!("times the largest skin node area ({a:.3e} m²) is not a finite, positive stiffness"),
                )),
                Some((_, k)) => Ok(k),
            }
            .map_err(located)?;
            if let Some(t) = scene.tool.as_mut() {
                t.stiffness = stiffness;
            }
            if let Some(t) = scene.effects.tool.as_mut() {
                t.stiffness = stiffness;
            }
        }
        Ok(scene)
    }

    /// Builds (or reads) the scene's model, with the scene's in-vivo skin pre-tension and
    /// muscle tone applied and settled ([`InVivo::apply`]).
    pub fn build_model(&self) -> Result<Model, SceneLoadError> {
        let mut model = self.build_generated_model()?;
        if !self.in_vivo.is_identity() {
            let file = self.path.clone().unwrap_or_else(|| PathBuf::from("<built-in default scene>"));
            self.in_vivo
                .apply(&mut model, self.effects.skin_volume)
                .map_err(|e| SceneLoadError::Model { path: file, message: e.to_string() })?;
        }
        Ok(model)
    }

    /// Builds (or reads) the scene's model as generated or stored, without the in-vivo
    /// settings.
    pub fn build_generated_model(&self) -> Result<Model, SceneLoadError> {
        let file = self.path.clone().unwrap_or_else(|| PathBuf::from("<built-in default scene>"));
        let model = match &self.model {
            ModelSource::LayeredBlock(spec) => spec
                .checked_model()
                .map_err(|e| SceneLoadError::Model { path: file.clone(), message: e.to_string() })?,
            ModelSource::Yardstick(size) => size
                .checked_model()
                .map_err(|e| SceneLoadError::Model { path: file.clone(), message: e.to_string() })?,
            ModelSource::CylinderLimb { columns, rows, length, springs } => {
                let spec = crate::generator::CylinderLimb {
                    grid: crate::generator::GridSize::new(*columns, *rows),
                    length: *length,
                    ..crate::generator::CylinderLimb::default()
                };
                let materials = springs.map_or_else(crate::generator::Materials::default, |s| s.materials());
                crate::generator::generate(&spec, &materials)
                    .map_err(|e| SceneLoadError::Model { path: file.clone(), message: e.to_string() })?
            }
            ModelSource::Anatomy(spec) => {
                crate::generator::generate_anatomy(spec, None)
                    .map_err(|e| SceneLoadError::Model { path: file.clone(), message: e.to_string() })?
                    .0
            }
            ModelSource::File(p) => crate::io::read_model(p)
                .map_err(|e| SceneLoadError::Model { path: file.clone(), message: e.to_string() })?,
        };
        let mut model = model;
        if self.effects.bone_motion.is_some() {
            let which = match &self.model {
                ModelSource::File(p) => format!("the model file {}", p.display()),
                _ => {
                    // A generated model's bone does not move unless the scene moves it.
                    model.nodes.set_bone_moving();
                    "the generated model".to_string()
                }
            };
            if !model.nodes.kind.contains(&NodeKind::Kinematic) {
                let message = format!(
                    "effects.bone_motion moves the nodes attached to moving bone, and {which} has none (no node of kind \"kinematic\")"
                );
                return Err(SceneLoadError::Model { path: file, message });
            }
        }
        model.validate().map_err(|e| SceneLoadError::Model { path: file, message: e.to_string() })?;
        Ok(model)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::ToolSource;

    #[test]
    fn scene_builtin_default_loads_works() {
        let s = Scene::builtin_default();
        assert_eq!(s.rate_hz, 1000);
        assert!(s.effects.bone && s.effects.guard.is_some());
        let m = s.build_model().unwrap();
        // The generator's cylinder limb on a 24 x 6 grid: W(7H+1) masses (the paper's Table 3 rule).
        assert_eq!(m.nodes.position.len(), 24 * (7 * 6 + 1));
    }

    #[test]
    fn scene_builtin_default_tool_and_handle_sit_on_the_skin_works() {
        use crate::solver::Simulation;
        let s = Scene::builtin_default();
        // The generated geometry finds the node; the settled (in-vivo) model is what runs.
        let m = s.build_generated_model().unwrap();
        let outer_radius = crate::generator::CylinderLimb::default().outer_skin_radius;
        let tool = s.tool.expect("the default scene has a haptic tool");
        let ToolSource::Haptics { device_origin, .. } = tool.source else { panic!("haptics tool") };
        // A skin node right under the device's centre, on top of the limb.
        let under: Vec<usize> = (0..m.nodes.position.len())
            .filter(|&i| {
                let p = m.nodes.position[i];
                (p[0] - device_origin[0]).abs() < 1e-9
                    && (p[2] - device_origin[2]).abs() < 1e-9
                    && (p[1] - outer_radius).abs() < 1e-9
            })
            .collect();
        assert_eq!(under.len(), 1, "one skin node under the device's centre");
        // Once the limb has settled (only the drag handle loads it), the device's centre is one tool radius
        // above that node (within 0.2 mm), so device z = 0 is the tool just touching.
        let mut sim = Simulation::<f64>::new(&s.build_model().unwrap(), s.solver.clone(), s.effects.clone()).unwrap();
        for _ in 0..3 * s.rate_hz {
            sim.step();
        }
        let settled = sim.state().x.get_f64(under[0]);
        assert!((device_origin[1] - tool.radius - settled[1]).abs() < 2e-4, "{device_origin:?} over {settled:?}");
        // The handle holds an outer-skin node and pulls it 1 cm straight out.
        let h = &s.effects.handles[0];
        let p = m.nodes.position[h.node as usize];
        assert!(((p[0] * p[0] + p[1] * p[1]).sqrt() - outer_radius).abs() < 1e-12, "{p:?}");
        let pull: f64 = (0..3).map(|c| (h.target[c] - p[c]).powi(2)).sum::<f64>().sqrt();
        assert!((pull - 0.01).abs() < 1e-12, "{pull}");
    }

    #[test]
    fn scene_tool_sections_parse_works() {
        let s = Scene::builtin_default();
        let tool = s.tool.expect("the default scene has a haptic tool");
        assert!(matches!(tool.source, ToolSource::Haptics { timeout_s, .. } if (timeout_s - 0.1).abs() < 1e-12));
        assert!(s.effects.tool.is_none(), "a haptics tool is parked until the first command");
        let text = "[effects.tool]\nsource = \"scripted\"\nradius = 0.01\nstiffness = 200.0\nstart = [0.0, 0.1, 0.0]\nvelocity = [0.0, -0.01, 0.0]\n";
        let s = Scene::from_toml_str(text, None).unwrap();
        let sphere = s.effects.tool.expect("a scripted tool is in the loop from the start");
        assert_eq!((sphere.radius, sphere.stiffness, sphere.velocity), (0.01, 200.0, [0.0, -0.01, 0.0]));
    }

    #[test]
    fn haptic_tool_radius_is_raised_to_min_radius_works() {
        let haptics = "[effects.tool]\nsource = \"haptics\"\nradius = 0.012\nstiffness = 300.0\ndevice_origin = [0.0, 0.0, 0.0]\n";
        // Without min_radius the shell is sampled for the scene's radius and nothing smaller
        // is allowed; a command of 0 means the scene's radius.
        let tool = Scene::from_toml_str(haptics, None).unwrap().tool.unwrap();
        assert_eq!(tool.shell_radius(), 0.012);
        assert_eq!(tool.commanded_radius(0.0), (0.012, false));
        assert_eq!(tool.commanded_radius(0.02), (0.02, false));
        assert_eq!(tool.commanded_radius(0.004), (0.012, true));
        let tool = Scene::from_toml_str(&format!("{haptics}min_radius = 0.003\n"), None).unwrap().tool.unwrap();
        assert_eq!(tool.shell_radius(), 0.003);
        assert_eq!(tool.commanded_radius(0.004), (0.004, false));
        assert_eq!(tool.commanded_radius(0.001), (0.003, true));
    }

    #[test]
    fn scene_typo_names_line_and_column_fails() {
        let text = "name = \"x\"\n[effects]\ngravty = [0, -9.81, 0]\n";
        let e = Scene::from_toml_str(text, Some(Path::new("bad.toml"))).unwrap_err();
        match &e {
            SceneLoadError::Syntax { line, path, .. } => {
                assert_eq!(*line, 3);
                assert_eq!(path, Path::new("bad.toml"));
            }
            other => panic!("{other:?}"),
        }
        assert!(e.to_string().starts_with("bad.toml:3:"), "{e}");
    }

    #[test]
    fn scene_nan_load_fails() {
        let text = "[effects]\n[[effects.loads]]\nnode = 1\nforce = [0.0, nan, 0.0]\n";
        let e = Scene::from_toml_str(text, Some(Path::new("nan.toml"))).unwrap_err();
        assert!(matches!(e, SceneLoadError::Value { ref field, .. } if field == "effects.loads[0]"), "{e}");
    }

    #[test]
    fn scene_malformed_toml_fails() {
        let e = Scene::from_toml_str("rate_hz = = 3\n", Some(Path::new("m.toml"))).unwrap_err();
        assert!(matches!(e, SceneLoadError::Syntax { line: 1, .. }), "{e}");
        let e = Scene::from_toml_str("rate_hz = 0\n", None).unwrap_err();
        assert!(matches!(e, SceneLoadError::Value { .. }), "{e}");
    }
}
