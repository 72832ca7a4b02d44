//! CPU tessellation of one frame into the renderer's vertex buffers: the Bézier-patched
//! boundary grids, other surfaces, the cut faces, the spring wireframe and the tool.
//!
//! # How it works
//! 1. For every boundary grid: the grid points of this frame, one [`Patch`] per cell, the
//!    paper's counts `(n, m)` per cell from its corner normals (Eqs. 3-4).
//! 2. Counts are made conforming: a column of cells takes the largest `n` found in it and a row
//!    of cells the largest `m`, so neighbouring patches share their edge samples and the surface
//!    has no cracks (T-junctions) while staying adaptive: flat strips stay coarse.
//! 3. Each patch is sampled at `S(u/n, v/m)` (Eq. 2) with normals from its exact tangents.
//! 4. Cut faces ([`crate::cut`]), the springs on the removed side (clipped to it) and the tool.
//!
//! [`MeshBuilder`] keeps its buffers between frames, so a steady stream allocates nothing after
//! the first frame.

use glam::Vec3;

use crate::bezier::{CellLayout, GridSurface, PHI, Patch, subdivisions_with_phi};
use crate::cut::{CutPlane, End, SectionLoop, end_loop, fill_section, loop_normal, section_loop_with_rest};
use crate::material::Material;
use crate::scene_mesh::{LineVertex, LitVertex, SceneMesh};
use crate::view_model::{Frame, Tissue, TissueSet, ToolPose, ViewModel};
use bytemuck::Zeroable;

/// Which springs to draw as lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpringDisplay {
    /// None.
    Off,
    /// Those on the side the cut plane removes (clipped to it): the network shows where the
    /// solid tissue was taken away. Without a cut plane: none.
    RemovedSide,
    /// All of them, everywhere.
    All,
}

/// What to build. `Default` is the viewer's default look.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshOptions {
    /// Angle threshold `φ` of Eqs. 3-4, radians. Default π/18.
    pub phi: f64,
    /// The cut plane, if any. Default none.
    pub cut: Option<CutPlane>,
    /// Springs drawn as lines. Default [`SpringDisplay::RemovedSide`].
    pub springs: SpringDisplay,
    /// Section samples per grid cell around the limb. Default 8.
    pub section_samples: usize,
    /// Close the two ends of a limb segment with cut faces. Default true.
    pub end_caps: bool,
    /// How far the removed side's springs are moved away from the cut, along its normal, m,
    /// so the wireframe does not hide the cross-section (an exploded view). Default 0.03.
    pub explode: f32,
    /// Tissues not drawn: their surfaces, cut faces and springs. When the skin is hidden the
    /// outermost shown boundary of a closed limb is drawn as a surface instead. Default none.
    pub hidden: TissueSet,
    /// Draw the edges of the triangles (tessellation, cut faces, tool) as lines instead of
    /// filled surfaces. Default false.
    pub wireframe: bool,
}

impl Default for MeshOptions {
    fn default() -> Self {
        Self {
            phi: PHI,
            cut: None,
            springs: SpringDisplay::RemovedSide,
            section_samples: 8,
            end_caps: true,
            explode: 0.03,
            hidden: TissueSet::default(),
            wireframe: false,
        }
    }
}

/// Builds [`SceneMesh`]es, reusing its scratch buffers between frames.
#[derive(Debug, Default)]
pub struct MeshBuilder {
    points: Vec<Vec3>,
    rest_points: Vec<Vec3>,
    patches: Vec<Vec<Patch>>,
    rest_patches: Vec<Vec<Patch>>,
    node_normals: Vec<Vec3>,
    node_vertex: Vec<u32>,
}

