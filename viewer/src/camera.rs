//! The default view: a camera framing the model from the side of the cut, and the cut plane
//! itself, both fixed from the first frame's bounds so the picture does not swim as the
//! tissue moves. [`OrbitCamera`] moves the camera around that view (orbit, pan, zoom, reset)
//! as the window's mouse bindings ask; it needs no window, so its maths is unit-tested.

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

/// A camera the user moves: orbit about its target, pan in the view plane, zoom toward the
/// target, and reset to the view it started from. The target starts at the model's centre
/// (see [`default_view`]).
///
/// # Examples
///
/// ```
/// use glam::Vec3;
/// use lamina_viewer::camera::{Camera, OrbitCamera};
///
/// let start = Camera { eye: Vec3::new(0.0, 0.0, 2.0), target: Vec3::ZERO, up: Vec3::Y, fov_y: 1.0 };
/// let mut cam = OrbitCamera::new(start);
/// cam.orbit(core::f32::consts::FRAC_PI_2, 0.0);
/// assert!((cam.camera().eye - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5);
/// cam.reset();
/// assert_eq!(cam.camera(), start);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    initial: Camera,
    current: Camera,
}

impl OrbitCamera {
    /// Closest the eye comes to the target, as a fraction of the initial distance (1 %).
    pub const MIN_DISTANCE_FRACTION: f32 = 0.01;
    /// Farthest the eye goes from the target, as a multiple of the initial distance (20).
    pub const MAX_DISTANCE_FACTOR: f32 = 20.0;
    /// Distance factor of one zoom step (one wheel notch): 0.9, i.e. 10 % closer.
    pub const ZOOM_STEP: f32 = 0.9;
    /// Smallest angle between the view direction and the up axis, radians (2°): orbiting
    /// stops there instead of flipping over the pole.
    pub const POLE_MARGIN: f32 = 2.0 * core::f32::consts::PI / 180.0;

    /// Starts at (and resets to) `initial`.
    pub fn new(initial: Camera) -> Self {
        Self { initial, current: initial }
    }

    /// The camera as it is now.
    pub fn camera(&self) -> Camera {
        self.current
    }

    /// The camera [`OrbitCamera::reset`] returns to.
    pub fn initial(&self) -> Camera {
        self.initial
    }

    /// Distance from the eye to the target, metres.
    pub fn distance(&self) -> f32 {
        (self.current.eye - self.current.target).length()
    }

    /// Rotates the eye about the target: `yaw` radians about the up axis (positive turns the
    /// eye counter-clockwise seen from above), then `pitch` radians about the camera's right
    /// axis (positive raises the eye). The distance to the target does not change; the pitch
    /// stops [`Self::POLE_MARGIN`] short of looking straight along the up axis.
    pub fn orbit(&mut self, yaw: f32, pitch: f32) {
        let c = &mut self.current;
        let up = c.up.normalize();
        let offset = glam::Quat::from_axis_angle(up, yaw) * (c.eye - c.target);
        let distance = offset.length();
        let dir = offset / distance;
        // Elevation of the eye above the plane normal to `up`, clamped short of the poles.
        let elevation = dir.dot(up).clamp(-1.0, 1.0).asin();
        let limit = core::f32::consts::FRAC_PI_2 - Self::POLE_MARGIN;
        let new_elevation = (elevation + pitch).clamp(-limit, limit);
        let horizontal = (dir - up * dir.dot(up)).try_normalize().unwrap_or_else(|| up.any_orthonormal_vector());
        let dir = horizontal * new_elevation.cos() + up * new_elevation.sin();
        c.eye = c.target + dir * distance;
    }

    /// Moves eye and target together in the view plane by `dx`, `dy` pixels of a viewport
    /// `height` pixels tall, so the point at the target follows the cursor: dragging right
    /// moves the camera left. One pixel is `2 · distance · tan(fov_y / 2) / height` metres.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let c = &mut self.current;
        let forward = (c.target - c.eye).normalize();
        let right = forward.cross(c.up).normalize();
        let up = right.cross(forward);
        let metres_per_pixel = 2.0 * (c.eye - c.target).length() * (c.fov_y * 0.5).tan() / height.max(1.0);
        let shift = (-right * dx + up * dy) * metres_per_pixel;
        c.eye += shift;
        c.target += shift;
    }

    /// Moves the eye toward the target (`steps > 0`) or away from it: the distance is
    /// multiplied by [`Self::ZOOM_STEP`]`^steps`, kept between [`Self::MIN_DISTANCE_FRACTION`]
    /// and [`Self::MAX_DISTANCE_FACTOR`] times the initial distance. The eye never reaches or
    /// passes the target.
    pub fn zoom(&mut self, steps: f32) {
        let initial = (self.initial.eye - self.initial.target).length();
        let c = &mut self.current;
        let offset = c.eye - c.target;
        let distance = (offset.length() * Self::ZOOM_STEP.powf(steps))
            .clamp(initial * Self::MIN_DISTANCE_FRACTION, initial * Self::MAX_DISTANCE_FACTOR);
        c.eye = c.target + offset.normalize() * distance;
    }

    /// Back to the initial view.
    pub fn reset(&mut self) {
        self.current = self.initial;
    }
}

