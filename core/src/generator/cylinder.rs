//! An analytic circular cylinder: the boundaries of the synthetic limb.

use super::surface::BoundarySurface;
use super::vec3::{add, dot, scale, sub};

/// An infinite circular cylinder of radius `radius` (m) around the line through `point`
/// along `direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    /// A point of the axis, m.
    pub point: [f64; 3],
    /// Axis direction, unit vector.
    pub direction: [f64; 3],
    /// Radius, m (> 0).
    pub radius: f64,
}

impl Cylinder {
    /// Distance of `p` (m) from the axis, m.
    pub fn distance_from_axis(&self, p: [f64; 3]) -> f64 {
        let rel = sub(p, self.point);
        let perp = sub(rel, scale(self.direction, dot(rel, self.direction)));
        dot(perp, perp).sqrt()
    }
}

impl BoundarySurface for Cylinder {
    fn hit_toward_axis(&self, origin: [f64; 3], axis_point: [f64; 3]) -> Option<[f64; 3]> {
        // |o⊥ + t d⊥|² = r² on t ∈ [0, 1], in the plane normal to the axis.
        let u = self.direction;
        let rel = sub(origin, self.point);
        let o = sub(rel, scale(u, dot(rel, u)));
        let d_full = sub(axis_point, origin);
        let d = sub(d_full, scale(u, dot(d_full, u)));
        let a = dot(d, d);
        let b = 2.0 * dot(o, d);
        let c = dot(o, o) - self.radius * self.radius;
        if a <= 0.0 {
            return None;
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        // Numerically stable roots.
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = [t0, t1].into_iter().find(|t| (0.0..=1.0).contains(t))?;
        Some(add(origin, scale(d_full, t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const Z: Cylinder = Cylinder { point: [0.0; 3], direction: [0.0, 0.0, 1.0], radius: 0.05 };

    #[test]
    fn cylinder_hit_from_outside_works() {
        let p = Z.hit_toward_axis([0.2, 0.0, 0.1], [0.0, 0.0, 0.1]).unwrap();
        assert!((p[0] - 0.05).abs() < 1e-15 && p[1] == 0.0 && p[2] == 0.1);
        let p = Z.hit_toward_axis([0.3, 0.4, 0.0], [0.0, 0.0, 0.2]).unwrap();
        assert!((Z.distance_from_axis(p) - 0.05).abs() < 1e-15);
    }

    #[test]
    fn cylinder_hit_from_inside_fails() {
        assert_eq!(Z.hit_toward_axis([0.03, 0.0, 0.0], [0.0, 0.0, 0.0]), None);
        assert_eq!(Z.hit_toward_axis([0.2, 0.0, 0.0], [0.1, 0.0, 0.0]), None);
    }
}
