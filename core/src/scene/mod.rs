//! Scenes: which model, which solver, which effects, which real-time budget. Scenes are TOML
//! files in `config/scenes/`; [`Scene::builtin_default`] is used when none is given.

mod effects_section;
mod in_vivo;
mod layered_block;
mod model_section;
mod realtime_section;
mod scalpel_section;
mod scene_file;
mod section;
mod solver_section;
mod springs_section;
mod tool_section;
mod tool_settings;
mod visual_section;

pub use in_vivo::{
    InVivo, InVivoApplyError, InVivoReport, MAX_ACTIVE_MUSCLE_FACTOR, MAX_SKIN_PRESTRAIN, MuscleTone,
    in_plane_skin_springs,
};
pub use layered_block::{BlockSpec, LayerMaterial, layered_block};
pub use model_section::ModelSource;
pub use realtime_section::{MIN_NODE_FRAME_CUTOFF_US, OverrunChoice, RealtimeSettings, STANDBY_DELAY_US};
pub use scalpel_section::{MAX_BLADE_LENGTH_M, MIN_BLADE_LENGTH_M};
pub(crate) use scene_file::line_column;
pub use scene_file::{DEFAULT_SCENE_TOML, Precision, Scene, SceneLoadError};
pub use springs_section::{SceneSprings, fat_material};
pub use tool_settings::{DEVICE_TO_Y_UP_MODEL, ToolSettings, ToolSource};
pub use visual_section::VisualSection;
