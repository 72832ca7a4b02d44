//! Time integration of a layered mass-spring model.
//!
//! The pipeline, stage by stage, is described on [`Simulation`]. The solver owns no model
//! data beyond what it derived for speed: the streaming spring layout, node arrays in
//! precision `T`, and scratch buffers allocated once.

mod bisected_ordering;
mod build_checks;
mod build_error;
mod critical_step;
mod cut_log;
mod disjoint;
mod dynamics;
mod effects;
mod factored_preconditioner;
mod guard;
mod idle_priority;
mod implicit;
mod implicit_factored;
pub(crate) mod lane_block;
mod multirate;
mod multirate_settings;
mod node_accel;
mod params;
mod refactor;
mod simd;
mod simulation;
mod skin_contact;
mod skin_volume;
mod sparse_cholesky;
mod spring_kernels;
mod spring_layout;
mod spring_pack;
#[cfg(test)]
mod spring_pack_checks;
mod spring_pass;
mod spring_runs;
mod vec3s;
mod worker_pool;

pub use build_checks::{
    MAX_CG_ITERATIONS, MAX_FACTORED_ITERATIONS, MAX_GUARD_RETRIES, MAX_SUBSTEPS, MAX_THREADS, max_coordinate,
};
pub use critical_step::StabilityEstimate;
pub use dynamics::{StageCounters, State};
pub use effects::{BoneMotion, DragHandle, Effects, GuardSettings, PointLoad, SphereTool, ToolFeedback};
pub use guard::{GuardEvent, GuardReason, Recovery};
pub use implicit_factored::ImplicitFactored;
pub use multirate::{FrameChanges, MultirateStatus, region_radius};
pub use multirate_settings::{LateBuild, MAX_BUILD_EXCHANGES, MAX_MULTIRATE_RATIO, MultirateSettings};
pub use params::{IntegrationParameters, IntegratorKind, Substeps};
pub use refactor::{FactorSwap, RefactorStatus};
pub use simd::SimdLevel;
pub use simulation::{CutError, GuardTotals, Simulation, SimulationBuildError};
pub use skin_contact::largest_skin_node_area;
pub use skin_volume::SkinVolume;
pub use sparse_cholesky::FactorStorage;
pub use spring_kernels::MIN_SPRING_LENGTH;
pub use vec3s::Vec3s;
