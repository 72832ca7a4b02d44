//! The cross-section: a plane that removes one side of the model, and the cut faces that show
//! skin, fat, muscle and bone where it passes.
//!
//! How the cut faces are found: each tissue boundary is a grid whose rows run along the limb,
//! so every column of the patch network (sampled at a fixed number of points per cell) crosses
//! a transverse plane once. Sampling all boundaries at the same column parameters gives loops
//! with matching points; the band between the loops of boundary `k` and `k + 1` is filled with
//! the tissue beneath boundary `k`, and the innermost loop is filled with bone (an ivory
//! cortex around a marrow core). The same filling closes the two ends of a limb segment.
//!
//! Limitation (documented, not hidden): a plane nearly parallel to the rows, or a boundary that
//! folds back across the plane, gives columns without a crossing; those bands are left open.

use glam::Vec3;

use crate::bezier::{CellLayout, Patch};
use crate::material::Material;
use crate::scene_mesh::{LitVertex, SceneMesh};
use crate::view_model::{Tissue, TissueSet};

/// A cutting plane: points with `normal · p > offset` are removed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutPlane {
    /// Unit normal, pointing into the removed half-space.
    pub normal: Vec3,
    /// Plane offset along the normal, metres.
    pub offset: f32,
}

impl CutPlane {
    /// The plane through `point` with (normalised) `normal` pointing into the removed side.
    pub fn through(point: Vec3, normal: Vec3) -> Self {
        let normal = normal.normalize();
        Self { normal, offset: normal.dot(point) }
    }

    /// Signed distance of `p`: positive on the removed side, metres.
    pub fn distance(&self, p: Vec3) -> f32 {
        self.normal.dot(p) - self.offset
    }

    /// The part of segment `a`–`b` on the removed side, if any.
    pub fn removed_part(&self, a: Vec3, b: Vec3) -> Option<(Vec3, Vec3)> {
        let (da, db) = (self.distance(a), self.distance(b));
        match (da > 0.0, db > 0.0) {
            (true, true) => Some((a, b)),
            (false, false) => None,
            _ => {
                let x = a.lerp(b, da / (da - db));
                Some(if da > 0.0 { (a, x) } else { (x, b) })
            }
        }
    }

    /// As `[nx, ny, nz, -offset]`, so `dot(plane, (p, 1))` is the signed distance (shader form).
    pub fn as_vec4(&self) -> [f32; 4] {
        [self.normal.x, self.normal.y, self.normal.z, -self.offset]
    }
}

/// Points of a section loop at fixed column parameters; `None` where a column has no crossing.
pub type SectionLoop = Vec<Option<Vec3>>;

/// Where boundary `grid` (with its per-cell `patches`, row-major by cell) crosses `plane`:
/// `samples_per_cell` points per cell column, each the first crossing along the column
/// (sampled `steps_per_cell` times per cell along the rows, then interpolated linearly).
pub fn section_loop(
    grid: &CellLayout,
    patches: &[Patch],
    plane: &CutPlane,
    samples_per_cell: usize,
    steps_per_cell: usize,
) -> SectionLoop {
    section_loop_with_rest(grid, patches, patches, plane, samples_per_cell, steps_per_cell).0
}

/// As [`section_loop`], and the same points on `rest_patches` (the boundary at rest, same
/// layout): each crossing's rest position is interpolated with the crossing's own patch
/// parameters and weights, so a texture fixed at rest positions follows the cut face.
pub fn section_loop_with_rest(
    grid: &CellLayout,
    patches: &[Patch],
    rest_patches: &[Patch],
    plane: &CutPlane,
    samples_per_cell: usize,
    steps_per_cell: usize,
) -> (SectionLoop, SectionLoop) {
    let (cc, cr) = (grid.cols, grid.rows);
    let mut out = Vec::with_capacity(cc * samples_per_cell + 1);
    let mut rest = Vec::with_capacity(cc * samples_per_cell + 1);
    for c in 0..cc {
        let last_sample = if c + 1 == cc && !grid.wrap { samples_per_cell } else { samples_per_cell - 1 };
        for s in 0..=last_sample {
            let u = s as f32 / samples_per_cell as f32;
            let (p, r) = column_crossing(patches, rest_patches, c, cc, cr, u, plane, steps_per_cell).unzip();
            out.push(p);
            rest.push(r);
        }
    }
    (out, rest)
}

