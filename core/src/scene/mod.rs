//! Scenes: which model, which solver, which effects, which real-time budget. Scenes are TOML
//! files in `config/scenes/`; [`Scene::builtin_default`] is used when none is given.

mod layered_block;
mod scene_file;
mod tool_settings;

pub use layered_block::{BlockSpec, LayerMaterial, layered_block};
pub(crate) use scene_file::line_column;
pub use scene_file::{ModelSource, OverrunChoice, Precision, RealtimeSettings, Scene, SceneLoadError};
pub use tool_settings::{ToolSettings, ToolSource};
