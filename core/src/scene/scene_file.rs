//! The scene file (TOML) and its loading, with errors that name file, line and column.

use super::layered_block::{BlockSpec, LayerMaterial, layered_block};
use super::tool_settings::{ToolSettings, ToolSource};
use crate::model::Model;
use crate::solver::{
    BoneMotion, DragHandle, Effects, GuardSettings, IntegrationParameters, IntegratorKind, PointLoad, SimdLevel,
    Substeps,
};
use crate::yardstick::{LatticeSize, lattice_model};
use serde::Deserialize;
use std::fmt;
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

/// Where the model comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelSource {
    /// The built-in layered block.
    LayeredBlock(BlockSpec),
    /// The yardstick lattice.
    Yardstick(LatticeSize),
    /// The generator's synthetic cylindrical limb (W columns × H rows, default materials).
    CylinderLimb {
        /// Columns around.
        columns: u32,
        /// Rows along.
        rows: u32,
        /// Length, m.
        length: f64,
    },
    /// A model file (XML), path relative to the scene file.
    File(PathBuf),
    /// Generated from segmented surfaces (paths relative to the scene file); see
    /// [`crate::generator::generate_anatomy`].
    Anatomy(Box<crate::generator::AnatomySpec>),
}

/// What the real-time loop does when a tick overruns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverrunChoice {
    /// Drop missed periods and realign to the grid.
    Skip,
    /// Run missed ticks back to back until on time.
    CatchUp,
}

/// Real-time settings of the core process.
#[derive(Clone, Debug, PartialEq)]
pub struct RealtimeSettings {
    /// CPU to pin the loop to. Default: the last CPU.
    pub cpu: Option<usize>,
    /// SCHED_FIFO priority (1–99). Default 80; `None` in the file as `0`.
    pub fifo_priority: Option<i32>,
    /// `mlockall` the process. Default true.
    pub lock_memory: bool,
    /// Frame budget, µs. Default: the period.
    pub budget_us: Option<f64>,
    /// Overrun policy. Default skip.
    pub overrun: OverrunChoice,
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
    /// File the scene was read from (`None` for the built-in one).
    pub path: Option<PathBuf>,
}

/// Why a scene could not be loaded.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneLoadError {
    /// The file could not be read.
    Io {
        /// File.
        path: PathBuf,
        /// OS error text.
        message: String,
    },
    /// The TOML is malformed or a field has the wrong type or name.
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
    Value {
        /// File.
        path: PathBuf,
        /// Field, e.g. `effects.loads[2].force`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The model named by the scene could not be built or read.
    Model {
        /// File.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl fmt::Display for SceneLoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { path, message } => write!(f, "{}: {message}", path.display()),
            Self::Syntax { path, line, column, message } => write!(f, "{}:{line}:{column}: {message}", path.display()),
            Self::Value { path, field, message } => write!(f, "{}: {field}: {message}", path.display()),
            Self::Model { path, message } => write!(f, "{}: model: {message}", path.display()),
        }
    }
}

