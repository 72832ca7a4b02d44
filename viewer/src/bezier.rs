//! Bi-quartic Bernstein-Bézier patches over a regular surface grid: the paper's adaptive
//! re-patching of the skin (Eqs. 2-4 of its section "Visualization").
//!
//! # How a patch is built
//! The mass-spring model gives one position per grid point; the paper replaces every grid cell
//! by one bi-quartic patch `S(u/n, v/m) = Σ_i Σ_j B_i^4(u/n) B_j^4(v/m) P_ij` (Eq. 2) but does
//! not say where the 5 × 5 control points `P_ij` come from. We take them from the cell's 4 × 4
//! neighbourhood of grid points: in each direction the uniform Catmull-Rom segment through the
//! two middle points is written as a cubic Bézier curve and degree-elevated to a quartic
//! (exactly the same curve), and the two directions are combined as a tensor product. So the
//! surface
//! - passes through every simulated node (what the tool touches is where the skin is drawn),
//! - is C¹ across cells, so the normals are continuous and the skin shows no facets,
//! - reproduces planes exactly (Catmull-Rom reproduces linear functions).
//!
//! Where the grid ends (not wrapping) the missing neighbour is extrapolated linearly,
//! `p[-1] = 2 p[0] - p[1]`. A grid may wrap in the column direction (a cylinder).
//!
//! # Subdivision counts (Eqs. 3-4)
//! Corners of a cell are numbered `N0 = (u0, v0)`, `N1 = (u0, v1)`, `N2 = (u1, v0)`,
//! `N3 = (u1, v1)` (`u` along columns, `v` along rows), so `N0·N1` and `N2·N3` compare normals
//! along `V` and give `m`, the subdivisions along `V`; `N0·N2` and `N1·N3` give `n` along `U`:
//! `m = ⌊max(acos N0·N1, acos N2·N3) / φ⌋`, `n = ⌊max(acos N0·N2, acos N1·N3) / φ⌋`,
//! `φ = π/18`, each clamped to `1..=`[`MAX_SUBDIVISIONS`].
//!
//! # Examples
//!
//! ```
//! use glam::Vec3;
//! use lamina_viewer::bezier::{GridSurface, subdivisions};
//!
//! // A flat 3 × 3 grid: one subdivision each way, and the patch lies in the plane.
//! let points: Vec<Vec3> = (0..9).map(|k| Vec3::new((k % 3) as f32, (k / 3) as f32, 0.0)).collect();
//! let grid = GridSurface::new(3, 3, false, &points);
//! let patch = grid.patch(0, 0);
//! assert!(patch.eval(0.5, 0.5).distance(Vec3::new(0.5, 0.5, 0.0)) < 1e-6);
//! assert_eq!(subdivisions(grid.cell_corner_normals(0, 0)), (1, 1));
//! ```

use glam::Vec3;

/// Polynomial degree of the patches in each direction (the paper's `k = l = 4`).
pub const DEGREE: usize = 4;

/// The paper's angle threshold `φ = π/18` (10°): one more subdivision per `φ` of normal turn.
pub const PHI: f64 = core::f64::consts::PI / 18.0;

/// Upper bound on `n` and `m`. With `φ = π/18` a count of 18 means the normal turns by 180°
/// across one cell, which a sane grid never does; the bound keeps a crumpled (e.g. exploding)
/// cell from costing more than 18 × 18 quads.
pub const MAX_SUBDIVISIONS: u32 = 18;

/// Binomial coefficients `C(4, i)`.
const BINOMIAL4: [f32; 5] = [1.0, 4.0, 6.0, 4.0, 1.0];

/// The Bernstein basis polynomial `B_i^4(t) = C(4, i) tⁱ (1 - t)^(4-i)`.
///
/// # Panics
/// If `i > 4`.
pub fn bernstein4(i: usize, t: f32) -> f32 {
    BINOMIAL4[i] * t.powi(i as i32) * (1.0 - t).powi((DEGREE - i) as i32)
}

