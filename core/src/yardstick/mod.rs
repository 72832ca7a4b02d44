//! The yardstick scene (`docs/yardstick-scene.md`): a layered block of
//! `NX × NY × NZ` nodes that other simulators were timed on. Built exactly as specified,
//! spring order included, and stepped either by Lamina's solver or by the plain scalar loop
//! of the specification, side by side.

pub(crate) mod lattice;
mod reference;
mod run;

pub use lattice::{LatticeSize, lattice_model, lattice_model_size, spring_count};
pub use reference::ReferenceStepper;
pub use run::{
    Checksum, DT, GRAVITY, YardstickImpl, checksum, impl_params, lattice_effects, lattice_params, run_gravity,
};