impl MeshBuilder {
    /// A builder with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Tessellates `frame` of `model` into `out` (cleared first).
    ///
    /// Every tissue vertex also gets its rest position (its 3D texture coordinate), computed
    /// exactly as its position is but from `model.rest_positions`: the same Bézier patch
    /// parameters, the same interpolation weights. A model without rest positions takes this
    /// frame's positions as rest. A frame with fewer positions than the model needs yields an
    /// empty mesh.
    pub fn build(&mut self, model: &ViewModel, frame: &Frame, opts: &MeshOptions, out: &mut SceneMesh) {
        out.clear();
        if frame.positions.len() < model.node_count || !model.is_consistent() {
            return;
        }
        let pos = &frame.positions;
        let rest = if model.rest_positions.len() >= model.node_count { &model.rest_positions } else { pos };
        self.patches.resize_with(model.grids.len(), Vec::new);
        self.rest_patches.resize_with(model.grids.len(), Vec::new);
        let mut count_sum = 0u64;
        // Boundaries inside a closed skin tube are seen only through the cut faces and end
        // caps, which are built from their patches: their own surfaces are not drawn. Drawn,
        // the approximating patches of a deeper grid (sampled half a cell apart from the
        // skin's, 2 mm beneath it) could poke through a sharply bent skin.
        let grid_tissue = |g: usize| if g == 0 { Tissue::Skin } else { model.grids[g].beneath };
        let outermost_shown = (0..model.grids.len()).find(|&g| !opts.hidden.contains(grid_tissue(g))).unwrap_or(0);
        let enclosed = |g: usize| {
            let outer = &model.grids[0];
            (g > outermost_shown || opts.hidden.contains(grid_tissue(g)))
                && opts.end_caps
                && outer.wrap
                && model.grids[g].wrap
                && model.grids[g].cols == outer.cols
        };
        for (g, grid) in model.grids.iter().enumerate() {
            self.points.clear();
            self.points.extend(grid.nodes.iter().map(|&i| pos[i as usize]));
            self.rest_points.clear();
            self.rest_points.extend(grid.nodes.iter().map(|&i| rest[i as usize]));
            let surface = GridSurface::new(grid.cols, grid.rows, grid.wrap, &self.points);
            let rest_surface = GridSurface::new(grid.cols, grid.rows, grid.wrap, &self.rest_points);
            let rest_patches = &mut self.rest_patches[g];
            rest_patches.clear();
            for r in 0..rest_surface.cell_rows() {
                rest_patches.extend((0..rest_surface.cell_cols()).map(|c| rest_surface.patch(c, r)));
            }
            if enclosed(g) {
                let patches = &mut self.patches[g];
                patches.clear();
                for r in 0..surface.cell_rows() {
                    patches.extend((0..surface.cell_cols()).map(|c| surface.patch(c, r)));
                }
                continue;
            }
            let material = Material::of(grid_tissue(g));
            if opts.hidden.contains(grid_tissue(g)) {
                // Hidden, and not part of a closed limb's section: nothing to keep.
                self.patches[g].clear();
                continue;
            }
            let (sum, max) = tessellate(&surface, &mut self.patches[g], &self.rest_patches[g], material, opts.phi, out);
            count_sum += sum;
            out.stats.max_counts = (out.stats.max_counts.0.max(max.0), out.stats.max_counts.1.max(max.1));
        }
        if out.stats.patches > 0 {
            out.stats.mean_quads_per_patch = count_sum as f32 / out.stats.patches as f32;
        }
        for surface in model.triangle_surfaces.iter().filter(|s| !opts.hidden.contains(s.tissue)) {
            self.smooth_triangles(pos, rest, &surface.triangles, Material::of(surface.tissue), out);
        }
        self.sections(model, opts, out);
        springs(model, pos, opts, out);
        if let Some(tool) = frame.tool {
            add_tool(&tool, out);
        }
        if opts.wireframe {
            to_wireframe(out);
        }
        out.stats.triangles = out.indices.len() / 3;
        out.stats.lines = out.lines.len() / 2;
    }