#[allow(clippy::too_many_arguments)]
fn column_crossing(
    patches: &[Patch],
    rest_patches: &[Patch],
    c: usize,
    cc: usize,
    cr: usize,
    u: f32,
    plane: &CutPlane,
    steps: usize,
) -> Option<(Vec3, Vec3)> {
    let (mut prev_patch, mut prev_v) = (c, 0.0);
    let mut prev = patches[c].eval(u, 0.0);
    let mut prev_d = plane.distance(prev);
    for r in 0..cr {
        let k_patch = r * cc + c;
        let patch = &patches[k_patch];
        for k in 1..=steps {
            let v = k as f32 / steps as f32;
            let p = patch.eval(u, v);
            let d = plane.distance(p);
            if (prev_d <= 0.0) != (d <= 0.0) {
                let w = prev_d / (prev_d - d);
                let rest = match (rest_patches.get(prev_patch), rest_patches.get(k_patch)) {
                    (Some(a), Some(b)) => a.eval(u, prev_v).lerp(b.eval(u, v), w),
                    _ => prev.lerp(p, w),
                };
                return Some((prev.lerp(p, w), rest));
            }
            (prev, prev_d, prev_patch, prev_v) = (p, d, k_patch, v);
        }
    }
    None
}

/// Which end of a limb segment (grid row 0 or the last row).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// Grid row 0.
    First,
    /// The last grid row.
    Last,
}

/// The loop of boundary `grid` at one end, sampled like [`section_loop`].
pub fn end_loop(grid: &CellLayout, patches: &[Patch], end: End, samples_per_cell: usize) -> SectionLoop {
    let (cc, cr) = (grid.cols, grid.rows);
    let (row, v) = match end {
        End::First => (0, 0.0),
        End::Last => (cr - 1, 1.0),
    };
    let mut out = Vec::with_capacity(cc * samples_per_cell + 1);
    for c in 0..cc {
        let last_sample = if c + 1 == cc && !grid.wrap { samples_per_cell } else { samples_per_cell - 1 };
        for s in 0..=last_sample {
            out.push(Some(patches[row * cc + c].eval(s as f32 / samples_per_cell as f32, v)));
        }
    }
    out
}