/// A close view of one spot instead of the whole model: the camera looks at `target` from
/// direction `from` (pointing from the target toward the eye), far enough that `span_m`
/// metres fit the image's height at the target's distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Focus {
    /// Point looked at, metres, model frame.
    pub target: Vec3,
    /// Direction from the target toward the eye (any length but zero).
    pub from: Vec3,
    /// Height of the view at the target, metres.
    pub span_m: f32,
}

impl Focus {
    /// The camera of this focus (30° vertical field of view, y up).
    ///
    /// # Examples
    ///
    /// ```
    /// use glam::Vec3;
    /// use lamina_viewer::camera::Focus;
    ///
    /// let f = Focus { target: Vec3::ZERO, from: Vec3::Z, span_m: 0.1 };
    /// let c = f.camera();
    /// // 0.1 m fill the height: half of it over the distance is tan(15°).
    /// assert!((0.05 / c.eye.z - 15f32.to_radians().tan()).abs() < 1e-6);
    /// ```
    pub fn camera(&self) -> Camera {
        let fov_y = 30f32.to_radians();
        let distance = self.span_m.max(1e-4) * 0.5 / (fov_y * 0.5).tan();
        let from = self.from.try_normalize().unwrap_or(Vec3::Z);
        Camera { eye: self.target + from * distance, target: self.target, up: Vec3::Y, fov_y }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Looking down -z at the origin from 2 m, 90° vertical field of view.
    fn start() -> Camera {
        Camera { eye: Vec3::new(0.0, 0.0, 2.0), target: Vec3::ZERO, up: Vec3::Y, fov_y: core::f32::consts::FRAC_PI_2 }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn orbit_keeps_the_distance_to_the_target_works() {
        let mut cam = OrbitCamera::new(start());
        for (yaw, pitch) in [(0.3, 0.2), (-1.1, 0.7), (2.5, -1.4), (0.0, 3.0), (-4.0, -3.0)] {
            cam.orbit(yaw, pitch);
            assert!((cam.distance() - 2.0).abs() < 1e-5, "distance {} after ({yaw}, {pitch})", cam.distance());
            assert_eq!(cam.camera().target, Vec3::ZERO);
        }
    }

    #[test]
    fn orbit_follows_closed_forms_works() {
        // Yaw θ about +y takes (0, 0, d) to (d sin θ, 0, d cos θ).
        let mut cam = OrbitCamera::new(start());
        cam.orbit(0.5, 0.0);
        assert!(close(cam.camera().eye, Vec3::new(2.0 * 0.5f32.sin(), 0.0, 2.0 * 0.5f32.cos())));
        // Pitch φ from the horizontal raises the eye to height d sin φ.
        let mut cam = OrbitCamera::new(start());
        cam.orbit(0.0, 0.6);
        assert!(close(cam.camera().eye, Vec3::new(0.0, 2.0 * 0.6f32.sin(), 2.0 * 0.6f32.cos())));
        // A pitch past the pole stops 2° short of it.
        cam.orbit(0.0, 10.0);
        let limit = 88f32.to_radians();
        assert!(close(cam.camera().eye, Vec3::new(0.0, 2.0 * limit.sin(), 2.0 * limit.cos())));
    }

    #[test]
    fn pan_moves_target_and_eye_by_the_same_vector_works() {
        let mut cam = OrbitCamera::new(start());
        // 90° field of view at 2 m: the 100 px viewport spans 2 · 2 · tan 45° = 4 m, 0.04 m/px.
        cam.pan(10.0, 5.0, 100.0);
        let expected = Vec3::new(-0.4, 0.2, 0.0);
        assert!(close(cam.camera().target, expected), "{:?}", cam.camera().target);
        assert!(close(cam.camera().eye, Vec3::new(0.0, 0.0, 2.0) + expected));
        assert!((cam.distance() - 2.0).abs() < 1e-5);
    }

    #[test]
    fn zoom_follows_the_step_and_never_crosses_the_target_works() {
        let mut cam = OrbitCamera::new(start());
        cam.zoom(1.0);
        assert!((cam.distance() - 1.8).abs() < 1e-5);
        cam.zoom(-2.0);
        assert!((cam.distance() - 2.0 / 0.9).abs() < 1e-5);
        cam.zoom(10_000.0);
        assert!((cam.distance() - 0.02).abs() < 1e-6, "stops at 1 % of 2 m: {}", cam.distance());
        assert!(cam.camera().eye.z > 0.0, "the eye stays on its side of the target");
        cam.zoom(-10_000.0);
        assert!((cam.distance() - 40.0).abs() < 1e-3, "stops at 20 × 2 m: {}", cam.distance());
        assert!(cam.camera().eye.z > 0.0);
    }

    #[test]
    fn reset_returns_to_the_initial_view_works() {
        let mut cam = OrbitCamera::new(start());
        cam.orbit(1.0, 0.4);
        cam.pan(30.0, -12.0, 480.0);
        cam.zoom(3.0);
        assert_ne!(cam.camera(), start());
        cam.reset();
        assert_eq!(cam.camera(), start());
    }
}
