//! Real anatomy: a limb region generated from segmented tissue surfaces (STL/OBJ through
//! `lamina-mesh`), such as the BodyParts3D thigh of the repository's `data/bodyparts3d-leg/`.
//!
//! # How it works
//! 1. Load the outer skin, the fat/muscle boundary and the bone: vertices welded, winding
//!    made consistent (flipped triangles counted), millimetres read as metres.
//! 2. Centreline: centroids of the **bone's** cross-sections over the region, so that every
//!    ray from outside toward it crosses skin, fat/muscle boundary and bone in that order.
//! 3. The paper's reparameterisation and layered topology ([`generate_layered`]): rays
//!    toward the centreline sample each boundary through a BVH ([`MeshBoundary`]).
//! 4. The dermis bottom, which segmented data lacks, is the outer skin offset inward by the
//!    given skin thickness ([`InwardOffset`]).
//! 5. Surfaces that do not nest, or rays that miss, are repaired by [`NestedBoundary`]: a
//!    sample closer than `min_layer` below the level above (or missing) is put `min_layer`
//!    below it along the ray, and counted.

use super::build::{LimbSurfaces, Progress, generate_layered};
use super::centreline::Centreline;
use super::error::GeneratorError;
use super::grid::GridSize;
use super::materials::Materials;
use super::surface::{BoundarySurface, InwardOffset};
use super::vec3::{add, dot, normalize, scale, sub};
use crate::model::Model;
use lamina_mesh::{AxisChoice, CentrelineOptions, LoadOptions, LoadReport, RayCaster, centreline, load};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A triangle surface as a generator boundary: the first crossing of the segment from the
/// ray's origin to the axis point.
pub struct MeshBoundary {
    caster: RayCaster,
}

impl MeshBoundary {
    /// A boundary over `mesh` (builds its BVH).
    pub fn new(mesh: &lamina_mesh::TriMesh) -> Self {
        Self { caster: RayCaster::new(mesh) }
    }
}

impl BoundarySurface for MeshBoundary {
    /// A ray exactly through a shared edge or vertex can slip between the two triangles in
    /// floating point; then it is cast again from origins nudged sideways by 1e-9 of its
    /// length (a nanometre on a limb), which cannot change which surface it meets.
    fn hit_toward_axis(&self, origin: [f64; 3], axis_point: [f64; 3]) -> Option<[f64; 3]> {
        let d = sub(axis_point, origin);
        let length = dot(d, d).sqrt();
        if let Some(h) = self.caster.cast(origin, d, length) {
            return Some(h.point);
        }
        let u = normalize(d)?;
        let side = normalize(super::vec3::cross(u, if u[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] }))?;
        let other = super::vec3::cross(u, side);
        let e = 1e-9 * length;
        [side, other, scale(side, -1.0), scale(other, -1.0)].iter().find_map(|n| {
            let o = add(origin, scale(*n, e));
            self.caster.cast(o, sub(add(axis_point, scale(*n, e)), o), length).map(|h| h.point)
        })
    }
}

/// An inner boundary kept at least `min_layer` (m) below the sample it is cast from: where
/// the surface is missing along the ray, or lies above or too close under the origin (the
/// surfaces do not nest there), the sample is placed `min_layer` below the origin and the
/// repair counted.
pub struct NestedBoundary<'a> {
    /// The surface.
    pub surface: &'a dyn BoundarySurface,
    /// Thinnest layer allowed, m (> 0).
    pub min_layer: f64,
    /// Rays that missed the surface.
    pub missed: Cell<usize>,
    /// Samples closer than `min_layer` to the level above (not nested there).
    pub clamped: Cell<usize>,
}

impl<'a> NestedBoundary<'a> {
    /// Wraps `surface`.
    pub fn new(surface: &'a dyn BoundarySurface, min_layer: f64) -> Self {
        Self { surface, min_layer, missed: Cell::new(0), clamped: Cell::new(0) }
    }
}

impl BoundarySurface for NestedBoundary<'_> {
    fn hit_toward_axis(&self, origin: [f64; 3], axis_point: [f64; 3]) -> Option<[f64; 3]> {
        let u = normalize(sub(axis_point, origin))?;
        let fallback = add(origin, scale(u, self.min_layer));
        match self.surface.hit_toward_axis(origin, axis_point) {
            Some(p) if dot(sub(p, origin), u) >= self.min_layer => Some(p),
            Some(_) => {
                self.clamped.set(self.clamped.get() + 1);
                Some(fallback)
            }
            None => {
                self.missed.set(self.missed.get() + 1);
                Some(fallback)
            }
        }
    }
}

