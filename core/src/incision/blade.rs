//! The scalpel's cutting edge and the surface it sweeps between two ticks.
//!
//! A blade is a segment, its *edge*, from the tip up along the tool's local `+y` axis (the
//! wire's convention: identity orientation points the edge straight up from the tip, for the
//! shipped limbs whose skin faces `+y` under the device). Between two ticks the edge sweeps
//! the quadrilateral `tip₀, back₀, back₁, tip₁`; a spring whose segment crosses it is cut.
//! The quadrilateral is split into two triangles along `tip₀–back₁`, and a segment crosses it
//! when it crosses either triangle (Möller and Trumbore's test, in `f64`). A blade moving
//! along its own edge (pushed straight in) sweeps no area and crosses nothing.

use crate::generator::vec3::{cross, dot, norm, sub};

/// Below this swept area, m², a sweep cuts nothing (the blade moved along its edge).
pub const MIN_SWEPT_AREA_M2: f64 = 1e-12;

/// The cutting edge at one instant: a segment from `tip` to `back`, m, model frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blade {
    /// The deepest point of the edge, m.
    pub tip: [f64; 3],
    /// The other end of the edge, m.
    pub back: [f64; 3],
}

impl Blade {
    /// The edge of a blade `length` m long whose tip is at `tip` (m) with orientation
    /// `orientation` (unit quaternion `[x, y, z, w]`): from the tip along the rotated `+y`.
    ///
    /// ```
    /// use lamina_core::incision::Blade;
    ///
    /// // A quarter turn about z tips the edge from +y to -x.
    /// let h = std::f64::consts::FRAC_1_SQRT_2;
    /// let b = Blade::from_pose([0.0, 0.05, 0.1], [0.0, 0.0, h, h], 0.01);
    /// assert!((b.back[0] + 0.01).abs() < 1e-12 && (b.back[1] - 0.05).abs() < 1e-12);
    /// ```
    pub fn from_pose(tip: [f64; 3], orientation: [f64; 4], length: f64) -> Self {
        let [x, y, z, w] = orientation;
        let n = (x * x + y * y + z * z + w * w).sqrt();
        let (x, y, z, w) = if n > 0.0 && n.is_finite() { (x / n, y / n, z / n, w / n) } else { (0.0, 0.0, 0.0, 1.0) };
        // The rotation matrix's second column: R · (0, 1, 0).
        let axis = [2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x)];
        Self { tip, back: [0, 1, 2].map(|c| tip[c] + length * axis[c]) }
    }

    /// The edge's length, m.
    pub fn length(&self) -> f64 {
        norm(sub(self.back, self.tip))
    }

    /// The point a fraction `s` (0 at the tip, 1 at the back) along the edge, m.
    pub fn point(&self, s: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| self.tip[c] + s * (self.back[c] - self.tip[c]))
    }
}

/// The surface a blade's edge sweeps from one pose to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sweep {
    /// The edge at the start of the tick.
    pub from: Blade,
    /// The edge at its end.
    pub to: Blade,
}

impl Sweep {
    /// The quadrilateral's two triangles, `(tip₀, back₀, back₁)` and `(tip₀, back₁, tip₁)`.
    pub fn triangles(&self) -> [[[f64; 3]; 3]; 2] {
        let (f, t) = (self.from, self.to);
        [[f.tip, f.back, t.back], [f.tip, t.back, t.tip]]
    }

    /// Area of the swept surface, m² (the two triangles').
    pub fn area(&self) -> f64 {
        self.triangles().iter().map(|[a, b, c]| 0.5 * norm(cross(sub(*b, *a), sub(*c, *a)))).sum()
    }

    /// Centre and radius of a sphere holding the swept surface, m.
    pub fn bounding_sphere(&self) -> ([f64; 3], f64) {
        let corners = [self.from.tip, self.from.back, self.to.back, self.to.tip];
        let centre = [0, 1, 2].map(|c| corners.iter().map(|p| p[c]).sum::<f64>() / 4.0);
        let radius = corners.iter().map(|p| norm(sub(*p, centre))).fold(0.0, f64::max);
        (centre, radius)
    }

    /// Whether the segment `p`–`q` (m) crosses the swept surface. A sweep of less than
    /// [`MIN_SWEPT_AREA_M2`] crosses nothing.
    pub fn crosses(&self, p: [f64; 3], q: [f64; 3]) -> bool {
        self.area() >= MIN_SWEPT_AREA_M2 && self.triangles().iter().any(|t| segment_crosses_triangle(p, q, t))
    }
}

/// Whether the segment `p`–`q` crosses triangle `t` (Möller and Trumbore, 1997): the
/// segment's parameter and the crossing's barycentric coordinates all within `[0, 1]`. A
/// segment in the triangle's plane does not cross it.
pub fn segment_crosses_triangle(p: [f64; 3], q: [f64; 3], t: &[[f64; 3]; 3]) -> bool {
    let d = sub(q, p);
    let (e1, e2) = (sub(t[1], t[0]), sub(t[2], t[0]));
    let h = cross(d, e2);
    let det = dot(e1, h);
    let scale = norm(e1) * norm(e2) * norm(d);
    if det.is_nan() || det.abs() <= 1e-12 * scale {
        return false;
    }
    let inv = 1.0 / det;
    let s = sub(p, t[0]);
    let u = inv * dot(s, h);
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let qv = cross(s, e1);
    let v = inv * dot(d, qv);
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let along = inv * dot(e2, qv);
    (0.0..=1.0).contains(&along)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_through_the_middle_of_a_sweep_crosses_it_and_one_beside_it_does_not_works() {
        // The edge from (0,0,0) to (0,1,0) swept to x = 1: the unit square in z = 0.
        let sweep = Sweep {
            from: Blade { tip: [0.0, 0.0, 0.0], back: [0.0, 1.0, 0.0] },
            to: Blade { tip: [1.0, 0.0, 0.0], back: [1.0, 1.0, 0.0] },
        };
        assert!((sweep.area() - 1.0).abs() < 1e-12);
        assert!(sweep.crosses([0.3, 0.7, -1.0], [0.3, 0.7, 1.0]));
        assert!(sweep.crosses([0.9, 0.1, 0.5], [0.9, 0.1, -0.5]));
        assert!(!sweep.crosses([1.1, 0.5, -1.0], [1.1, 0.5, 1.0])); // beside it
        assert!(!sweep.crosses([0.5, 0.5, 0.1], [0.5, 0.5, 1.0])); // short of it
        assert!(!sweep.crosses([-1.0, 0.5, 0.0], [2.0, 0.5, 0.0])); // in its plane
    }

    #[test]
    fn a_blade_pushed_along_its_edge_sweeps_nothing_works() {
        let from = Blade { tip: [0.0, 0.0, 0.0], back: [0.0, 0.01, 0.0] };
        let to = Blade { tip: [0.0, -0.002, 0.0], back: [0.0, 0.008, 0.0] };
        let sweep = Sweep { from, to };
        assert!(sweep.area() < MIN_SWEPT_AREA_M2);
        assert!(!sweep.crosses([-0.01, 0.0, 0.0], [0.01, 0.0, 0.0]));
    }
}