impl std::error::Error for SceneLoadError {}

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
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
enum RawModel {
    LayeredBlock {
        #[serde(flatten)]
        spec: Box<BlockSpecPartial>,
    },
    Yardstick {
        size: String,
    },
    CylinderLimb {
        columns: Option<u32>,
        rows: Option<u32>,
        length: Option<f64>,
    },
    File {
        path: PathBuf,
    },
    Anatomy {
        skin: PathBuf,
        fat_muscle: PathBuf,
        bone: PathBuf,
        z_range_mm: [f64; 2],
        columns: u32,
        rows: u32,
        skin_thickness_mm: Option<f64>,
        min_layer_mm: Option<f64>,
    },
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct BlockSpecPartial {
    nx: Option<usize>,
    nz: Option<usize>,
    spacing: Option<f64>,
    muscle_rows: Option<usize>,
    fat_rows: Option<usize>,
    skin_rows: Option<usize>,
    density: Option<f64>,
    skin: Option<LayerMaterial>,
    fat: Option<LayerMaterial>,
    muscle: Option<LayerMaterial>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawSolver {
    integrator: Option<String>,
    substeps: Option<toml::Value>,
    threads: Option<usize>,
    simd: Option<String>,
    stability_safety: Option<f64>,
    max_substeps: Option<u32>,
    cg_tolerance: Option<f64>,
    cg_max_iterations: Option<u32>,
    rayleigh_alpha: Option<f64>,
    rayleigh_beta: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawEffects {
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
    guard: Option<RawGuard>,
    tool: Option<RawTool>,
    skin_volume: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTool {
    radius: f64,
    stiffness: f64,
    source: String,
    start: Option<[f64; 3]>,
    velocity: Option<[f64; 3]>,
    device_origin: Option<[f64; 3]>,
    timeout_ms: Option<f64>,
    min_radius: Option<f64>,
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

#[derive(Deserialize)]
#[serde(untagged)]
enum RawGuard {
    Flag(bool),
    Settings { max_speed: Option<f64>, max_displacement: Option<f64>, retries: Option<u32> },
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawRealtime {
    cpu: Option<usize>,
    fifo_priority: Option<i32>,
    lock_memory: Option<bool>,
    budget_us: Option<f64>,
    overrun: Option<String>,
}

/// 1-based line and column of byte `offset` in `text` (for TOML errors).
pub(crate) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
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
        let value_err = |field: &str, message: &str| SceneLoadError::Value {
            path: file.clone(),
            field: field.into(),
            message: message.into(),
        };
        let rate_hz = raw.rate_hz.unwrap_or(1000);
        if rate_hz == 0 || rate_hz > 100_000 {
            return Err(value_err("rate_hz", "must be between 1 and 100000 Hz"));
        }
        let precision = match raw.precision.as_deref().unwrap_or("f32") {
            "f32" => Precision::F32,
            "f64" => Precision::F64,
            _ => return Err(value_err("precision", "must be \"f32\" or \"f64\"")),
        };
        let model = match raw.model {
            None => ModelSource::LayeredBlock(BlockSpec::default()),
            Some(RawModel::LayeredBlock { spec }) => {
                let d = BlockSpec::default();
                let s = BlockSpec {
                    nx: spec.nx.unwrap_or(d.nx),
                    nz: spec.nz.unwrap_or(d.nz),
                    spacing: spec.spacing.unwrap_or(d.spacing),
                    muscle_rows: spec.muscle_rows.unwrap_or(d.muscle_rows),
                    fat_rows: spec.fat_rows.unwrap_or(d.fat_rows),
                    skin_rows: spec.skin_rows.unwrap_or(d.skin_rows),
                    density: spec.density.unwrap_or(d.density),
                    skin: spec.skin.unwrap_or(d.skin),
                    fat: spec.fat.unwrap_or(d.fat),
                    muscle: spec.muscle.unwrap_or(d.muscle),
                };
                if s.nx < 2 || s.nz < 2 || s.nx * s.nz * s.rows() > 50_000_000 {
                    return Err(value_err("model", "nx and nz must be at least 2 and the block at most 5e7 nodes"));
                }
                if !(s.spacing.is_finite() && s.spacing > 0.0 && s.density.is_finite() && s.density > 0.0) {
                    return Err(value_err("model", "spacing and density must be finite and positive"));
                }
                for (name, m) in [("skin", &s.skin), ("fat", &s.fat), ("muscle", &s.muscle)] {
                    if !m.is_valid() {
                        return Err(value_err(
                            &format!("model.{name}"),
                            "material values must be finite and non-negative",
                        ));
                    }
                }
                ModelSource::LayeredBlock(s)
            }
            Some(RawModel::Yardstick { size }) => ModelSource::Yardstick(
                LatticeSize::parse(&size).ok_or_else(|| value_err("model.size", "small, medium, large or NXxNYxNZ"))?,
            ),
            Some(RawModel::CylinderLimb { columns, rows, length }) => {
                let d = crate::generator::CylinderLimb::default();
                let (columns, rows) = (columns.unwrap_or(d.grid.columns), rows.unwrap_or(d.grid.rows));
                let length = length.unwrap_or(d.length);
                if !((3..=4096).contains(&columns) && (1..=4096).contains(&rows) && length.is_finite() && length > 0.0)
                {
                    return Err(value_err("model", "columns 3..=4096, rows 1..=4096, length finite and positive"));
                }
                ModelSource::CylinderLimb { columns, rows, length }
            }
            Some(RawModel::File { path: p }) => {
                let base = path.and_then(Path::parent).unwrap_or(Path::new("."));
                ModelSource::File(base.join(p))
            }
            Some(RawModel::Anatomy {
                skin,
                fat_muscle,
                bone,
                z_range_mm,
                columns,
                rows,
                skin_thickness_mm,
                min_layer_mm,
            }) => {
                let base = path.and_then(Path::parent).unwrap_or(Path::new("."));
                let skin_thickness = skin_thickness_mm.unwrap_or(2.0) * 1e-3;
                let min_layer = min_layer_mm.unwrap_or(1.0) * 1e-3;
                let ok = z_range_mm.iter().all(|z| z.is_finite())
                    && z_range_mm[0] < z_range_mm[1]
                    && (3..=4096).contains(&columns)
                    && (1..=4096).contains(&rows)
                    && skin_thickness.is_finite()
                    && skin_thickness > 0.0
                    && min_layer.is_finite()
                    && min_layer > 0.0;
                if !ok {
                    return Err(value_err(
                        "model",
                        "z_range_mm increasing, columns 3..=4096, rows 1..=4096, skin_thickness_mm and min_layer_mm positive",
                    ));
                }
                ModelSource::Anatomy(Box::new(crate::generator::AnatomySpec {
                    skin: base.join(skin),
                    fat_muscle: base.join(fat_muscle),
                    bone: base.join(bone),
                    z_range: (z_range_mm[0] * 1e-3, z_range_mm[1] * 1e-3),
                    grid: crate::generator::GridSize::new(columns, rows),
                    skin_thickness,
                    min_layer,
                    materials: crate::generator::Materials::default(),
                }))
            }
        };
        let mut solver = IntegrationParameters { dt: 1.0 / rate_hz as f64, ..IntegrationParameters::default() };
        let s = raw.solver;
        if let Some(name) = s.integrator {
            solver.integrator = IntegratorKind::parse(&name)
                .ok_or_else(|| value_err("solver.integrator", "symplectic_euler, rk4 or implicit_euler"))?;
        }
        match s.substeps {
            None => {}
            Some(toml::Value::String(v)) if v == "auto" => solver.substeps = Substeps::Auto,
            Some(toml::Value::Integer(n)) if (1..=100_000).contains(&n) => solver.substeps = Substeps::Fixed(n as u32),
            Some(_) => return Err(value_err("solver.substeps", "\"auto\" or an integer from 1 to 100000")),
        }
        if let Some(t) = s.threads {
            if t == 0 || t > 256 {
                return Err(value_err("solver.threads", "between 1 and 256"));
            }
            solver.threads = t;
        }
        if let Some(level) = s.simd {
            solver.simd =
                SimdLevel::parse(&level).ok_or_else(|| value_err("solver.simd", "auto, baseline, avx2 or avx512"))?;
        }
        let positive = |v: Option<f64>, field: &str, into: &mut f64| -> Result<(), SceneLoadError> {
            if let Some(v) = v {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(value_err(field, "must be finite and non-negative"));
                }
                *into = v;
            }
            Ok(())
        };
        positive(s.stability_safety, "solver.stability_safety", &mut solver.stability_safety)?;
        positive(s.cg_tolerance, "solver.cg_tolerance", &mut solver.cg_tolerance)?;
        positive(s.rayleigh_alpha, "solver.rayleigh_alpha", &mut solver.rayleigh_alpha)?;
        positive(s.rayleigh_beta, "solver.rayleigh_beta", &mut solver.rayleigh_beta)?;
        if let Some(m) = s.max_substeps {
            solver.max_substeps = m.max(1);
        }
        if let Some(m) = s.cg_max_iterations {
            solver.cg_max_iterations = m.max(1);
        }
        let e = raw.effects;
        let finite3 = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        if e.gravity.as_ref().is_some_and(|g| !finite3(g)) {
            return Err(value_err("effects.gravity", "must be finite"));
        }
        let mut viscous = None;
        positive(e.viscous_damping, "effects.viscous_damping", viscous.get_or_insert(0.0))?;
        if e.viscous_damping.is_none() {
            viscous = None;
        }
        if e.skin_volume.is_some_and(|k| !(k.is_finite() && k > 0.0)) {
            return Err(value_err("effects.skin_volume", "must be finite and positive (Pa)"));
        }
        let mut loads = Vec::new();
        for (i, l) in e.loads.iter().enumerate() {
            if !(finite3(&l.force) && l.ramp_s.is_finite() && l.ramp_s >= 0.0) {
                return Err(value_err(&format!("effects.loads[{i}]"), "force must be finite and ramp_s finite, >= 0"));
            }
            loads.push(PointLoad { node: l.node, force: l.force, ramp_s: l.ramp_s });
        }
        let mut handles = Vec::new();
        for (i, h) in e.handles.iter().enumerate() {
            if !(finite3(&h.target)
                && h.stiffness.is_finite()
                && h.stiffness >= 0.0
                && h.damping.is_finite()
                && h.damping >= 0.0)
            {
                return Err(value_err(
                    &format!("effects.handles[{i}]"),
                    "target, stiffness and damping must be finite, >= 0",
                ));
            }
            handles.push(DragHandle { node: h.node, target: h.target, stiffness: h.stiffness, damping: h.damping });
        }
        let bone_motion = match e.bone_motion {
            Some(m) if finite3(&m.amplitude) && m.frequency_hz.is_finite() => {
                Some(BoneMotion { amplitude: m.amplitude, frequency_hz: m.frequency_hz })
            }
            Some(_) => return Err(value_err("effects.bone_motion", "must be finite")),
            None => None,
        };
        let guard = match e.guard {
            None | Some(RawGuard::Flag(false)) => None,
            Some(RawGuard::Flag(true)) => Some(GuardSettings::default()),
            Some(RawGuard::Settings { max_speed, max_displacement, retries }) => {
                let d = GuardSettings::default();
                let g = GuardSettings {
                    max_speed: max_speed.unwrap_or(d.max_speed),
                    max_displacement: max_displacement.unwrap_or(d.max_displacement),
                    retries: retries.unwrap_or(d.retries),
                };
                if !(g.max_speed > 0.0 && g.max_displacement > 0.0) {
                    return Err(value_err("effects.guard", "max_speed and max_displacement must be positive"));
                }
                Some(g)
            }
        };
        let tool = match e.tool {
            None => None,
            Some(t) => {
                if !(t.radius.is_finite() && t.radius > 0.0 && t.stiffness.is_finite() && t.stiffness > 0.0) {
                    return Err(value_err("effects.tool", "radius and stiffness must be finite and positive"));
                }
                let source = match t.source.as_str() {
                    "scripted" => {
                        if t.min_radius.is_some() {
                            return Err(value_err("effects.tool.min_radius", "only for source = \"haptics\""));
                        }
                        let start = t.start.ok_or_else(|| value_err("effects.tool.start", "required when scripted"))?;
                        let velocity = t.velocity.unwrap_or([0.0; 3]);
                        if !(finite3(&start) && finite3(&velocity)) {
                            return Err(value_err("effects.tool", "start and velocity must be finite"));
                        }
                        ToolSource::Scripted { start, velocity }
                    }
                    "haptics" => {
                        let device_origin = t.device_origin.ok_or_else(|| {
                            value_err("effects.tool.device_origin", "required when source = \"haptics\"")
                        })?;
                        let timeout_s = t.timeout_ms.unwrap_or(100.0) * 1e-3;
                        if !(finite3(&device_origin) && timeout_s.is_finite() && timeout_s > 0.0) {
                            return Err(value_err("effects.tool", "device_origin finite and timeout_ms positive"));
                        }
                        let min_radius = t.min_radius.unwrap_or(t.radius);
                        if !(min_radius.is_finite() && min_radius > 0.0 && min_radius <= t.radius) {
                            return Err(value_err("effects.tool.min_radius", "finite, positive and at most radius"));
                        }
                        ToolSource::Haptics { device_origin, timeout_s, min_radius }
                    }
                    _ => return Err(value_err("effects.tool.source", "\"scripted\" or \"haptics\"")),
                };
                Some(ToolSettings { radius: t.radius, stiffness: t.stiffness, source })
            }
        };
        let effects = Effects {
            gravity: e.gravity,
            viscous_damping: viscous,
            spring_damping: e.spring_damping,
            bone: e.bone,
            bone_motion,
            loads,
            handles,
            guard,
            tool: tool.and_then(|t| t.initial_sphere()),
            skin_volume: e.skin_volume,
        };
        let r = raw.realtime;
        let overrun = match r.overrun.as_deref().unwrap_or("skip") {
            "skip" => OverrunChoice::Skip,
            "catch_up" | "catch-up" => OverrunChoice::CatchUp,
            _ => return Err(value_err("realtime.overrun", "\"skip\" or \"catch_up\"")),
        };
        if r.budget_us.is_some_and(|b| !(b.is_finite() && b > 0.0)) {
            return Err(value_err("realtime.budget_us", "must be finite and positive"));
        }
        let fifo_priority = match r.fifo_priority {
            None => Some(80),
            Some(0) => None,
            Some(p) if (1..=99).contains(&p) => Some(p),
            Some(_) => return Err(value_err("realtime.fifo_priority", "0 (off) or 1..=99")),
        };
        let realtime = RealtimeSettings {
            cpu: r.cpu,
            fifo_priority,
            lock_memory: r.lock_memory.unwrap_or(true),
            budget_us: r.budget_us,
            overrun,
        };
        Ok(Self {
            name: raw.name.unwrap_or_else(|| "unnamed".into()),
            rate_hz,
            precision,
            model,
            solver,
            effects,
            realtime,
            tool,
            path: path.map(Path::to_path_buf),
        })
    }

    /// Builds (or reads) the scene's model.
    pub fn build_model(&self) -> Result<Model, SceneLoadError> {
        let file = self.path.clone().unwrap_or_else(|| PathBuf::from("<built-in default scene>"));
        let model = match &self.model {
            ModelSource::LayeredBlock(spec) => layered_block(spec),
            ModelSource::Yardstick(size) => lattice_model(*size),
            ModelSource::CylinderLimb { columns, rows, length } => {
                let spec = crate::generator::CylinderLimb {
                    grid: crate::generator::GridSize::new(*columns, *rows),
                    length: *length,
                    ..crate::generator::CylinderLimb::default()
                };
                crate::generator::generate(&spec, &crate::generator::Materials::default())
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
        model.validate().map_err(|e| SceneLoadError::Model { path: file, message: e.to_string() })?;
        Ok(model)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let m = s.build_model().unwrap();
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
        let mut sim = Simulation::<f64>::new(&m, s.solver.clone(), s.effects.clone()).unwrap();
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
    fn scene_tool_bad_values_name_the_field_fails() {
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
        ];
        for (body, field) in cases {
            let text = format!("[effects.tool]\n{body}");
            match Scene::from_toml_str(&text, Some(Path::new("tool.toml"))) {
                Err(SceneLoadError::Value { field: f, path, .. }) => {
                    assert_eq!(f, field, "{body}");
                    assert_eq!(path, Path::new("tool.toml"));
                }
                other => panic!("{body}: expected a value error on {field}, got {other:?}"),
            }
        }
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