/// Rows of the matrix that turns 4 uniform Catmull-Rom points `p0..p3` into the 5 quartic
/// Bézier control points of the segment from `p1` to `p2` (cubic Bézier form
/// `p1, p1 + (p2 - p0)/6, p2 - (p3 - p1)/6, p2`, then degree elevation).
const CATMULL_ROM_TO_QUARTIC: [[f32; 4]; 5] = [
    [0.0, 1.0, 0.0, 0.0],
    [-1.0 / 8.0, 1.0, 1.0 / 8.0, 0.0],
    [-1.0 / 12.0, 7.0 / 12.0, 7.0 / 12.0, -1.0 / 12.0],
    [0.0, 1.0 / 8.0, 1.0, -1.0 / 8.0],
    [0.0, 0.0, 1.0, 0.0],
];

/// One bi-quartic patch: `points[i][j]` is `P_ij`, `i` along `U` (columns), `j` along `V` (rows).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Patch {
    /// The 5 × 5 control points, metres.
    pub points: [[Vec3; 5]; 5],
}

/// One de Casteljau reduction of 5 points at `t`: the curve point and its derivative.
fn de_casteljau(mut p: [Vec3; 5], t: f32) -> (Vec3, Vec3) {
    for level in (2..=DEGREE).rev() {
        for k in 0..level {
            p[k] = p[k].lerp(p[k + 1], t);
        }
    }
    // Two points left: the curve point lies between them, the derivative is 4 × their difference.
    (p[0].lerp(p[1], t), (p[1] - p[0]) * DEGREE as f32)
}

impl Patch {
    /// The surface point at parameters `(s, t) ∈ [0, 1]²` (de Casteljau, equal to Eq. 2).
    pub fn eval(&self, s: f32, t: f32) -> Vec3 {
        self.eval_with_tangents(s, t).0
    }

    /// The surface point and its tangents `∂S/∂s`, `∂S/∂t` at `(s, t)`.
    pub fn eval_with_tangents(&self, s: f32, t: f32) -> (Vec3, Vec3, Vec3) {
        let mut along_v = [Vec3::ZERO; 5];
        let mut along_v_ds = [Vec3::ZERO; 5];
        for j in 0..5 {
            let column =
                [self.points[0][j], self.points[1][j], self.points[2][j], self.points[3][j], self.points[4][j]];
            (along_v[j], along_v_ds[j]) = de_casteljau(column, s);
        }
        let (point, dt) = de_casteljau(along_v, t);
        let (ds, _) = de_casteljau(along_v_ds, t);
        (point, ds, dt)
    }

    /// Eq. 2: the point `S(u/n, v/m)` for integer steps `u ∈ 0..=n`, `v ∈ 0..=m`.
    pub fn sample(&self, u: u32, n: u32, v: u32, m: u32) -> Vec3 {
        self.eval(u as f32 / n.max(1) as f32, v as f32 / m.max(1) as f32)
    }

    /// The unit normal `∂S/∂s × ∂S/∂t` at `(s, t)`, or `fallback` where the tangents are
    /// parallel or zero (a collapsed cell).
    pub fn normal(&self, s: f32, t: f32, fallback: Vec3) -> Vec3 {
        let (_, ds, dt) = self.eval_with_tangents(s, t);
        ds.cross(dt).try_normalize().unwrap_or(fallback)
    }
}

/// Angle between two directions, radians, in `f64` (normalised first; `0` for a zero vector).
fn angle(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3().normalize_or_zero(), b.as_dvec3().normalize_or_zero());
    a.dot(b).clamp(-1.0, 1.0).acos()
}