/// Appends the cut faces between nested `loops` (outermost first, each with the tissue beneath
/// it and the same points at rest, which become the vertices' 3D texture coordinates) to
/// `mesh`. `closed` joins the last point to the first; `normal` is the face normal;
/// `clip` says whether the faces are themselves subject to the cut plane in the shader.
/// Bands of `hidden` tissues are left open.
pub fn fill_section(
    loops: &[(Tissue, SectionLoop, SectionLoop)],
    closed: bool,
    normal: Vec3,
    clip: bool,
    hidden: TissueSet,
    mesh: &mut SceneMesh,
) {
    let Some(len) = loops.first().map(|l| l.1.len()) else { return };
    if loops.iter().any(|l| l.1.len() != len) || len < 2 {
        return;
    }
    let segments = if closed { len } else { len - 1 };
    for (k, (tissue, outer, outer_rest)) in loops.iter().enumerate() {
        let outer = Ring { at: outer, rest: outer_rest };
        let (inner, inner_rest): (SectionLoop, SectionLoop) = match loops.get(k + 1) {
            Some((_, inner, inner_rest)) => (inner.clone(), inner_rest.clone()),
            None => {
                // Innermost: shrink toward the loop's centroid (bone cortex around marrow);
                // the rest loop shrinks with the same weights.
                let present: Vec<(Vec3, Vec3)> =
                    outer.at.iter().zip(outer.rest).filter_map(|(p, r)| Some((*p)?).zip(*r)).collect();
                if present.is_empty() {
                    continue;
                }
                let n = present.len() as f32;
                let centroid = present.iter().map(|p| p.0).sum::<Vec3>() / n;
                let centroid_rest = present.iter().map(|p| p.1).sum::<Vec3>() / n;
                let core: SectionLoop = outer.at.iter().map(|p| p.map(|p| centroid.lerp(p, 0.55))).collect();
                let core_rest: SectionLoop =
                    outer.rest.iter().map(|p| p.map(|p| centroid_rest.lerp(p, 0.55))).collect();
                let marrow = if *tissue == Tissue::Bone { Material::marrow() } else { Material::cut_face(*tissue) };
                if !hidden.contains(*tissue) {
                    let ring = Ring { at: &core, rest: &core_rest };
                    fan(ring, (centroid, centroid_rest), segments, normal, marrow, clip, mesh);
                }
                (core, core_rest)
            }
        };
        if hidden.contains(*tissue) {
            continue;
        }
        let inner = Ring { at: &inner, rest: &inner_rest };
        band(outer, inner, segments, normal, Material::cut_face(*tissue), clip, mesh);
    }
}

/// A section loop with its rest positions.
#[derive(Clone, Copy)]
struct Ring<'a> {
    at: &'a SectionLoop,
    rest: &'a SectionLoop,
}

impl Ring<'_> {
    fn get(&self, i: usize) -> Option<(Vec3, Vec3)> {
        self.at.get(i).copied().flatten().zip(self.rest.get(i).copied().flatten())
    }
}

fn vertex((p, rest): (Vec3, Vec3), normal: Vec3, material: Material, clip: bool) -> LitVertex {
    LitVertex {
        position: p.to_array(),
        normal: normal.to_array(),
        color: material.linear_rgba(),
        params: [material.shininess, if clip { 1.0 } else { 0.0 }],
        rest: rest.extend(1.0).to_array(),
    }
}

fn band(
    outer: Ring<'_>,
    inner: Ring<'_>,
    segments: usize,
    normal: Vec3,
    material: Material,
    clip: bool,
    mesh: &mut SceneMesh,
) {
    let len = outer.at.len();
    for i in 0..segments {
        let j = (i + 1) % len;
        let (Some(a), Some(b), Some(c), Some(d)) = (outer.get(i), outer.get(j), inner.get(j), inner.get(i)) else {
            continue;
        };
        let base = mesh.vertices.len() as u32;
        for p in [a, b, c, d] {
            mesh.vertices.push(vertex(p, normal, material, clip));
        }
        mesh.indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
}

fn fan(
    ring: Ring<'_>,
    centre: (Vec3, Vec3),
    segments: usize,
    normal: Vec3,
    material: Material,
    clip: bool,
    mesh: &mut SceneMesh,
) {
    let len = ring.at.len();
    let base = mesh.vertices.len() as u32;
    mesh.vertices.push(vertex(centre, normal, material, clip));
    for i in 0..segments {
        let j = (i + 1) % len;
        let (Some(a), Some(b)) = (ring.get(i), ring.get(j)) else { continue };
        let k = mesh.vertices.len() as u32;
        mesh.vertices.push(vertex(a, normal, material, clip));
        mesh.vertices.push(vertex(b, normal, material, clip));
        mesh.indices.extend_from_slice(&[base, k, k + 1]);
    }
}

/// Unit normal of a loop by Newell's method (`+Z` if degenerate); orientation follows the loop.
pub fn loop_normal(points: &SectionLoop) -> Vec3 {
    let p: Vec<Vec3> = points.iter().flatten().copied().collect();
    let mut n = Vec3::ZERO;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        n += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    n.try_normalize().unwrap_or(Vec3::Z)
}
