//! The default view: a camera framing the model from the side of the cut, and the cut plane
//! itself, both fixed from the first frame's bounds so the picture does not swim as the
//! tissue moves.

use glam::{Mat4, Vec3};

use crate::cut::CutPlane;

/// A perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position, metres.
    pub eye: Vec3,
    /// Point looked at, metres.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl Camera {
    /// The camera that frames the box `min..max` (the model's extent) looking from direction
    /// `from` (pointing from the box centre toward the eye), with a small margin.
    pub fn framing(min: Vec3, max: Vec3, from: Vec3, aspect: f32) -> Self {
        let target = (min + max) * 0.5;
        let radius = ((max - min) * 0.5).length().max(1e-3);
        let fov_y = 30f32.to_radians();
        // Fit the bounding sphere in the narrower of the two fields of view.
        let half = (fov_y * 0.5).tan().min((fov_y * 0.5).tan() * aspect).atan();
        let distance = radius / half.sin() * 0.86;
        Self { eye: target + from.normalize() * distance, target, up: Vec3::Y, fov_y }
    }

    /// World to clip space (wgpu depth range 0..1) for an image of `aspect` = width / height.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let distance = (self.eye - self.target).length();
        // WebGPU clip space is DirectX's: z in 0..1, y up.
        let proj = glam::camera::rh::proj::directx::perspective(self.fov_y, aspect, distance * 0.05, distance * 4.0);
        proj * glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }
}

/// The axis-aligned bounds of `points` (`None` when empty or not finite).
pub fn bounds(points: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let first = *points.first()?;
    let (min, max) = points.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    (min.is_finite() && max.is_finite()).then_some((min, max))
}

/// The default view of a model with bounds `min..max`: the cut is transverse to the longest
/// axis, 28 % of the length from its far end, removing that end; the camera looks at the cut
/// face from above and in front.
pub fn default_view(min: Vec3, max: Vec3, aspect: f32) -> (Camera, CutPlane) {
    let extent = max - min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        Vec3::X
    } else if extent.z >= extent.y {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let length = extent.dot(axis);
    let centre = (min + max) * 0.5;
    let cut = CutPlane::through(centre + axis * (0.5 - 0.28) * length, axis);
    // Look from the removed side, above and in front; for an x-axis limb: (+x, +y, +z).
    let side = if axis == Vec3::Z { Vec3::X } else { Vec3::Z };
    let from = axis * 0.62 + Vec3::Y * 0.6 + side * 1.0;
    // Frame the exploded wireframe of the removed end too (see `MeshOptions::explode`).
    let max = max + axis * 0.12 * length;
    (Camera::framing(min, max, from, aspect), cut)
}