/// What to generate from segmented surfaces.
#[derive(Clone, Debug, PartialEq)]
pub struct AnatomySpec {
    /// Outer skin surface file.
    pub skin: PathBuf,
    /// Fat/muscle boundary surface file.
    pub fat_muscle: PathBuf,
    /// Bone surface file (one bone: the region's centreline runs inside it).
    pub bone: PathBuf,
    /// Region along z, m (`from < to`).
    pub z_range: (f64, f64),
    /// W × H grid.
    pub grid: GridSize,
    /// Skin/fat (dermis bottom) surface file, when segmented: the skin's thickness is then
    /// taken from it along every ray. `None`: the dermis bottom is the outer skin offset
    /// inward by `skin_thickness`.
    pub skin_fat: Option<PathBuf>,
    /// Skin thickness (the dermis bottom below the outer skin) when no `skin_fat` surface is
    /// given, m. Default 2 mm.
    pub skin_thickness: f64,
    /// Thinnest fat or muscle layer allowed where surfaces do not nest, m. Default 1 mm.
    pub min_layer: f64,
    /// Materials of the layers.
    pub materials: Materials,
}

/// What generation found, repaired and took.
#[derive(Clone, Debug, PartialEq)]
pub struct AnatomyReport {
    /// Loader reports of skin, fat/muscle boundary and bone, then the skin/fat surface when
    /// given (flipped triangles fixed, welding).
    pub loads: Vec<(PathBuf, LoadReport)>,
    /// Centreline stations used.
    pub stations: usize,
    /// Skin/fat (dermis bottom) samples placed by the repair: (missed, too close or outside):
    /// where an outer triangle's centroid lies deeper under a concave skin than the skin
    /// thickness.
    pub skin_fat_repairs: (usize, usize),
    /// Fat/muscle samples placed by the nesting repair: (missed, too close or outside).
    pub fat_muscle_repairs: (usize, usize),
    /// Bone samples placed by the nesting repair: (missed, too close or outside).
    pub bone_repairs: (usize, usize),
    /// Seconds per stage: load, centreline, layered generation.
    pub seconds: [f64; 3],
}

/// Why a model could not be generated from surfaces.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AnatomyGenerateError {
    /// A surface file could not be loaded (missing, malformed, holes, ...).
    #[error("{0}")]
    Load(String),
    /// The bone's cross-sections gave no centreline over the region.
    #[error("centreline: {0}")]
    Centreline(String),
    /// The settings are out of range.
    #[error("{0}")]
    Settings(String),
    /// The layered generation failed.
    #[error("{0}")]
    Generate(GeneratorError),
    /// The repairs of one boundary exceed [`MAX_REPAIR_FRACTION`] of its samples: the
    /// surfaces do not describe nested layers (a bone given as the skin, a minimum layer
    /// thicker than the limb), so the model would be the repair's, not the data's.
    #[error("{boundary}: {repaired} of {samples} samples had to be repaired ({:.0} %, more than the {:.0} % allowed): the surfaces do not nest as skin, fat/muscle boundary and bone; check which file is which and min_layer", 100.0 * *.repaired as f64 / (*.samples).max(1) as f64, 100.0 * MAX_REPAIR_FRACTION)]
    TooManyRepairs {
        /// The boundary, e.g. `fat/muscle`.
        boundary: &'static str,
        /// Samples repaired (missed plus too close or outside).
        repaired: usize,
        /// Samples on that boundary.
        samples: usize,
    },
}

/// Largest fraction of a boundary's samples the nesting repair may place: 25 %. The
/// BodyParts3D thigh needs 5.9 % (skin/fat) and 2.8 % (fat/muscle).
pub const MAX_REPAIR_FRACTION: f64 = 0.25;

