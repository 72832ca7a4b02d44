//! A built-in animated limb segment, so the viewer runs (and is tested) without a core.
//!
//! Four tissue boundaries sampled on the same `columns × rows` grid around an axis along `x`
//! (outer skin, skin/fat, fat/muscle, muscle/bone), slightly elliptical and tapering like a
//! forearm, with the bone off-centre. Springs follow the generator's pattern in spirit: grid
//! edges and diagonals on every boundary, radial and crossed springs between boundaries.
//! The animation is a spherical tool pressing into the top of the skin with a depth that
//! breathes over time; the indentation fades with depth (bone does not move).
//!
//! # Examples
//!
//! ```
//! use lamina_viewer::synthetic::SyntheticLimb;
//!
//! let limb = SyntheticLimb::default();
//! let model = limb.view_model();
//! let frame = limb.frame(0, 0.0);
//! assert_eq!(frame.positions.len(), model.node_count);
//! assert!(model.is_consistent());
//! ```

use core::f32::consts::TAU;

use glam::Vec3;

use crate::view_model::{BoundaryGrid, Frame, Tissue, ToolPose, ViewModel};

/// Shape and motion of the synthetic limb. Lengths in metres, times in seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticLimb {
    /// Grid columns around the limb. Default 16.
    pub columns: usize,
    /// Grid rows along the limb. Default 25 (1 cm apart).
    pub rows: usize,
    /// Length along `x`, m. Default 0.24.
    pub length: f32,
    /// Radii of the four boundaries at the thick end, outermost first, m.
    /// Default 40, 36.5, 29, 13 mm (skin 3.5 mm, fat 7.5 mm).
    pub radii: [f32; 4],
    /// Relative radius lost from the thick (`-x`) to the thin (`+x`) end. Default 0.15.
    pub taper: f32,
    /// Ellipticity: radius × (1 - e·cos 2θ), θ from +y: flatter top to bottom. Default 0.08.
    pub ellipticity: f32,
    /// Bone axis offset from the limb axis (y, z), m. Default (-4 mm, 2 mm).
    pub bone_offset: [f32; 2],
    /// Tool tip radius, m. Default 7 mm.
    pub tool_radius: f32,
    /// Mean indentation depth, m. Default 9 mm.
    pub indent_depth: f32,
    /// Width (Gaussian σ) of the indentation on the skin, m. Default 12 mm.
    pub indent_width: f32,
    /// Frequency of the pressing motion, Hz. Default 0.5.
    pub press_hz: f32,
}

impl Default for SyntheticLimb {
    fn default() -> Self {
        Self {
            columns: 16,
            rows: 25,
            length: 0.24,
            radii: [0.040, 0.0365, 0.029, 0.013],
            taper: 0.15,
            ellipticity: 0.08,
            bone_offset: [-0.004, 0.002],
            tool_radius: 0.007,
            indent_depth: 0.009,
            indent_width: 0.012,
            press_hz: 0.5,
        }
    }
}

/// How much of the indentation each boundary follows, outermost first.
const INDENT_FOLLOW: [f32; 4] = [1.0, 0.85, 0.4, 0.0];

impl SyntheticLimb {
    fn boundary_count(&self) -> usize {
        self.radii.len()
    }

    /// Node index of grid point `(col, row)` on boundary `k`.
    pub fn node(&self, k: usize, col: usize, row: usize) -> u32 {
        (k * self.columns * self.rows + row * self.columns + col % self.columns) as u32
    }

