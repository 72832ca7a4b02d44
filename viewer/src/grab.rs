//! Mouse grab (ctrl + left drag in the window), window-free maths: the ray under the cursor,
//! the skin node it picks, and where the grasp point goes as the cursor moves (in the plane
//! through the picked node facing the camera). The window sends the result to the core as
//! tool commands (button 0 held: grasp) on the same `tool` service the haptics process uses.

use glam::Vec3;

use crate::camera::Camera;

/// How far from the cursor a node may be and still be picked, pixels (12).
pub const PICK_RADIUS_PX: f32 = 12.0;

/// A ray: origin and unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start, metres.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

/// The ray from the eye through pixel `(x, y)` (from the top-left corner) of a
/// `width × height` image drawn with `camera`.
pub fn cursor_ray(camera: &Camera, width: f32, height: f32, x: f32, y: f32) -> Ray {
    let forward = (camera.target - camera.eye).normalize();
    let right = forward.cross(camera.up).normalize();
    let up = right.cross(forward);
    let half = (camera.fov_y * 0.5).tan();
    let aspect = width / height.max(1.0);
    let (nx, ny) = (2.0 * x / width.max(1.0) - 1.0, 1.0 - 2.0 * y / height.max(1.0));
    let dir = (forward + right * (nx * half * aspect) + up * (ny * half)).normalize();
    Ray { origin: camera.eye, dir }
}

/// The node of `candidates` (indices into `positions`) the cursor picks: among those in front
/// of the eye within [`PICK_RADIUS_PX`] pixels of the ray (at their depth, for an image
/// `height` pixels tall with the camera's `fov_y`), the nearest to the eye. `None` if none.
pub fn pick_node(ray: &Ray, fov_y: f32, height: f32, positions: &[Vec3], candidates: &[u32]) -> Option<u32> {
    let metres_per_px_per_m = 2.0 * (fov_y * 0.5).tan() / height.max(1.0);
    let mut best: Option<(f32, u32)> = None;
    for &i in candidates {
        let Some(&p) = positions.get(i as usize) else { continue };
        let t = (p - ray.origin).dot(ray.dir);
        if t <= 0.0 {
            continue;
        }
        let off_ray = (p - (ray.origin + ray.dir * t)).length();
        if off_ray <= PICK_RADIUS_PX * metres_per_px_per_m * t && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, i));
        }
    }
    best.map(|(_, i)| i)
}

/// Where `ray` meets the plane through `point` with normal `normal`; `None` when parallel or
/// behind the origin.
pub fn on_plane(ray: &Ray, point: Vec3, normal: Vec3) -> Option<Vec3> {
    let denom = ray.dir.dot(normal);
    if denom.abs() < 1e-6 {
        return None;
    }
    let t = (point - ray.origin).dot(normal) / denom;
    (t > 0.0).then(|| ray.origin + ray.dir * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eye at (0, 0, 2) looking at the origin, 90° vertical field of view.
    fn camera() -> Camera {
        Camera { eye: Vec3::new(0.0, 0.0, 2.0), target: Vec3::ZERO, up: Vec3::Y, fov_y: core::f32::consts::FRAC_PI_2 }
    }

    #[test]
    fn cursor_ray_goes_through_the_pixel_works() {
        // Centre pixel: straight at the target.
        let r = cursor_ray(&camera(), 200.0, 100.0, 100.0, 50.0);
        assert!((r.dir - Vec3::NEG_Z).length() < 1e-6);
        // Top-right corner of a 2:1 image, 90° vertical: direction (2 tan 45°, tan 45°, -1).
        let r = cursor_ray(&camera(), 200.0, 100.0, 200.0, 0.0);
        assert!((r.dir - Vec3::new(2.0, 1.0, -1.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn pick_takes_the_nearest_node_under_the_cursor_works() {
        // Two nodes on the centre ray (front at z = 0.5, back at z = -0.5), one off to the
        // side, one behind the eye.
        let positions =
            [Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 3.0)];
        let ray = cursor_ray(&camera(), 100.0, 100.0, 50.0, 50.0);
        let fov = camera().fov_y;
        assert_eq!(pick_node(&ray, fov, 100.0, &positions, &[0, 1, 2, 3]), Some(1));
        assert_eq!(pick_node(&ray, fov, 100.0, &positions, &[0, 2, 3]), Some(0));
        // The side node is 0.5 m off the ray at 2 m: 0.5 / (2 · 2 · tan 45° / 100) = 12.5 px.
        assert_eq!(pick_node(&ray, fov, 100.0, &positions, &[2, 3]), None);
        let near = cursor_ray(&camera(), 100.0, 100.0, 50.0 + 12.5, 50.0);
        assert_eq!(pick_node(&near, fov, 100.0, &positions, &[2, 3]), Some(2));
        assert_eq!(pick_node(&ray, fov, 100.0, &positions, &[9]), None, "out-of-range index");
    }

    #[test]
    fn drag_point_stays_in_the_view_plane_works() {
        // The plane z = 0.5 facing the camera; the ray through the top-right quarter point.
        let r = cursor_ray(&camera(), 100.0, 100.0, 75.0, 25.0);
        let p = on_plane(&r, Vec3::new(0.0, 0.0, 0.5), Vec3::Z).unwrap();
        // Direction (0.5, 0.5, -1): 1.5 m down the axis reaches z = 0.5 at x = y = 0.75.
        assert!((p - Vec3::new(0.75, 0.75, 0.5)).length() < 1e-5, "{p:?}");
        assert_eq!(on_plane(&r, Vec3::new(0.0, 0.0, 3.0), Vec3::Z), None, "behind the eye");
        assert_eq!(on_plane(&r, Vec3::ZERO, Vec3::X.cross(r.dir).normalize()), None, "parallel");
    }
}
