//! The tissue boundaries the generator samples, behind one ray query.

use super::vec3::{add, dot, normalize, scale, sub};

/// One of the four tissue boundaries, outermost first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Boundary {
    /// The outer skin (epidermis surface).
    OuterSkin,
    /// Skin / fat: the bottom of the dermis.
    SkinFat,
    /// Fat / muscle.
    FatMuscle,
    /// Muscle / bone (the periosteum); the nodes on it are fixed.
    MuscleBone,
}

impl Boundary {
    /// All four, outermost first.
    pub const ALL: [Boundary; 4] = [Boundary::OuterSkin, Boundary::SkinFat, Boundary::FatMuscle, Boundary::MuscleBone];

    /// Name used in messages and as the model's surface name: `skin_outer`, `skin_fat`,
    /// `fat_muscle`, `muscle_bone`.
    pub fn name(self) -> &'static str {
        match self {
            Boundary::OuterSkin => "skin_outer",
            Boundary::SkinFat => "skin_fat",
            Boundary::FatMuscle => "fat_muscle",
            Boundary::MuscleBone => "muscle_bone",
        }
    }
}

/// A closed tissue boundary around the limb's centreline, as the generator sees it: the
/// only question it asks is where a ray cast toward the axis first meets the surface.
///
/// Implemented here by the analytic [`Cylinder`](super::Cylinder) and by [`InwardOffset`];
/// a triangle mesh with a BVH (crate `lamina-mesh`) implements it for segmented data.
pub trait BoundarySurface {
    /// The first point where the segment from `origin` to `axis_point` (both m) crosses the
    /// surface, walking from `origin`; `None` when the segment does not cross it (for
    /// example because `origin` already lies inside the surface).
    fn hit_toward_axis(&self, origin: [f64; 3], axis_point: [f64; 3]) -> Option<[f64; 3]>;
}

impl<S: BoundarySurface + ?Sized> BoundarySurface for &S {
    fn hit_toward_axis(&self, origin: [f64; 3], axis_point: [f64; 3]) -> Option<[f64; 3]> {
        (**self).hit_toward_axis(origin, axis_point)
    }
}

/// A surface `thickness` (m) inside another one, measured along each ray: the dermis bottom
/// of segmented data, which has only the outer skin, is the outer skin offset inward by
/// the skin thickness (about 2 mm on a forearm).
///
/// A query first extends its segment backward by `reach` (m) to find where the ray enters
/// `surface`, then steps `thickness` further toward the axis. Where rays meet the skin at
/// right angles (a cylinder, any surface the centreline rays cross normally) this is the
/// true normal offset; where they meet it obliquely the layer is thicker than `thickness`
/// along the normal by `1/cos` of the angle.
#[derive(Clone, Debug, PartialEq)]
pub struct InwardOffset<S> {
    /// The surface offset (usually the outer skin).
    pub surface: S,
    /// Offset along the ray, m (> 0).
    pub thickness: f64,
    /// How far behind a query's origin to start looking for `surface`, m: at least the
    /// largest distance from an origin back to the outer skin (twice the limb's radius is
    /// ample).
    pub reach: f64,
}

impl<S: BoundarySurface> BoundarySurface for InwardOffset<S> {
    fn hit_toward_axis(&self, origin: [f64; 3], axis_point: [f64; 3]) -> Option<[f64; 3]> {
        let d = sub(axis_point, origin);
        let length = dot(d, d).sqrt();
        let u = normalize(d)?;
        let start = sub(origin, scale(u, self.reach));
        let entry = self.surface.hit_toward_axis(start, axis_point)?;
        let point = add(entry, scale(u, self.thickness));
        let t = dot(sub(point, origin), u);
        (0.0..=length).contains(&t).then_some(point)
    }
}
