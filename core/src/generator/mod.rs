//! The deformable model generator: tissue boundary surfaces to a layered mass-spring model
//! (the paper's "Deformable Model Generator", DESIGN.md §4).
//!
//! # How it works
//! 1. **Reparameterisation.** A regular W × H grid around the centreline ([`GridSize`]):
//!    W columns in angle, `H + 1` rings along the axis. A ray from outside toward the
//!    centreline samples the outer skin at each grid point: `W(H+1)` surface nodes.
//! 2. **Outer triangulation.** Each grid cell is split into two triangles, `2WH` in all,
//!    counter-clockwise seen from outside; the grid wraps in angle, not along the axis.
//! 3. **Tetrahedral skin.** A ray from each triangle's centroid toward the centreline gives
//!    the triangle's skin/fat node. The nodes of the triangles around each grid point,
//!    sorted counter-clockwise, form its dual (Voronoi) polygon ([`DualPolygon`]: a hexagon
//!    around inner points); each is connected one by one and triangulated
//!    ([`zigzag`]). With each skin/fat node joined to its triangle's corners, the skin
//!    is cut into tetrahedra.
//! 4. **Cross-linked blocks.** From each skin/fat node a ray toward the axis finds the
//!    fat/muscle node, and from that the muscle/bone node (fixed). Between successive
//!    levels: the level's edges (dual edges and polygon diagonals), vertical edges and
//!    both diagonals of every side face.
//! 5. **Materials.** Springs take their layer's law and dashpot ([`Materials`]); nodes the
//!    density times their share of the element volumes (see `mass.rs`).
//!
//! Every node pair is joined at most once ([`EdgeTable`]); the counts per spring family,
//! and why they differ from the paper's Table 3, are in [`families`]. The generator only
//! asks the surfaces one question ([`BoundarySurface::hit_toward_axis`]), so the analytic
//! cylinders of [`CylinderLimb`] and triangle meshes serve alike.
//!
//! # Examples
//! ```
//! use lamina_core::generator::{CylinderLimb, Materials, generate};
//! # fn main() -> Result<(), lamina_core::generator::GeneratorError> {
//! let model = generate(&CylinderLimb::new(12, 3), &Materials::default())?;
//! assert_eq!(model.nodes.len(), 12 * (7 * 3 + 1));
//! assert_eq!(model.springs.len(), 12 * (55 * 3 - 13));
//! # Ok(())
//! # }
//! ```

mod anatomy;
mod build;
mod centreline;
mod cylinder;
mod edge_table;
mod error;
pub mod families;
mod grid;
pub mod layers;
mod limb;
mod mass;
mod materials;
mod surface;
mod table3;
mod topology;
pub(crate) mod vec3;

pub use anatomy::{
    AnatomyGenerateError, AnatomyReport, AnatomySpec, MAX_REPAIR_FRACTION, MeshBoundary, NestedBoundary,
    generate_anatomy,
};
pub use build::{LimbSurfaces, Progress, STAGES, generate_layered};
pub use centreline::{AxisFrame, Centreline};
pub use cylinder::Cylinder;
pub use edge_table::{EdgeTable, TopologySpring};
pub use error::GeneratorError;
pub use families::{SpringFamily, distinct_springs, paper_springs};
pub use grid::GridSize;
pub use limb::{CylinderLimb, generate, generate_with_progress};
pub use materials::{Materials, SpringMaterial, TissueMaterial};
pub use surface::{Boundary, BoundarySurface, InwardOffset};
pub use table3::{PAPER_TABLE3, PaperRow, Table3, Table3Row, table3_rows};
pub use topology::{DualPolygon, LayeredTopology, zigzag};
