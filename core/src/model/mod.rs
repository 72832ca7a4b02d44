//! The layered mass-spring model as it is stored and exchanged: nodes, springs, layers,
//! surfaces, volume cells. Double precision, SI units. The solver derives its own streaming layout from it.

mod cell;
mod layer;
mod model_data;
mod node_set;
mod size;
mod spring_set;
mod surface;

pub use cell::{Cell, CellKind};
pub use layer::{Layer, Tissue};
pub use model_data::{Model, ModelValidateError, Provenance};
pub use node_set::{NodeKind, NodeSet};
pub use size::{
    GENERATE_MEMORY_FACTOR, ModelSize, ModelSizeError, NODE_BYTES, RUN_MEMORY_FACTOR, SPRING_BYTES, TRIANGLE_BYTES,
};
pub use spring_set::SpringSet;
pub use surface::Surface;
