//! Ray casting against a [`TriMesh`] through a bounding-volume hierarchy (parry3d-f64's).
//!
//! # Examples
//! ```
//! use lamina_mesh::{RayCaster, synthetic};
//! let sphere = synthetic::sphere([0.0, 0.0, 0.0], 0.05, 4);
//! let caster = RayCaster::new(&sphere);
//! // From 0.2 m out on +x, toward the centre: the surface is about 0.15 m away.
//! let hit = caster.cast([0.2, 0.0, 0.0], [-1.0, 0.0, 0.0], f64::INFINITY).unwrap();
//! assert!((hit.t - 0.15).abs() < 1e-3);
//! assert!(hit.normal[0] > 0.99); // outward normal of the hit triangle
//! ```

use parry3d_f64::math::Vector;
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::{TriMesh as ParryTriMesh, TriMeshFlags};

use crate::trimesh::TriMesh;
use crate::vec3::{self, V3};

/// One intersection of a ray with the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Distance from the ray origin to the hit (m); the direction is normalised first.
    pub t: f64,
    /// Index of the triangle hit.
    pub triangle: u32,
    /// Hit point (m).
    pub point: [f64; 3],
    /// Unit normal of the hit triangle by its winding (outward for a surface loaded with
    /// [`crate::load()`]), not turned toward the ray; zero for a zero-area triangle.
    pub normal: [f64; 3],
}

/// A ray caster over one surface; build once, cast many rays (it is `Sync`).
#[derive(Clone)]
pub struct RayCaster {
    shape: Option<ParryTriMesh>,
    normals: Vec<V3>,
}

impl std::fmt::Debug for RayCaster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RayCaster").field("triangles", &self.normals.len()).finish()
    }
}

impl RayCaster {
    /// Builds the hierarchy over `mesh`'s triangles (O(n log n)). An empty mesh gives a
    /// caster that never hits.
    pub fn new(mesh: &TriMesh) -> Self {
        let vertices: Vec<Vector> = mesh.vertices().iter().map(|v| Vector::new(v[0], v[1], v[2])).collect();
        let shape = ParryTriMesh::with_flags(vertices, mesh.triangles().to_vec(), TriMeshFlags::empty()).ok();
        let normals = (0..mesh.triangle_count()).map(|t| mesh.triangle_normal(t).unwrap_or([0.0; 3])).collect();
        Self { shape, normals }
    }

    fn ray(origin: [f64; 3], dir: [f64; 3], max_t: f64) -> Option<Ray> {
        let d = vec3::normalize(dir)?;
        if !vec3::is_finite(origin) || max_t.is_nan() || max_t < 0.0 {
            return None;
        }
        Some(Ray::new(Vector::new(origin[0], origin[1], origin[2]), Vector::new(d[0], d[1], d[2])))
    }

    fn hit(&self, ray: &Ray, t: f64, triangle: u32) -> RayHit {
        let p = ray.point_at(t);
        RayHit { t, triangle, point: [p.x, p.y, p.z], normal: self.normals[triangle as usize] }
    }

    /// First hit of the ray from `origin` (m) along `dir` (any length, normalised here)
    /// within distance `max_t` (m; `f64::INFINITY` for no limit). Both faces of a triangle
    /// are hit. `None` when nothing is hit, or `dir` is zero, or an input is not finite
    /// (`max_t` may be infinite).
    pub fn cast(&self, origin: [f64; 3], dir: [f64; 3], max_t: f64) -> Option<RayHit> {
        let shape = self.shape.as_ref()?;
        let ray = Self::ray(origin, dir, max_t)?;
        let hit = shape.cast_local_ray_and_get_normal(&ray, max_t, false)?;
        Some(self.hit(&ray, hit.time_of_impact, hit.subshape))
    }

    /// Every hit of the ray within `max_t` (m), sorted by distance (then triangle index).
    /// A ray through a shared edge or vertex reports one hit per triangle touched there.
    /// Empty under the same conditions as [`RayCaster::cast`] returns `None`.
    pub fn cast_all(&self, origin: [f64; 3], dir: [f64; 3], max_t: f64) -> Vec<RayHit> {
        let (Some(shape), Some(ray)) = (self.shape.as_ref(), Self::ray(origin, dir, max_t)) else {
            return Vec::new();
        };
        let mut hits: Vec<RayHit> = shape
            .bvh()
            .leaves(|node| {
                let t = node.cast_ray(&ray, max_t);
                t < f64::MAX && t <= max_t
            })
            .filter_map(|tri| shape.triangle(tri).cast_local_ray(&ray, max_t, false).map(|t| self.hit(&ray, t, tri)))
            .collect();
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
        hits
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check<T: Send + Sync>() {}

    #[test]
    fn raycaster_is_send_sync_works() {
        check::<RayCaster>();
    }
}