    /// The static model: four wrapping boundary grids and the spring network.
    pub fn view_model(&self) -> ViewModel {
        let names = ["skin_outer", "skin_fat", "fat_muscle", "muscle_bone"];
        let (w, h) = (self.columns, self.rows);
        let mut model = ViewModel {
            name: "synthetic limb".into(),
            node_count: self.boundary_count() * w * h,
            ..ViewModel::default()
        };
        for (k, name) in names.iter().enumerate() {
            model.grids.push(BoundaryGrid {
                name: (*name).into(),
                cols: w,
                rows: h,
                wrap: true,
                nodes: (0..h).flat_map(|r| (0..w).map(move |c| (r, c))).map(|(r, c)| self.node(k, c, r)).collect(),
                beneath: Tissue::beneath_boundary(name),
            });
        }
        let mut push = |a: u32, b: u32, t: Tissue| {
            model.springs.push([a, b]);
            model.spring_tissue.push(t);
        };
        for k in 0..self.boundary_count() {
            let on_surface = if k == 0 { Tissue::Skin } else { Tissue::beneath_boundary(names[k]) };
            for r in 0..h {
                for c in 0..w {
                    push(self.node(k, c, r), self.node(k, c + 1, r), on_surface);
                    if r + 1 < h {
                        push(self.node(k, c, r), self.node(k, c, r + 1), on_surface);
                        push(self.node(k, c, r), self.node(k, c + 1, r + 1), on_surface);
                    }
                    if k + 1 < self.boundary_count() {
                        let between = Tissue::beneath_boundary(names[k]);
                        push(self.node(k, c, r), self.node(k + 1, c, r), between);
                        push(self.node(k, c, r), self.node(k + 1, c + 1, r), between);
                        if r + 1 < h {
                            push(self.node(k, c, r), self.node(k + 1, c, r + 1), between);
                        }
                    }
                }
            }
        }
        model
    }

    /// Rest position of grid point `(col, row)` on boundary `k`, and the outward unit radial.
    fn rest(&self, k: usize, col: usize, row: usize) -> (Vec3, Vec3) {
        let along = row as f32 / (self.rows - 1) as f32;
        let x = (along - 0.5) * self.length;
        let theta = TAU * col as f32 / self.columns as f32;
        let radial = Vec3::new(0.0, theta.cos(), theta.sin());
        let scale = (1.0 - self.taper * along) * (1.0 - self.ellipticity * (2.0 * theta).cos());
        // Deeper boundaries drift toward the bone axis, so the muscle is thick where the bone is far.
        let depth = k as f32 / (self.boundary_count() - 1) as f32;
        let centre = Vec3::new(x, self.bone_offset[0] * depth, self.bone_offset[1] * depth);
        let r = self.radii[k] * if k + 1 == self.boundary_count() { 1.0 - 0.5 * self.taper * along } else { scale };
        (centre + radial * r, radial)
    }

    /// Tool contact point on the rest skin and the pressing depth at time `t`.
    fn press(&self, t: f32) -> (Vec3, f32) {
        let x = -0.015 + 0.02 * (0.13 * TAU * t).sin();
        let depth = self.indent_depth * (1.0 + 0.3 * (self.press_hz * TAU * t).sin());
        (Vec3::new(x, 0.0, 0.0), depth)
    }

    /// The frame at simulated time `t` seconds, numbered `sequence`.
    pub fn frame(&self, sequence: u64, t: f64) -> Frame {
        let (contact_x, depth) = self.press(t as f32);
        let top_theta = 0.0; // column 0 faces +y: the tool presses from above
        let (w, h) = (self.columns, self.rows);
        let mut positions = Vec::with_capacity(self.boundary_count() * w * h);
        let sigma2 = 2.0 * self.indent_width * self.indent_width;
        for (k, follow) in INDENT_FOLLOW.iter().enumerate() {
            for r in 0..h {
                for c in 0..w {
                    let (p, radial) = self.rest(k, c, r);
                    // Distance on the skin from the contact point (arc around, straight along).
                    let theta = TAU * c as f32 / w as f32;
                    let dtheta = ((theta - top_theta + TAU * 1.5) % TAU) - TAU * 0.5;
                    let arc = dtheta * self.radii[0];
                    let dx = p.x - contact_x.x;
                    let weight = (-(arc * arc + dx * dx) / sigma2).exp();
                    // Pushed straight down (-y), mostly, as a probe would.
                    let push = Vec3::new(0.0, -1.0, 0.0).lerp(-radial, 0.3).normalize();
                    positions.push(p + push * depth * weight * follow);
                }
            }
        }
        // Skin surface height under the tool at the contact column, after indentation.
        let thick_end = 0.5 - contact_x.x / self.length;
        let along = 1.0 - thick_end;
        let skin_top = self.radii[0] * (1.0 - self.taper * along) * (1.0 - self.ellipticity);
        let center = Vec3::new(contact_x.x, skin_top - depth + self.tool_radius, 0.0);
        Frame {
            sequence,
            sim_time_s: t,
            publish_time_ns: 0,
            positions,
            tool: Some(ToolPose { center, radius: self.tool_radius }),
            stats: None,
        }
    }
}