/// Generates the layered model of `spec`'s region, with a report of defects and times.
pub fn generate_anatomy(
    spec: &AnatomySpec,
    progress: Option<Progress<'_>>,
) -> Result<(Model, AnatomyReport), AnatomyGenerateError> {
    let (z0, z1) = spec.z_range;
    if !(z0.is_finite() && z1.is_finite() && z0 < z1) {
        return Err(AnatomyGenerateError::Settings(format!("z range {z0}..{z1} m is empty")));
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !(positive(spec.skin_thickness) && positive(spec.min_layer)) {
        return Err(AnatomyGenerateError::Settings("skin thickness and minimum layer must be positive".into()));
    }
    let t0 = Instant::now();
    let load_one = |p: &Path| load(p, &LoadOptions::default()).map_err(|e| AnatomyGenerateError::Load(e.to_string()));
    let skin = load_one(&spec.skin)?;
    let fat_muscle = load_one(&spec.fat_muscle)?;
    let bone = load_one(&spec.bone)?;
    let skin_fat = spec.skin_fat.as_deref().map(load_one).transpose()?;
    let t_load = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let stations = (spec.grid.rows as usize * 2).max(8);
    let line = centreline(
        &bone.mesh,
        &CentrelineOptions { axis: AxisChoice::Given([0.0, 0.0, 1.0]), stations, range: Some((z0, z1)) },
    )
    .map_err(|e| AnatomyGenerateError::Centreline(format!("{}: {e}", spec.bone.display())))?;
    let points = line.points();
    let axis = Centreline::new(points.clone()).ok_or_else(|| {
        AnatomyGenerateError::Centreline(format!(
            "{}: {} of {stations} cross-sections between z = {z0} and {z1} m closed",
            spec.bone.display(),
            points.len()
        ))
    })?;
    let t_line = t1.elapsed().as_secs_f64();

    let t2 = Instant::now();
    let skin_b = MeshBoundary::new(&skin.mesh);
    let bb = skin.mesh.bounding_box();
    let reach = 2.0 * bb.map_or(1.0, |b| b.diagonal());
    let dermis = InwardOffset { surface: &skin_b, thickness: spec.skin_thickness, reach };
    let dermis_mesh = skin_fat.as_ref().map(|m| MeshBoundary::new(&m.mesh));
    let dermis_surface: &dyn BoundarySurface = match &dermis_mesh {
        Some(m) => m,
        None => &dermis,
    };
    let dermis_nested = NestedBoundary::new(dermis_surface, 0.5 * spec.skin_thickness.min(spec.min_layer));
    let fat_b = MeshBoundary::new(&fat_muscle.mesh);
    let bone_b = MeshBoundary::new(&bone.mesh);
    let fat_nested = NestedBoundary::new(&fat_b, spec.min_layer);
    let bone_nested = NestedBoundary::new(&bone_b, spec.min_layer);
    let surfaces = LimbSurfaces {
        centreline: &axis,
        outer_skin: &skin_b,
        skin_fat: &dermis_nested,
        fat_muscle: &fat_nested,
        muscle_bone: &bone_nested,
        reach,
    };
    let name = format!("anatomy-{}x{}", spec.grid.columns, spec.grid.rows);
    let mut model = generate_layered(&name, &surfaces, spec.grid, &spec.materials, progress)
        .map_err(AnatomyGenerateError::Generate)?;
    let t_gen = t2.elapsed().as_secs_f64();
    let samples = spec.grid.triangles();
    for (boundary, b) in [("skin/fat", &dermis_nested), ("fat/muscle", &fat_nested), ("bone", &bone_nested)] {
        let repaired = b.missed.get() + b.clamped.get();
        if repaired as f64 > MAX_REPAIR_FRACTION * samples as f64 {
            return Err(AnatomyGenerateError::TooManyRepairs { boundary, repaired, samples });
        }
    }
    let mut loads = vec![
        (spec.skin.clone(), skin.report),
        (spec.fat_muscle.clone(), fat_muscle.report),
        (spec.bone.clone(), bone.report),
    ];
    if let (Some(path), Some(m)) = (&spec.skin_fat, skin_fat) {
        loads.push((path.clone(), m.report));
    }
    let report = AnatomyReport {
        loads,
        stations: points.len(),
        skin_fat_repairs: (dermis_nested.missed.get(), dermis_nested.clamped.get()),
        fat_muscle_repairs: (fat_nested.missed.get(), fat_nested.clamped.get()),
        bone_repairs: (bone_nested.missed.get(), bone_nested.clamped.get()),
        seconds: [t_load, t_line, t_gen],
    };
    model.provenance.push(("anatomy.skin".into(), spec.skin.display().to_string()));
    model.provenance.push(("anatomy.fat_muscle".into(), spec.fat_muscle.display().to_string()));
    model.provenance.push(("anatomy.bone".into(), spec.bone.display().to_string()));
    model.provenance.push(("anatomy.z_range_m".into(), format!("{z0} {z1}")));
    match &spec.skin_fat {
        Some(p) => model.provenance.push(("anatomy.skin_fat".into(), p.display().to_string())),
        None => model.provenance.push(("anatomy.skin_thickness_m".into(), spec.skin_thickness.to_string())),
    }
    model.provenance.push((
        "anatomy.repairs".into(),
        format!(
            "skin/fat missed {} clamped {}; fat/muscle missed {} clamped {}; bone missed {} clamped {}",
            report.skin_fat_repairs.0,
            report.skin_fat_repairs.1,
            report.fat_muscle_repairs.0,
            report.fat_muscle_repairs.1,
            report.bone_repairs.0,
            report.bone_repairs.1
        ),
    ));
    Ok((model, report))
}