/// `⌊angle / φ⌋` clamped to `1..=MAX_SUBDIVISIONS`. A relative tolerance of 1e-6 makes an
/// angle of exactly `k φ` give `k` despite rounding in `acos`.
pub fn count_for_angle(angle_rad: f64, phi: f64) -> u32 {
    let steps = (angle_rad / phi * (1.0 + 1e-6)).floor();
    if steps.is_nan() { 1 } else { (steps as u32).clamp(1, MAX_SUBDIVISIONS) }
}

/// Eqs. 3-4 with the paper's `φ = π/18`: the subdivision counts `(n, m)` (along `U`, along
/// `V`) of a cell from its corner normals `[N0, N1, N2, N3]` (numbering in the
/// [module docs](self)).
pub fn subdivisions(normals: [Vec3; 4]) -> (u32, u32) {
    subdivisions_with_phi(normals, PHI)
}

/// Eqs. 3-4 with another threshold `phi` (radians, > 0): smaller gives finer meshes.
pub fn subdivisions_with_phi(normals: [Vec3; 4], phi: f64) -> (u32, u32) {
    let [n0, n1, n2, n3] = normals;
    let m = count_for_angle(angle(n0, n1).max(angle(n2, n3)), phi);
    let n = count_for_angle(angle(n0, n2).max(angle(n1, n3)), phi);
    (n, m)
}

/// How a grid's cells are laid out: cells per row and column, and whether columns wrap.
/// Patches of such a grid are stored row-major by cell (`patches[row * cols + col]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellLayout {
    /// Cells in the column direction.
    pub cols: usize,
    /// Cells in the row direction.
    pub rows: usize,
    /// Whether the last cell column joins the first.
    pub wrap: bool,
}

/// A regular grid of surface points: `cols × rows`, row-major (`points[row * cols + col]`),
/// optionally wrapping in the column direction (a closed tube).
#[derive(Debug, Clone, Copy)]
pub struct GridSurface<'a> {
    cols: usize,
    rows: usize,
    wrap: bool,
    points: &'a [Vec3],
}

impl<'a> GridSurface<'a> {
    /// A view of `points` as a grid.
    ///
    /// # Panics
    /// If `points.len() != cols * rows`, or the grid has fewer than 2 points in a direction
    /// (3 columns when wrapping).
    pub fn new(cols: usize, rows: usize, wrap: bool, points: &'a [Vec3]) -> Self {
        assert_eq!(points.len(), cols * rows, "grid point count");
        assert!(rows >= 2 && cols >= if wrap { 3 } else { 2 }, "grid too small");
        Self { cols, rows, wrap, points }
    }

    /// Grid points per row.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Grid points per column.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Whether column `cols - 1` connects back to column 0.
    pub fn wraps(&self) -> bool {
        self.wrap
    }

    /// Cells in the column direction (`cols` when wrapping, else `cols - 1`).
    pub fn cell_cols(&self) -> usize {
        if self.wrap { self.cols } else { self.cols - 1 }
    }

    /// Cells in the row direction.
    pub fn cell_rows(&self) -> usize {
        self.rows - 1
    }

    /// The cell layout (for code that only walks the patches).
    pub fn layout(&self) -> CellLayout {
        CellLayout { cols: self.cell_cols(), rows: self.cell_rows(), wrap: self.wrap }
    }

    /// Grid point `(col, row)`; wraps columns on a tube, and one step beyond an open edge is
    /// extrapolated linearly.
    pub fn point(&self, col: isize, row: isize) -> Vec3 {
        let (cols, rows) = (self.cols as isize, self.rows as isize);
        let col = if self.wrap { col.rem_euclid(cols) } else { col };
        // Beyond an edge by k steps: edge + k · (edge - inner neighbour). Rows first, so a
        // corner beyond both edges extrapolates the already extrapolated column.
        if row < 0 {
            let (edge, inner) = (self.point(col, 0), self.point(col, 1));
            return edge + (edge - inner) * (-row) as f32;
        }
        if row >= rows {
            let (edge, inner) = (self.point(col, rows - 1), self.point(col, rows - 2));
            return edge + (edge - inner) * (row - rows + 1) as f32;
        }
        let at = |c: isize| self.points[(row * cols + c) as usize];
        if col < 0 {
            return at(0) + (at(0) - at(1)) * (-col) as f32;
        }
        if col >= cols {
            return at(cols - 1) + (at(cols - 1) - at(cols - 2)) * (col - cols + 1) as f32;
        }
        at(col)
    }