    fn sections(&self, model: &ViewModel, opts: &MeshOptions, out: &mut SceneMesh) {
        // Only closed tubes enclose a cross-section; and only grids that share the outer
        // grid's column structure can be paired. Open sheets (e.g. the core's layered block,
        // whose inner layers have no grid) show their cut through the springs alone.
        let Some(outer) = model.grids.first().filter(|g| g.wrap) else { return };
        let nested: Vec<usize> = (0..model.grids.len())
            .filter(|&g| model.grids[g].cols == outer.cols && model.grids[g].wrap == outer.wrap)
            .collect();
        let samples = opts.section_samples.max(1);
        type Loops = Vec<(Tissue, SectionLoop, SectionLoop)>;
        // The loop of one boundary and the same points at rest, from its patches.
        type MakeLoops<'a> = &'a dyn Fn(&CellLayout, &[Patch], &[Patch]) -> (SectionLoop, SectionLoop);
        let loops_with = |make: MakeLoops<'_>| -> Loops {
            nested
                .iter()
                .map(|&g| {
                    let grid = &model.grids[g];
                    let layout = CellLayout {
                        cols: if grid.wrap { grid.cols } else { grid.cols - 1 },
                        rows: grid.rows - 1,
                        wrap: grid.wrap,
                    };
                    let (at, rest) = make(&layout, &self.patches[g], &self.rest_patches[g]);
                    (grid.beneath, at, rest)
                })
                .collect()
        };
        if let Some(plane) = opts.cut {
            let loops =
                loops_with(&|grid, patches, rest| section_loop_with_rest(grid, patches, rest, &plane, samples, 6));
            fill_section(&loops, outer.wrap, plane.normal, false, opts.hidden, out);
            // Dark outlines where the boundaries meet the cut, lifted off the face slightly.
            let lift = plane.normal * 2.0e-4;
            let outline = [0.06, 0.025, 0.02, 0.9];
            for (tissue, lp, _) in &loops {
                if opts.hidden.contains(*tissue) {
                    continue;
                }
                let n = lp.len();
                let segments = if outer.wrap { n } else { n.saturating_sub(1) };
                for i in 0..segments {
                    if let (Some(a), Some(b)) = (lp[i], lp[(i + 1) % n]) {
                        out.lines.push(LineVertex { position: (a + lift).to_array(), color: outline });
                        out.lines.push(LineVertex { position: (b + lift).to_array(), color: outline });
                    }
                }
            }
        }
        if opts.end_caps {
            for end in [End::First, End::Last] {
                let loops = loops_with(&|grid, patches, rest| {
                    (end_loop(grid, patches, end, samples), end_loop(grid, rest, end, samples))
                });
                let normal = loops.first().map_or(Vec3::Z, |l| loop_normal(&l.1));
                fill_section(&loops, outer.wrap, normal, true, opts.hidden, out);
            }
        }
    }

    fn smooth_triangles(
        &mut self,
        pos: &[Vec3],
        rest: &[Vec3],
        triangles: &[[u32; 3]],
        material: Material,
        out: &mut SceneMesh,
    ) {
        self.node_normals.clear();
        self.node_normals.resize(pos.len(), Vec3::ZERO);
        self.node_vertex.clear();
        self.node_vertex.resize(pos.len(), u32::MAX);
        for t in triangles {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let n = (b - a).cross(c - a);
            for &i in t {
                self.node_normals[i as usize] += n;
            }
        }
        let color = material.linear_rgba();
        for t in triangles {
            for &i in t {
                let slot = &mut self.node_vertex[i as usize];
                if *slot == u32::MAX {
                    *slot = out.vertices.len() as u32;
                    out.vertices.push(LitVertex {
                        position: pos[i as usize].to_array(),
                        normal: self.node_normals[i as usize].normalize_or(Vec3::Z).to_array(),
                        color,
                        params: [material.shininess, 1.0],
                        rest: rest[i as usize].extend(1.0).to_array(),
                    });
                }
                out.indices.push(*slot);
            }
        }
    }
}

