//! How big a model will be, before it is built: counts checked without overflow against
//! the `u32` indices, and bytes estimated and checked against the memory available.
//!
//! The estimate is the model's own arrays ([`ModelSize::model_bytes`]) times a factor for
//! what is built from it: [`GENERATE_MEMORY_FACTOR`] while generating and writing it,
//! [`RUN_MEMORY_FACTOR`] to run it (the solver's layout, state, scratch and snapshot, the
//! stability estimate, the published node buffers).
//!
//! # Examples
//! ```
//! use lamina_core::model::{ModelSize, ModelSizeError, RUN_MEMORY_FACTOR};
//!
//! let small = ModelSize::counted(Some(1_000), Some(8_000), Some(500));
//! assert!(small.check("a small block", RUN_MEMORY_FACTOR).is_ok());
//! // nx = nz = 2^32: the node count itself overflows. Refused for memory where the budget
//! // is known (the estimate overflows too: more than 16 EiB), else for the indices.
//! let huge = ModelSize::counted(1u64.checked_shl(32).and_then(|n| n.checked_mul(1u64 << 32)), None, None);
//! let e = huge.check("block", RUN_MEMORY_FACTOR).unwrap_err();
//! assert!(matches!(e, ModelSizeError::Memory(_) | ModelSizeError::TooManyNodes { nodes: None, .. }));
//! assert!(e.to_string().contains("more than 2^64 nodes"), "{e}");
//! ```

use crate::law::SpringLaw;
use crate::model::NodeKind;
use lamina_input::{MemoryCheckError, check_memory};
use std::mem::size_of;

/// Bytes per byte of model while generating and writing it. Measured: peak resident memory
/// of `lamina generate --cylinder 400x200` (560,400 nodes, 4.4 million springs) is 1.2 times
/// the model's arrays.
pub const GENERATE_MEMORY_FACTOR: u64 = 2;
/// Bytes per byte of model to run it. Measured: peak resident memory of `lamina run` on a
/// 140,200-node, 1.1-million-spring limb is 6.6 (f32) and 7.7 (f64) times the model's arrays.
pub const RUN_MEMORY_FACTOR: u64 = 8;

/// Bytes of one node in a [`Model`](crate::model::Model): position, mass, kind, layer,
/// texture coordinate.
pub const NODE_BYTES: u64 =
    (size_of::<[f64; 3]>() + size_of::<f64>() + size_of::<NodeKind>() + size_of::<u16>() + size_of::<[f32; 3]>())
        as u64;
/// Bytes of one spring: two ends, rest length, law, damping, layer.
pub const SPRING_BYTES: u64 =
    (2 * size_of::<u32>() + size_of::<f64>() + size_of::<SpringLaw>() + size_of::<f64>() + size_of::<u16>()) as u64;
/// Bytes of one surface triangle.
pub const TRIANGLE_BYTES: u64 = size_of::<[u32; 3]>() as u64;

/// Counts of a model to be built; `None` where computing the count overflowed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModelSize {
    /// Nodes.
    pub nodes: Option<u64>,
    /// Springs.
    pub springs: Option<u64>,
    /// Surface triangles, all surfaces together.
    pub triangles: Option<u64>,
}

/// Why a model of some size is refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ModelSizeError {
    /// More nodes than `u32` indices can address (`None`: the count overflowed).
    #[error("{what}: {} nodes, more than 32-bit indices address (4,294,967,295)", count(.nodes))]
    TooManyNodes {
        /// What was asked for.
        what: String,
        /// The count.
        nodes: Option<u64>,
    },
    /// More springs than `u32` indices can address (`None`: the count overflowed).
    #[error("{what}: {} springs, more than 32-bit indices address (4,294,967,295)", count(.springs))]
    TooManySprings {
        /// What was asked for.
        what: String,
        /// The count.
        springs: Option<u64>,
    },
    /// The estimate exceeds the memory available.
    #[error("{0}")]
    Memory(MemoryCheckError),
}

impl ModelSize {
    /// A size from counts computed with checked arithmetic (`None`: overflowed).
    pub const fn counted(nodes: Option<u64>, springs: Option<u64>, triangles: Option<u64>) -> Self {
        Self { nodes, springs, triangles }
    }

    /// Bytes of the model's arrays; `u64::MAX` when a count or the sum overflowed.
    pub fn model_bytes(&self) -> u64 {
        let term = |n: Option<u64>, each: u64| n.and_then(|n| n.checked_mul(each));
        [term(self.nodes, NODE_BYTES), term(self.springs, SPRING_BYTES), term(self.triangles, TRIANGLE_BYTES)]
            .into_iter()
            .try_fold(0u64, |sum, t| t.and_then(|t| sum.checked_add(t)))
            .unwrap_or(u64::MAX)
    }

    /// Refuses `model_bytes() × factor` above the memory available, then counts beyond
    /// `u32` indices. `what` names the model in the error, e.g. `cylinder limb 4096x4096`.
    /// Memory comes first so that the message gives the estimate and the budget: a model
    /// beyond the indices (4.3e9 nodes, about 1.6 TB to run) exceeds it on any smaller host.
    ///
    /// # Errors
    /// [`ModelSizeError`].
    pub fn check(&self, what: &str, factor: u64) -> Result<(), ModelSizeError> {
        let described = format!("{what} ({} nodes, {} springs)", count(&self.nodes), count(&self.springs));
        check_memory(&described, self.model_bytes().saturating_mul(factor)).map_err(ModelSizeError::Memory)?;
        let max = u64::from(u32::MAX);
        if self.nodes.is_none_or(|n| n > max) {
            return Err(ModelSizeError::TooManyNodes { what: what.into(), nodes: self.nodes });
        }
        if self.springs.is_none_or(|n| n > max) {
            return Err(ModelSizeError::TooManySprings { what: what.into(), springs: self.springs });
        }
        Ok(())
    }
}

/// A count for [`ModelSizeError`]'s messages (`None`: the count overflowed).
fn count(n: &Option<u64>) -> String {
    n.map_or("more than 2^64".to_string(), |n| n.to_string())
}
