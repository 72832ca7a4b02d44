//! The limb's axis: a polyline, parameterised by normalised arc length, with a frame that
//! turns as little as possible along it.

use super::vec3::{add, cross, dot, norm, normalize, scale, sub};

/// A polyline along the limb's axis (m). Rays of the generator are cast toward it.
#[derive(Clone, Debug, PartialEq)]
pub struct Centreline {
    points: Vec<[f64; 3]>,
    /// Cumulative arc length at each point, m.
    arc: Vec<f64>,
}

/// A right-handed orthonormal frame on the centreline: `normal × binormal = tangent`.
/// Angle 0 around the axis points along `normal`, angle π/2 along `binormal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisFrame {
    /// Point on the centreline, m.
    pub origin: [f64; 3],
    /// Unit tangent (direction of increasing arc length).
    pub tangent: [f64; 3],
    /// Unit normal.
    pub normal: [f64; 3],
    /// Unit binormal, `tangent × normal`.
    pub binormal: [f64; 3],
}

impl AxisFrame {
    /// Unit direction at angle `theta` (rad) around the tangent, counter-clockwise seen from
    /// the tangent's tip.
    pub fn direction(&self, theta: f64) -> [f64; 3] {
        add(scale(self.normal, theta.cos()), scale(self.binormal, theta.sin()))
    }
}

impl Centreline {
    /// A centreline through `points` (m, at least two, consecutive points distinct, all
    /// finite); `None` otherwise.
    pub fn new(points: Vec<[f64; 3]>) -> Option<Self> {
        if points.len() < 2 || points.iter().flatten().any(|c| !c.is_finite()) {
            return None;
        }
        let mut arc = vec![0.0];
        for w in points.windows(2) {
            let l = norm(sub(w[1], w[0]));
            if l <= 0.0 {
                return None;
            }
            arc.push(arc.last().copied().unwrap_or(0.0) + l);
        }
        Some(Self { points, arc })
    }

    /// The polyline's points, m.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Total length, m.
    pub fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }

    /// Segment index and local parameter in `[0, 1]` at normalised arc length `s`.
    fn locate(&self, s: f64) -> (usize, f64) {
        let target = s.clamp(0.0, 1.0) * self.length();
        let seg = self.arc.partition_point(|&a| a <= target).clamp(1, self.points.len() - 1) - 1;
        let l = self.arc[seg + 1] - self.arc[seg];
        (seg, ((target - self.arc[seg]) / l).clamp(0.0, 1.0))
    }

    /// The point at normalised arc length `s ∈ [0, 1]` (clamped), m.
    pub fn point_at(&self, s: f64) -> [f64; 3] {
        let (seg, t) = self.locate(s);
        let (a, b) = (self.points[seg], self.points[seg + 1]);
        add(a, scale(sub(b, a), t))
    }

    /// Unit tangent at `s`: the segment's direction, or at an inner vertex the mean of the
    /// two segments meeting there.
    pub fn tangent_at(&self, s: f64) -> [f64; 3] {
        let (seg, t) = self.locate(s);
        let dir = |i: usize| normalize(sub(self.points[i + 1], self.points[i])).unwrap_or([0.0, 0.0, 1.0]);
        let here = dir(seg);
        let mixed = if t == 0.0 && seg > 0 {
            add(here, dir(seg - 1))
        } else if t == 1.0 && seg + 2 < self.points.len() {
            add(here, dir(seg + 1))
        } else {
            here
        };
        normalize(mixed).unwrap_or(here)
    }

    /// Frames at increasing normalised arc lengths `params`. The first normal is the
    /// coordinate axis least aligned with the first tangent, made orthogonal to it; each
    /// next normal is the previous one projected onto the next normal plane (discrete
    /// parallel transport), so the frame does not twist about the axis. For a straight
    /// centreline along +z the normal is +x and the binormal +y.
    pub fn frames(&self, params: &[f64]) -> Vec<AxisFrame> {
        let mut frames = Vec::with_capacity(params.len());
        let mut previous: Option<[f64; 3]> = None;
        for &s in params {
            let tangent = self.tangent_at(s);
            let seed = previous.unwrap_or_else(|| {
                // The least aligned axis, preferring x, then y, on near ties (within 1e-9), so
                // that round-off in a measured axis does not turn the frame by 90 degrees.
                let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                let least = axes.iter().map(|a| dot(*a, tangent).abs()).fold(f64::INFINITY, f64::min);
                *axes.iter().find(|a| dot(**a, tangent).abs() <= least + 1e-9).unwrap_or(&axes[0])
            });
            let projected = sub(seed, scale(tangent, dot(seed, tangent)));
            let normal = normalize(projected).unwrap_or_else(|| {
                // The axis turned by a right angle: fall back to any perpendicular.
                let other = if tangent[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
                normalize(cross(tangent, other)).unwrap_or([1.0, 0.0, 0.0])
            });
            let binormal = cross(tangent, normal);
            frames.push(AxisFrame { origin: self.point_at(s), tangent, normal, binormal });
            previous = Some(normal);
        }
        frames
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centreline_straight_frames_works() {
        let c = Centreline::new(vec![[0.0; 3], [0.0, 0.0, 0.3]]).unwrap();
        let f = c.frames(&[0.0, 0.5, 1.0]);
        assert_eq!(f[1].origin, [0.0, 0.0, 0.15]);
        for fr in &f {
            assert_eq!(fr.normal, [1.0, 0.0, 0.0]);
            assert_eq!(fr.binormal, [0.0, 1.0, 0.0]);
        }
    }

    #[test]
    fn centreline_bent_point_at_works() {
        let c = Centreline::new(vec![[0.0; 3], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]).unwrap();
        assert_eq!(c.length(), 2.0);
        assert_eq!(c.point_at(0.75), [1.0, 0.5, 0.0]);
        let t = c.tangent_at(0.5);
        assert!((t[0] - t[1]).abs() < 1e-15 && t[2] == 0.0);
    }

    #[test]
    fn centreline_repeated_point_fails() {
        assert!(Centreline::new(vec![[0.0; 3], [0.0; 3]]).is_none());
        assert!(Centreline::new(vec![[0.0; 3]]).is_none());
    }
}
