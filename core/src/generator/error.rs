//! Why a model could not be generated.

use super::surface::Boundary;
use crate::model::{ModelSizeError, ModelValidateError, Tissue};

/// Why [`generate_layered`](super::generate_layered) or [`generate`](super::generate)
/// failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GeneratorError {
    /// The grid has fewer than 3 columns or 1 row, or too many nodes for `u32` indices.
    #[error("grid {columns}x{rows}: needs at least 3 columns and 1 row and fewer than 2^32 nodes")]
    BadGrid {
        /// Requested W.
        columns: u32,
        /// Requested H.
        rows: u32,
    },
    /// The cylinder limb's length or a radius is outside 1 µm to 1 km
    /// ([`CylinderLimb::MIN_SIZE_M`](super::CylinderLimb::MIN_SIZE_M) to
    /// [`MAX_SIZE_M`](super::CylinderLimb::MAX_SIZE_M)), or the radii do not decrease
    /// strictly inward.
    #[error("cylinder limb: length and radii must be between 1e-6 and 1e3 m, radii decreasing inward")]
    BadCylinder,
    /// The ray origin distance is not positive and finite.
    #[error("ray reach must be positive and finite")]
    BadReach,
    /// A tissue's material has a non-finite or negative parameter or a non-positive density.
    #[error("material of {}: a parameter is not finite and valid", .tissue.name())]
    BadMaterial {
        /// The tissue.
        tissue: Tissue,
    },
    /// A ray cast toward the centreline did not meet a boundary: the boundary is not closed
    /// there, lies outside the reach, or the previous sample is already inside it (the
    /// layer above is thinner than the sagitta of the outer grid's triangles).
    #[error("ray toward the centreline missed {} {}", .boundary.name(), ray_missed_at(*.column, *.row, *.triangle))]
    RayMissed {
        /// The boundary that was missed.
        boundary: Boundary,
        /// Grid column of the sample (the cell's column for a triangle sample).
        column: u32,
        /// Grid ring of a point sample, or row of the cell of a triangle sample.
        row: u32,
        /// For a triangle sample, which triangle of the cell (0 or 1); `None` for a grid
        /// point of the outer skin.
        triangle: Option<u8>,
    },
    /// Two connected nodes landed within 1 nm of each other (a degenerate surface).
    #[error("nodes {a} and {b} coincide (spring shorter than 1 nm)")]
    DegenerateSpring {
        /// First node.
        a: u32,
        /// Second node.
        b: u32,
    },
    /// The finished model failed [`Model::validate`](crate::model::Model::validate).
    #[error("generated model is invalid: {0}")]
    Model(ModelValidateError),
    /// The model would need more memory than is available (or more nodes than `u32`
    /// indices address).
    #[error(transparent)]
    Size(ModelSizeError),
}

/// Where a [`GeneratorError::RayMissed`] ray started: a grid point of the outer skin, or a
/// triangle of a grid cell.
fn ray_missed_at(column: u32, row: u32, triangle: Option<u8>) -> String {
    match triangle {
        None => format!("at grid point (column {column}, ring {row})"),
        Some(half) => format!("below triangle {half} of grid cell (column {column}, row {row})"),
    }
}

impl From<ModelValidateError> for GeneratorError {
    fn from(e: ModelValidateError) -> Self {
        Self::Model(e)
    }
}