/// Tessellates one grid; returns `(Σ n·m, (max n, max m))` of the paper's per-cell counts.
fn tessellate(
    surface: &GridSurface<'_>,
    patches: &mut Vec<Patch>,
    rest_patches: &[Patch],
    material: Material,
    phi: f64,
    out: &mut SceneMesh,
) -> (u64, (u32, u32)) {
    let (cc, cr) = (surface.cell_cols(), surface.cell_rows());
    patches.clear();
    let mut n_col = vec![1u32; cc];
    let mut m_row = vec![1u32; cr];
    let mut sum = 0u64;
    let mut max = (1, 1);
    for r in 0..cr {
        for c in 0..cc {
            patches.push(surface.patch(c, r));
            let (n, m) = subdivisions_with_phi(surface.cell_corner_normals(c, r), phi);
            n_col[c] = n_col[c].max(n);
            m_row[r] = m_row[r].max(m);
            sum += u64::from(n * m);
            max = (max.0.max(n), max.1.max(m));
        }
    }
    out.stats.patches += patches.len();
    let prefix = |counts: &[u32]| -> Vec<usize> {
        let mut acc = 0;
        let mut v: Vec<usize> = counts
            .iter()
            .map(|&k| {
                let start = acc;
                acc += k as usize;
                start
            })
            .collect();
        v.push(acc);
        v
    };
    let (u_off, v_off) = (prefix(&n_col), prefix(&m_row));
    let total_u = u_off[cc];
    let total_v = v_off[cr];
    let vcols = if surface.wraps() { total_u } else { total_u + 1 };
    let vrows = total_v + 1;
    let base = out.vertices.len();
    let color = material.linear_rgba();
    out.vertices.resize(base + vcols * vrows, LitVertex::zeroed());
    for r in 0..cr {
        for c in 0..cc {
            let patch = &patches[r * cc + c];
            let rest_patch = rest_patches.get(r * cc + c).unwrap_or(patch);
            let fallback = surface.point_normal(c as isize, r as isize);
            let (n, m) = (n_col[c], m_row[r]);
            for a in 0..=n {
                for b in 0..=m {
                    let (s, t) = (a as f32 / n as f32, b as f32 / m as f32);
                    let (p, ds, dt) = patch.eval_with_tangents(s, t);
                    let normal = ds.cross(dt).try_normalize().unwrap_or(fallback);
                    let iu = (u_off[c] + a as usize) % vcols;
                    let iv = v_off[r] + b as usize;
                    out.vertices[base + iv * vcols + iu] = LitVertex {
                        position: p.to_array(),
                        normal: normal.to_array(),
                        color,
                        params: [material.shininess, 1.0],
                        rest: rest_patch.eval(s, t).extend(1.0).to_array(),
                    };
                }
            }
        }
    }
    for j in 0..total_v {
        for i in 0..total_u {
            let i1 = (i + 1) % vcols;
            let v00 = (base + j * vcols + i) as u32;
            let v10 = (base + j * vcols + i1) as u32;
            let v01 = (base + (j + 1) * vcols + i) as u32;
            let v11 = (base + (j + 1) * vcols + i1) as u32;
            out.indices.extend_from_slice(&[v00, v10, v11, v00, v11, v01]);
        }
    }
    (sum, max)
}

fn springs(model: &ViewModel, pos: &[Vec3], opts: &MeshOptions, out: &mut SceneMesh) {
    for (s, &[a, b]) in model.springs.iter().enumerate() {
        let (pa, pb) = (pos[a as usize], pos[b as usize]);
        let seg = match (opts.springs, opts.cut) {
            (SpringDisplay::Off, _) | (SpringDisplay::RemovedSide, None) => return,
            (SpringDisplay::All, _) => Some((pa, pb)),
            (SpringDisplay::RemovedSide, Some(plane)) => plane
                .removed_part(pa, pb)
                .map(|(p, q)| (p + plane.normal * opts.explode, q + plane.normal * opts.explode)),
        };
        if opts.hidden.contains(model.spring_tissue[s]) {
            continue;
        }
        if let Some((p, q)) = seg {
            let color = Material::spring_rgba(model.spring_tissue[s]);
            out.lines.push(LineVertex { position: p.to_array(), color });
            out.lines.push(LineVertex { position: q.to_array(), color });
        }
    }
}

/// Replaces the filled triangles of `out` by their edges (each shared edge once), drawn in
/// the triangles' colours, opaque.
fn to_wireframe(out: &mut SceneMesh) {
    let mut edges: Vec<(u32, u32)> = out
        .indices
        .chunks_exact(3)
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    for (a, b) in edges {
        for v in [a, b] {
            let v = &out.vertices[v as usize];
            let [r, g, b, _] = v.color;
            out.lines.push(LineVertex { position: v.position, color: [r, g, b, 1.0] });
        }
    }
    out.indices.clear();
}

