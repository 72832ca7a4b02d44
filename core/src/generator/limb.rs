//! The built-in synthetic limb: four coaxial cylinders around a straight centreline.

use super::build::{LimbSurfaces, Progress, generate_layered};
use super::centreline::Centreline;
use super::cylinder::Cylinder;
use super::error::GeneratorError;
use super::grid::GridSize;
use super::materials::Materials;
use super::surface::Boundary;
use crate::model::Model;

/// A cylindrical limb along +z from the origin: outer skin, skin/fat, fat/muscle and
/// muscle/bone boundaries are coaxial cylinders. Defaults: the paper's 39 × 10 grid,
/// 0.30 m long, radii 50 / 48 / 40 / 15 mm (skin 2 mm, fat 8 mm, muscle 25 mm thick).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylinderLimb {
    /// W × H grid. Default 39 × 10.
    pub grid: GridSize,
    /// Length along the axis, m. Default 0.30.
    pub length: f64,
    /// Outer skin radius, m. Default 0.050.
    pub outer_skin_radius: f64,
    /// Skin/fat (dermis bottom) radius, m. Default 0.048.
    pub skin_fat_radius: f64,
    /// Fat/muscle radius, m. Default 0.040.
    pub fat_muscle_radius: f64,
    /// Muscle/bone radius, m. Default 0.015.
    pub bone_radius: f64,
}

impl Default for CylinderLimb {
    fn default() -> Self {
        Self {
            grid: GridSize::new(39, 10),
            length: 0.30,
            outer_skin_radius: 0.050,
            skin_fat_radius: 0.048,
            fat_muscle_radius: 0.040,
            bone_radius: 0.015,
        }
    }
}

impl CylinderLimb {
    /// The default limb on a `columns × rows` grid.
    pub fn new(columns: u32, rows: u32) -> Self {
        Self { grid: GridSize::new(columns, rows), ..Self::default() }
    }

    /// Shortest length or radius accepted, m: 1 µm.
    pub const MIN_SIZE_M: f64 = 1e-6;
    /// Longest length or radius accepted, m: 1 km.
    pub const MAX_SIZE_M: f64 = 1e3;

    /// Length and radii within [[`MIN_SIZE_M`](Self::MIN_SIZE_M),
    /// [`MAX_SIZE_M`](Self::MAX_SIZE_M)] (1 µm to 1 km), radii decreasing strictly inward.
    pub fn is_valid(&self) -> bool {
        let r = [self.outer_skin_radius, self.skin_fat_radius, self.fat_muscle_radius, self.bone_radius];
        let in_range = |x: f64| (Self::MIN_SIZE_M..=Self::MAX_SIZE_M).contains(&x);
        in_range(self.length) && r.iter().all(|x| in_range(*x)) && r.windows(2).all(|p| p[0] > p[1])
    }

    /// The centreline: from the origin to `(0, 0, length)`; `None` when the length is not a
    /// positive length whose square is a normal number (below about 1e-154 m).
    pub fn centreline(&self) -> Option<Centreline> {
        Centreline::new(vec![[0.0; 3], [0.0, 0.0, self.length]])
    }

    /// Radius of `boundary`, m.
    pub fn radius(&self, boundary: Boundary) -> f64 {
        match boundary {
            Boundary::OuterSkin => self.outer_skin_radius,
            Boundary::SkinFat => self.skin_fat_radius,
            Boundary::FatMuscle => self.fat_muscle_radius,
            Boundary::MuscleBone => self.bone_radius,
        }
    }

    /// The cylinder of `boundary`.
    pub fn cylinder(&self, boundary: Boundary) -> Cylinder {
        Cylinder { point: [0.0; 3], direction: [0.0, 0.0, 1.0], radius: self.radius(boundary) }
    }
}

/// Generates the layered model of a cylinder limb (model name `cylinder-limb-WxH`).
/// Rays start at twice the outer radius. Fails when the spec is invalid or when the
/// skin is thinner than the sagitta of the outer triangles (too few columns for its
/// thickness: a triangle's centroid then lies below the skin/fat cylinder).
pub fn generate(spec: &CylinderLimb, materials: &Materials) -> Result<Model, GeneratorError> {
    generate_with_progress(spec, materials, None)
}

/// [`generate`] reporting progress (see [`Progress`]).
pub fn generate_with_progress(
    spec: &CylinderLimb,
    materials: &Materials,
    progress: Option<Progress<'_>>,
) -> Result<Model, GeneratorError> {
    let Some(centreline) = spec.centreline().filter(|_| spec.is_valid()) else {
        return Err(GeneratorError::BadCylinder);
    };
    let [outer, skin_fat, fat_muscle, muscle_bone] = Boundary::ALL.map(|b| spec.cylinder(b));
    let surfaces = LimbSurfaces {
        centreline: &centreline,
        outer_skin: &outer,
        skin_fat: &skin_fat,
        fat_muscle: &fat_muscle,
        muscle_bone: &muscle_bone,
        reach: 2.0 * spec.outer_skin_radius,
    };
    let name = format!("cylinder-limb-{}x{}", spec.grid.columns, spec.grid.rows);
    let mut model = generate_layered(&name, &surfaces, spec.grid, materials, progress)?;
    model.provenance.push((
        "cylinder_radii_m".into(),
        format!("{} {} {} {}", spec.outer_skin_radius, spec.skin_fat_radius, spec.fat_muscle_radius, spec.bone_radius),
    ));
    Ok(model)
}