    /// The normal at grid point `(col, row)` from central differences (the Catmull-Rom
    /// surface's own normal there), unit length; `+Z` if degenerate.
    pub fn point_normal(&self, col: isize, row: isize) -> Vec3 {
        let du = self.point(col + 1, row) - self.point(col - 1, row);
        let dv = self.point(col, row + 1) - self.point(col, row - 1);
        du.cross(dv).try_normalize().unwrap_or(Vec3::Z)
    }

    /// The corner normals `[N0, N1, N2, N3]` of cell `(col, row)` for [`subdivisions`].
    pub fn cell_corner_normals(&self, col: usize, row: usize) -> [Vec3; 4] {
        let (c, r) = (col as isize, row as isize);
        [
            self.point_normal(c, r),
            self.point_normal(c, r + 1),
            self.point_normal(c + 1, r),
            self.point_normal(c + 1, r + 1),
        ]
    }

    /// The bi-quartic patch of cell `(col, row)` (spanning grid points `col..=col+1`,
    /// `row..=row+1`), built from its 4 × 4 neighbourhood as described in the module docs.
    pub fn patch(&self, col: usize, row: usize) -> Patch {
        let (c, r) = (col as isize, row as isize);
        let mut g = [[Vec3::ZERO; 4]; 4];
        for (a, ga) in g.iter_mut().enumerate() {
            for (b, gab) in ga.iter_mut().enumerate() {
                *gab = self.point(c - 1 + a as isize, r - 1 + b as isize);
            }
        }
        // Rows first (along U), then along V: both are linear maps, so the order is free.
        let mut half = [[Vec3::ZERO; 4]; 5];
        for (i, weights) in CATMULL_ROM_TO_QUARTIC.iter().enumerate() {
            for b in 0..4 {
                half[i][b] = (0..4).map(|a| g[a][b] * weights[a]).sum();
            }
        }
        let mut points = [[Vec3::ZERO; 5]; 5];
        for (i, row) in points.iter_mut().enumerate() {
            for (j, weights) in CATMULL_ROM_TO_QUARTIC.iter().enumerate() {
                row[j] = (0..4).map(|b| half[i][b] * weights[b]).sum();
            }
        }
        Patch { points }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 2 written out: Σ_i Σ_j B_i^4(u/n) B_j^4(v/m) P_ij.
    fn eq2(patch: &Patch, u: u32, n: u32, v: u32, m: u32) -> Vec3 {
        let (s, t) = (u as f32 / n as f32, v as f32 / m as f32);
        let mut sum = Vec3::ZERO;
        for i in 0..=DEGREE {
            for j in 0..=DEGREE {
                sum += bernstein4(i, s) * bernstein4(j, t) * patch.points[i][j];
            }
        }
        sum
    }

    /// A deterministic, non-planar patch.
    fn bumpy_patch() -> Patch {
        let mut points = [[Vec3::ZERO; 5]; 5];
        for (i, row) in points.iter_mut().enumerate() {
            for (j, p) in row.iter_mut().enumerate() {
                let k = (i * 5 + j) as f32;
                *p = Vec3::new(i as f32 + 0.1 * (k * 1.3).sin(), j as f32 + 0.2 * (k * 0.7).cos(), (k * 0.9).sin());
            }
        }
        Patch { points }
    }

    /// Rotates +Z about the X axis by `deg` (a normal tilting in the Y-Z plane).
    fn tilted_about_x(deg: f32) -> Vec3 {
        let a = deg.to_radians();
        Vec3::new(0.0, -a.sin(), a.cos())
    }

    /// Rotates +Z about the Y axis by `deg`.
    fn tilted_about_y(deg: f32) -> Vec3 {
        let a = deg.to_radians();
        Vec3::new(a.sin(), 0.0, a.cos())
    }

    #[test]
    fn patch_sample_matches_eq2_works() {
        let patch = bumpy_patch();
        for (n, m) in [(1, 1), (3, 5), (7, 2), (18, 18)] {
            for u in 0..=n {
                for v in 0..=m {
                    let (a, b) = (patch.sample(u, n, v, m), eq2(&patch, u, n, v, m));
                    assert!(a.distance(b) < 1e-5, "({u}/{n}, {v}/{m}): {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn bernstein_partition_of_unity_works() {
        for k in 0..=10 {
            let t = k as f32 / 10.0;
            let sum: f32 = (0..=DEGREE).map(|i| bernstein4(i, t)).sum();
            assert!((sum - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn patch_tangents_match_finite_differences_works() {
        let patch = bumpy_patch();
        let h = 1e-3;
        for (s, t) in [(0.2, 0.3), (0.5, 0.5), (0.9, 0.1)] {
            let (_, ds, dt) = patch.eval_with_tangents(s, t);
            let fd_s = (patch.eval(s + h, t) - patch.eval(s - h, t)) / (2.0 * h);
            let fd_t = (patch.eval(s, t + h) - patch.eval(s, t - h)) / (2.0 * h);
            assert!(ds.distance(fd_s) < 2e-2 * ds.length().max(1.0), "{ds} vs {fd_s}");
            assert!(dt.distance(fd_t) < 2e-2 * dt.length().max(1.0), "{dt} vs {fd_t}");
        }
    }

    #[test]
    fn flat_grid_reproduces_plane_works() {
        // An affine grid on a tilted plane: p(c, r) = o + c a + r b.
        let (o, a, b) = (Vec3::new(0.3, -0.2, 1.0), Vec3::new(0.01, 0.0, 0.004), Vec3::new(0.0, 0.012, -0.003));
        let (cols, rows) = (5, 4);
        let points: Vec<Vec3> =
            (0..rows).flat_map(|r| (0..cols).map(move |c| o + a * c as f32 + b * r as f32)).collect();
        let grid = GridSurface::new(cols, rows, false, &points);
        let normal = a.cross(b).normalize();
        for r in 0..grid.cell_rows() {
            for c in 0..grid.cell_cols() {
                let patch = grid.patch(c, r);
                for (s, t) in [(0.0, 0.0), (0.25, 0.75), (0.5, 0.5), (1.0, 0.3)] {
                    let expected = o + a * (c as f32 + s) + b * (r as f32 + t);
                    assert!(patch.eval(s, t).distance(expected) < 1e-6, "cell ({c}, {r}) at ({s}, {t})");
                    assert!(patch.normal(s, t, Vec3::Z).cross(normal).length() < 1e-4);
                }
                assert_eq!(subdivisions(grid.cell_corner_normals(c, r)), (1, 1));
            }
        }
    }

    #[test]
    fn patch_interpolates_grid_points_works() {
        let limb = crate::synthetic::SyntheticLimb::default();
        let frame = limb.frame(0, 0.4);
        let model = limb.view_model();
        let g = &model.grids[0];
        let points: Vec<Vec3> = g.nodes.iter().map(|&i| frame.positions[i as usize]).collect();
        let grid = GridSurface::new(g.cols, g.rows, g.wrap, &points);
        for r in 0..grid.cell_rows() {
            for c in 0..grid.cell_cols() {
                let patch = grid.patch(c, r);
                let (c1, r1) = (c as isize + 1, r as isize + 1);
                assert!(patch.eval(0.0, 0.0).distance(grid.point(c as isize, r as isize)) < 1e-6);
                assert!(patch.eval(1.0, 1.0).distance(grid.point(c1, r1)) < 1e-6);
            }
        }
    }

    #[test]
    fn neighbouring_patches_join_with_matching_tangents_works() {
        let limb = crate::synthetic::SyntheticLimb::default();
        let frame = limb.frame(0, 1.3);
        let model = limb.view_model();
        let g = &model.grids[0];
        let points: Vec<Vec3> = g.nodes.iter().map(|&i| frame.positions[i as usize]).collect();
        let grid = GridSurface::new(g.cols, g.rows, g.wrap, &points);
        // Across the seam of the tube (last column to column 0) and across an inner edge.
        for (left, right) in [(grid.cell_cols() - 1, 0), (3, 4)] {
            for t in [0.0, 0.3, 0.8] {
                let (pl, dsl, _) = grid.patch(left, 5).eval_with_tangents(1.0, t);
                let (pr, dsr, _) = grid.patch(right, 5).eval_with_tangents(0.0, t);
                assert!(pl.distance(pr) < 1e-6, "C0 at t = {t}");
                assert!(dsl.distance(dsr) < 1e-5, "C1 at t = {t}: {dsl} vs {dsr}");
            }
        }
    }

    #[test]
    fn subdivisions_on_known_normals_works() {
        let z = Vec3::Z;
        // 0°: one subdivision each way (⌊0⌋ clamped to 1).
        assert_eq!(subdivisions([z, z, z, z]), (1, 1));
        // 25° between the corners along U (N0→N2, N1→N3): n = ⌊25/10⌋ = 2, m = 1.
        let u25 = tilted_about_y(25.0);
        assert_eq!(subdivisions([z, z, u25, u25]), (2, 1));
        // 90° along V (N0→N1, N2→N3): m = 9, n = 1.
        let v90 = Vec3::new(0.0, -1.0, 0.0);
        assert_eq!(subdivisions([z, v90, z, v90]), (1, 9));
        // The larger of the two pairs decides: 25° on one V edge, 90° on the other.
        assert_eq!(subdivisions([z, tilted_about_x(25.0), z, v90]).1, 9);
        // Just under and over the threshold.
        assert_eq!(subdivisions([z, tilted_about_x(9.5), z, z]), (1, 1));
        let t = tilted_about_x(20.5);
        assert_eq!(subdivisions([z, t, z, t]), (1, 2));
        // Opposite normals are clamped to the documented maximum.
        assert_eq!(subdivisions([z, -z, z, -z]), (1, MAX_SUBDIVISIONS));
    }

    #[test]
    fn subdivisions_on_cylinder_works() {
        // 16 columns around a cylinder: 22.5° between neighbouring normals → n = 2; straight
        // along the axis → m = 1.
        let points: Vec<Vec3> = (0..4)
            .flat_map(|r| {
                (0..16).map(move |c| {
                    let a = core::f32::consts::TAU * c as f32 / 16.0;
                    Vec3::new(r as f32 * 0.02, a.cos() * 0.04, a.sin() * 0.04)
                })
            })
            .collect();
        let grid = GridSurface::new(16, 4, true, &points);
        for c in 0..grid.cell_cols() {
            assert_eq!(subdivisions(grid.cell_corner_normals(c, 1)), (2, 1), "cell {c}");
        }
    }

    #[test]
    fn point_extrapolates_beyond_open_edges_works() {
        let points: Vec<Vec3> = (0..6).map(|k| Vec3::new((k % 3) as f32, (k / 3) as f32 * 2.0, 0.0)).collect();
        let grid = GridSurface::new(3, 2, false, &points);
        assert_eq!(grid.point(-1, 0), Vec3::new(-1.0, 0.0, 0.0));
        assert_eq!(grid.point(3, 1), Vec3::new(3.0, 2.0, 0.0));
        assert_eq!(grid.point(0, -1), Vec3::new(0.0, -2.0, 0.0));
        assert_eq!(grid.point(-1, 2), Vec3::new(-1.0, 4.0, 0.0));
    }
}
