//! Triangle surfaces for Lamina: loading, repair, inspection, ray casting and centrelines.
//!
//! Everything is `f64` and SI: coordinates in metres, areas in m², volumes in m³. Files in
//! other units are converted on load ([`Units`], inferred when not given).
//!
//! - [`load()`] reads STL (binary or ASCII) and OBJ, welds coincident vertices, removes
//!   degenerate triangles, checks that the surface is closed and manifold, and winds it
//!   consistently outward, reporting what it did in a [`LoadReport`].
//! - [`inspect()`] measures a file and reports its defects without failing on them
//!   ([`Inspection`] prints as a table; it backs `lamina inspect FILE`).
//! - [`RayCaster`] casts rays against a surface through a BVH.
//! - [`centreline()`] slices a limb-like surface into cross-sections along an axis.
//! - [`synthetic`] builds closed test surfaces (cuboid, sphere, cylinder, cone).
//!
//! # Examples
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use lamina_mesh::{LoadOptions, Units, load, save_stl_binary, synthetic};
//! # let dir = tempfile::tempdir()?;
//! # let path = dir.path().join("limb.stl");
//! let limb = synthetic::cylinder(0.05, 0.0, 0.4, 48, 8);
//! save_stl_binary(&path, &limb, Units::Millimetre)?;
//! let loaded = load(&path, &LoadOptions::default())?;
//! assert_eq!(loaded.report.units, Units::Millimetre); // inferred: diagonal > 10
//! assert_eq!(loaded.report.welded_vertices, limb.vertices().len());
//! assert!((loaded.mesh.signed_volume() - limb.signed_volume()).abs() < 1e-9);
//! # Ok(())
//! # }
//! ```

pub mod centreline;
pub mod error;
pub mod inspect;
mod lex;
pub mod load;
pub mod obj;
mod orient;
pub mod raw;
pub mod raycast;
pub mod stl;
pub mod synthetic;
mod topology;
pub mod trimesh;
pub mod units;
mod vec3;
mod weld;

pub use centreline::{AxisChoice, Centreline, CentrelineOptions, CrossSection, centreline, cross_section};
pub use error::{CentrelineComputeError, MeshLoadError, MeshSaveError, TriMeshBuildError};
pub use inspect::{Inspection, inspect, inspect_with};
pub use load::{LoadOptions, LoadReport, LoadedMesh, load};
pub use obj::save_obj;
pub use raw::MeshFormat;
pub use raycast::{RayCaster, RayHit};
pub use stl::{save_stl_ascii, save_stl_binary};
pub use trimesh::{BoundingBox, TriMesh};
pub use units::{Units, UnitsParseError};