/// The haptic tool: a steel ball on a shaft leaning back toward the viewer's upper side.
fn add_tool(tool: &ToolPose, out: &mut SceneMesh) {
    let material = Material::tool();
    let color = material.linear_rgba();
    let params = [material.shininess, 0.0];
    let (stacks, slices) = (16usize, 24usize);
    let base = out.vertices.len() as u32;
    for i in 0..=stacks {
        let phi = core::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let theta = core::f32::consts::TAU * j as f32 / slices as f32;
            let n = Vec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin());
            out.vertices.push(LitVertex {
                position: (tool.center + n * tool.radius).to_array(),
                normal: n.to_array(),
                color,
                params,
                rest: [0.0; 4],
            });
        }
    }
    let row = (slices + 1) as u32;
    for i in 0..stacks as u32 {
        for j in 0..slices as u32 {
            let a = base + i * row + j;
            out.indices.extend_from_slice(&[a, a + row, a + 1, a + 1, a + row, a + row + 1]);
        }
    }
    // Shaft: a thin cylinder from the ball's centre up and slightly toward -x.
    let axis = Vec3::new(-0.35, 1.0, 0.25).normalize();
    let side = axis.cross(Vec3::Z).normalize();
    let up = side.cross(axis);
    let (radius, length) = (tool.radius * 0.38, tool.radius * 9.0);
    let base = out.vertices.len() as u32;
    for j in 0..=slices {
        let theta = core::f32::consts::TAU * j as f32 / slices as f32;
        let n = side * theta.cos() + up * theta.sin();
        for end in [0.0, length] {
            out.vertices.push(LitVertex {
                position: (tool.center + axis * end + n * radius).to_array(),
                normal: n.to_array(),
                color,
                params,
                rest: [0.0; 4],
            });
        }
    }
    for j in 0..slices as u32 {
        let a = base + 2 * j;
        out.indices.extend_from_slice(&[a, a + 1, a + 2, a + 2, a + 1, a + 3]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::SyntheticLimb;

    fn limb_mesh(t: f64, opts: &MeshOptions) -> (ViewModel, SceneMesh) {
        let limb = SyntheticLimb::default();
        let model = limb.view_model();
        let mut mesh = SceneMesh::default();
        MeshBuilder::new().build(&model, &limb.frame(0, t), opts, &mut mesh);
        (model, mesh)
    }

    #[test]
    fn tessellation_is_finite_and_indexed_works() {
        let (_, mesh) = limb_mesh(0.5, &MeshOptions::default());
        assert!(mesh.stats.triangles > 1000);
        assert!(mesh.indices.iter().all(|&i| (i as usize) < mesh.vertices.len()));
        assert!(mesh.vertices.iter().all(|v| v.position.iter().chain(&v.normal).all(|x| x.is_finite())));
    }

    #[test]
    fn tessellation_adapts_to_the_indentation_works() {
        // The pressed skin bends more than 20° within a cell somewhere, the flat limb does not.
        let (_, pressed) = limb_mesh(0.5, &MeshOptions::default());
        let flat_limb = SyntheticLimb { indent_depth: 0.0, ..SyntheticLimb::default() };
        let model = flat_limb.view_model();
        let mut flat = SceneMesh::default();
        MeshBuilder::new().build(&model, &flat_limb.frame(0, 0.5), &MeshOptions::default(), &mut flat);
        assert!(pressed.stats.max_counts.1 > flat.stats.max_counts.1, "{:?} vs {:?}", pressed.stats, flat.stats);
        assert!(pressed.stats.triangles > flat.stats.triangles);
    }

    #[test]
    fn skin_tessellation_is_watertight_works() {
        // Every edge of the skin tube is shared by two triangles except on its two end rims:
        // the conforming counts leave no cracks between patches of different resolution.
        let limb = SyntheticLimb::default();
        let mut model = limb.view_model();
        model.grids.truncate(1);
        let mut frame = limb.frame(0, 0.5);
        frame.tool = None;
        let mut mesh = SceneMesh::default();
        let opts = MeshOptions { springs: SpringDisplay::Off, end_caps: false, ..MeshOptions::default() };
        MeshBuilder::new().build(&model, &frame, &opts, &mut mesh);
        assert!(mesh.stats.max_counts.1 > 1, "the test needs patches of different resolution");
        let mut edges = std::collections::HashMap::<(u32, u32), u32>::new();
        for t in mesh.indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let half = limb.length / 2.0;
        for (&(a, b), &n) in &edges {
            assert!(n <= 2, "edge shared by {n} triangles");
            if n == 1 {
                for v in [a, b] {
                    let x = mesh.vertices[v as usize].position[0];
                    assert!((x.abs() - half).abs() < 1e-4, "open edge inside the surface at x = {x}");
                }
            }
        }
    }

    #[test]
    fn section_shows_every_tissue_works() {
        let (_, mesh) = limb_mesh(
            0.5,
            &MeshOptions {
                cut: Some(crate::cut::CutPlane::through(glam::Vec3::new(0.05, 0.0, 0.0), glam::Vec3::X)),
                ..MeshOptions::default()
            },
        );
        for tissue in [Tissue::Skin, Tissue::Fat, Tissue::Muscle, Tissue::Bone] {
            let color = Material::cut_face(tissue).linear_rgba();
            assert!(mesh.vertices.iter().any(|v| v.color == color && v.params[1] == 0.0), "no cut face of {tissue:?}");
        }
        assert!(mesh.lines.len() > 100, "springs on the removed side are drawn");
    }

    #[test]
    fn hidden_skin_shows_the_fat_surface_and_no_skin_works() {
        let mut hidden = TissueSet::default();
        hidden.toggle(Tissue::Skin);
        let cut = Some(crate::cut::CutPlane::through(glam::Vec3::new(0.05, 0.0, 0.0), glam::Vec3::X));
        let (model, mesh) = limb_mesh(0.5, &MeshOptions { hidden, cut, ..MeshOptions::default() });
        let colour = |m: Material| m.linear_rgba();
        let used = |c: [f32; 4]| mesh.vertices.iter().any(|v| v.color == c);
        assert!(!used(colour(Material::of(Tissue::Skin))), "skin surface drawn");
        assert!(!used(colour(Material::cut_face(Tissue::Skin))), "skin cut face drawn");
        assert!(used(colour(Material::of(Tissue::Fat))), "the fat surface replaces the skin");
        assert!(used(colour(Material::cut_face(Tissue::Muscle))));
        assert!(!used(colour(Material::of(Tissue::Muscle))), "muscle stays inside the fat");
        let skin_springs = Material::spring_rgba(Tissue::Skin);
        assert!(mesh.lines.iter().all(|l| l.color != skin_springs), "skin springs drawn");
        assert!(!model.springs.is_empty());
    }

    #[test]
    fn wireframe_draws_each_triangle_edge_once_works() {
        let limb = SyntheticLimb::default();
        let model = limb.view_model();
        let frame = limb.frame(0, 0.5);
        let opts = MeshOptions { springs: SpringDisplay::Off, ..MeshOptions::default() };
        let mut filled = SceneMesh::default();
        MeshBuilder::new().build(&model, &frame, &opts, &mut filled);
        let mut wire = SceneMesh::default();
        MeshBuilder::new().build(&model, &frame, &MeshOptions { wireframe: true, ..opts }, &mut wire);
        assert!(wire.indices.is_empty());
        // Every triangle has three edges; in a closed or nearly closed surface each edge is
        // shared by two triangles, so there are between 1.5 and 3 edges per triangle.
        let (edges, triangles) = (wire.lines.len() / 2, filled.indices.len() / 3);
        assert!(edges * 2 >= triangles * 3 && edges <= triangles * 3, "{edges} edges, {triangles} triangles");
    }

    #[test]
    fn boundaries_inside_the_skin_tube_are_not_drawn_works() {
        // Only the skin's own colour appears on lit surfaces (besides cut faces and the
        // tool): the fat, muscle and bone boundaries inside the closed tube show through the
        // section alone.
        let (model, mesh) = limb_mesh(0.5, &MeshOptions::default());
        assert!(model.grids.len() > 1, "the test needs nested boundaries");
        for tissue in [Tissue::Fat, Tissue::Muscle, Tissue::Bone] {
            let color = Material::of(tissue).linear_rgba();
            assert!(mesh.vertices.iter().all(|v| v.color != color), "{tissue:?}'s surface is drawn");
        }
        assert!(mesh.vertices.iter().any(|v| v.color == Material::of(Tissue::Skin).linear_rgba()));
    }
}
