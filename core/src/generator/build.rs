//! The generation pipeline: sample the boundaries, lay the topology over the samples, and
//! give springs their laws and nodes their masses.

use super::centreline::Centreline;
use super::error::GeneratorError;
use super::grid::GridSize;
use super::layers::{BONE, FAT, MUSCLE, SKIN, generated_layers};
use super::mass::node_masses;
use super::materials::Materials;
use super::surface::{Boundary, BoundarySurface};
use super::topology::LayeredTopology;
use super::vec3::{add, centroid, distance, scale};
use crate::model::{Cell, CellKind, GENERATE_MEMORY_FACTOR, Model, NodeKind, Surface};
use std::f64::consts::TAU;

/// Springs shorter than this (m) mean two samples coincide.
const MIN_REST_LENGTH: f64 = 1e-9;

/// Progress callback: `(stage, done, total)`. Called with `done = 0` when a stage starts,
/// after each ring or row of cells, and with `done = total` when it ends. Stages, in
/// order: [`STAGES`].
pub type Progress<'a> = &'a mut dyn FnMut(&str, usize, usize);

/// Names of the generation stages, in the order they report progress.
pub const STAGES: [&str; 6] = ["outer skin", "skin/fat", "fat/muscle", "muscle/bone", "springs", "masses"];

/// What the generator samples: the limb's centreline and its four tissue boundaries,
/// outermost first.
#[derive(Clone, Copy)]
pub struct LimbSurfaces<'a> {
    /// The limb's axis; the grid spans it from end to end.
    pub centreline: &'a Centreline,
    /// The outer skin.
    pub outer_skin: &'a dyn BoundarySurface,
    /// The skin/fat boundary (dermis bottom); for segmented data usually
    /// [`InwardOffset`](super::InwardOffset) of the outer skin.
    pub skin_fat: &'a dyn BoundarySurface,
    /// The fat/muscle boundary.
    pub fat_muscle: &'a dyn BoundarySurface,
    /// The muscle/bone boundary; its nodes are fixed.
    pub muscle_bone: &'a dyn BoundarySurface,
    /// Distance from the centreline of the outer rays' origins, m: more than the outer
    /// skin's largest distance from the axis (twice it is a safe choice).
    pub reach: f64,
}

impl LimbSurfaces<'_> {
    fn surface(&self, boundary: Boundary) -> &dyn BoundarySurface {
        match boundary {
            Boundary::OuterSkin => self.outer_skin,
            Boundary::SkinFat => self.skin_fat,
            Boundary::FatMuscle => self.fat_muscle,
            Boundary::MuscleBone => self.muscle_bone,
        }
    }
}

fn tick(progress: &mut Option<Progress<'_>>, stage: &str, done: usize, total: usize) {
    if let Some(p) = progress.as_mut() {
        p(stage, done, total);
    }
}

/// Generates the layered model of a limb on a `grid` (see the [module docs](super) for
/// the stages). Nodes: `W(H+1)` outer grid points, then `2WH` nodes on each of the
/// skin/fat, fat/muscle and muscle/bone boundaries (the last ones fixed). Layers: skin,
/// fat, muscle, bone (indices in [`layers`](super::layers)). Surfaces: `skin_outer`
/// (with its grid, the seam column repeated as column W so a consumer that does not wrap
/// still covers every cell), `skin_fat`, `fat_muscle`, `muscle_bone`. Texture coordinates
/// are positions scaled to the model's bounding box.
pub fn generate_layered(
    name: &str,
    surfaces: &LimbSurfaces<'_>,
    grid: GridSize,
    materials: &Materials,
    mut progress: Option<Progress<'_>>,
) -> Result<Model, GeneratorError> {
    if !grid.is_valid() {
        return Err(GeneratorError::BadGrid { columns: grid.columns, rows: grid.rows });
    }
    let what = format!("model '{name}'");
    grid.model_size().check(&what, GENERATE_MEMORY_FACTOR).map_err(GeneratorError::Size)?;
    if !(surfaces.reach.is_finite() && surfaces.reach > 0.0) {
        return Err(GeneratorError::BadReach);
    }
    if let Some(tissue) = materials.first_invalid() {
        return Err(GeneratorError::BadMaterial { tissue });
    }
    let (w, h) = (grid.columns, grid.rows);
    let topo = LayeredTopology::new(grid);
    let mut positions = vec![[0.0; 3]; grid.masses()];

    // 1. Outer skin: one ray per grid point, from `reach` outside toward the centreline.
    let rings: Vec<f64> = (0..=h).map(|j| j as f64 / h as f64).collect();
    let frames = surfaces.centreline.frames(&rings);
    let stage = STAGES[0];
    tick(&mut progress, stage, 0, grid.surface_nodes());
    for (j, frame) in frames.iter().enumerate() {
        for i in 0..w {
            let dir = frame.direction(TAU * i as f64 / w as f64);
            let origin = add(frame.origin, scale(dir, surfaces.reach));
            let hit = surfaces.outer_skin.hit_toward_axis(origin, frame.origin).ok_or(GeneratorError::RayMissed {
                boundary: Boundary::OuterSkin,
                column: i,
                row: j as u32,
                triangle: None,
            })?;
            positions[grid.surface_node(grid.vertex(i as i64, j as u32)) as usize] = hit;
        }
        tick(&mut progress, stage, (j + 1) * w as usize, grid.surface_nodes());
    }

    // 2–4. Deeper boundaries: one ray per outer triangle, from its centroid (level 1) or
    // its node on the level above, toward the centreline point at the triangle's mean
    // axial position.
    let t_count = grid.triangles();
    let axis_points: Vec<[f64; 3]> = topo
        .outer_triangles
        .iter()
        .map(|c| {
            let s = c.iter().map(|&v| grid.vertex_cell(v).1 as f64).sum::<f64>() / (3.0 * h as f64);
            surfaces.centreline.point_at(s)
        })
        .collect();
    for (level, boundary) in [(1u32, Boundary::SkinFat), (2, Boundary::FatMuscle), (3, Boundary::MuscleBone)] {
        let stage = STAGES[level as usize];
        let surface = surfaces.surface(boundary);
        tick(&mut progress, stage, 0, t_count);
        for t in 0..t_count as u32 {
            let origin = if level == 1 {
                centroid(&topo.outer_triangles[t as usize].map(|v| positions[grid.surface_node(v) as usize]))
            } else {
                positions[grid.triangle_node(level - 1, t) as usize]
            };
            let hit = surface.hit_toward_axis(origin, axis_points[t as usize]).ok_or_else(|| {
                let (column, row, half) = grid.triangle_cell(t);
                GeneratorError::RayMissed { boundary, column, row, triangle: Some(half as u8) }
            })?;
            positions[grid.triangle_node(level, t) as usize] = hit;
            if (t as usize + 1).is_multiple_of(2 * w as usize) {
                tick(&mut progress, stage, t as usize + 1, t_count);
            }
        }
    }

    let mut model = Model { name: name.into(), layers: generated_layers(), ..Model::default() };
    let first_bone = grid.triangle_node(3, 0) as usize;
    let first_fat = grid.triangle_node(2, 0) as usize;
    for (n, &p) in positions.iter().enumerate() {
        let (kind, layer) = if n >= first_bone {
            (NodeKind::Fixed, BONE)
        } else if n >= first_fat {
            (NodeKind::Free, FAT)
        } else {
            (NodeKind::Free, SKIN)
        };
        model.nodes.push(p, 0.0, kind, layer);
    }

    // 5. Springs, in the topology's order, with their layer's law and dashpot.
    let stage = STAGES[4];
    let total = topo.springs.len();
    tick(&mut progress, stage, 0, total);
    for s in &topo.springs {
        let rest = distance(positions[s.a as usize], positions[s.b as usize]);
        if rest.is_nan() || rest < MIN_REST_LENGTH {
            return Err(GeneratorError::DegenerateSpring { a: s.a, b: s.b });
        }
        let material = materials.of_layer(s.layer);
        model.springs.push(s.a, s.b, rest, material.spring.law(rest), material.damping, s.layer);
    }
    tick(&mut progress, stage, total, total);

    // 6. Masses, texture coordinates, surfaces, provenance.
    let stage = STAGES[5];
    tick(&mut progress, stage, 0, positions.len());
    model.nodes.mass = node_masses(&positions, &topo, materials);
    set_texcoords(&mut model);
    model.surfaces = surfaces_of(&topo);
    model.cells = cells_of(&topo, &positions);
    model.provenance = vec![
        ("generator".into(), "lamina layered generator".into()),
        ("grid".into(), format!("{w}x{h}")),
        ("centreline_length_m".into(), surfaces.centreline.length().to_string()),
        ("reach_m".into(), surfaces.reach.to_string()),
        ("masses".into(), model.nodes.len().to_string()),
        ("springs".into(), model.springs.len().to_string()),
    ];
    tick(&mut progress, stage, positions.len(), positions.len());
    model.validate()?;
    Ok(model)
}

/// Texture coordinates: positions scaled to the bounding box, each axis to `[0, 1]`.
fn set_texcoords(model: &mut Model) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &model.nodes.position {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    for (tc, p) in model.nodes.texcoord.iter_mut().zip(&model.nodes.position) {
        for k in 0..3 {
            let span = hi[k] - lo[k];
            tc[k] = if span > 0.0 { ((p[k] - lo[k]) / span) as f32 } else { 0.0 };
        }
    }
}

/// The volume cells the masses were computed on (see `mass.rs`): the skin's tetrahedra
/// (per outer triangle, per shared outer edge, per dual-polygon triangle), then one
/// triangular prism per level triangle in the fat (levels 1–2) and in the muscle (levels
/// 2–3). Each is put in VTK order and oriented to a positive rest volume.
fn cells_of(topo: &LayeredTopology, positions: &[[f64; 3]]) -> Vec<Cell> {
    let grid = topo.grid;
    let s = |v: u32| grid.surface_node(v);
    let l = |level: u32, t: u32| grid.triangle_node(level, t);
    let tet = |nodes: [u32; 4]| Cell::oriented(CellKind::Tetra, SKIN, &nodes, positions);
    let wedge = |upper: u32, tri: &[u32; 3], layer: u16| {
        let nodes = [l(upper, tri[0]), l(upper, tri[1]), l(upper, tri[2])];
        let below = [l(upper + 1, tri[0]), l(upper + 1, tri[1]), l(upper + 1, tri[2])];
        // Base below, top above: the base's right-hand normal faces the top.
        Cell::oriented(CellKind::Wedge, layer, &[below, nodes].concat(), positions)
    };
    let outer = topo.outer_triangles.iter().enumerate().map(|(t, c)| tet([s(c[0]), s(c[1]), s(c[2]), l(1, t as u32)]));
    let edges = topo.shared_edges.iter().map(|&([a, b], [t, u])| tet([s(a), s(b), l(1, t), l(1, u)]));
    let dual = topo
        .level_triangles
        .iter()
        .zip(&topo.level_triangle_apex)
        .map(|(tri, &v)| tet([s(v), l(1, tri[0]), l(1, tri[1]), l(1, tri[2])]));
    let fat = topo.level_triangles.iter().map(|tri| wedge(1, tri, FAT));
    let muscle = topo.level_triangles.iter().map(|tri| wedge(2, tri, MUSCLE));
    outer.chain(edges).chain(dual).chain(fat).chain(muscle).map(|c| c.expect("node counts match the kinds")).collect()
}

/// The outer skin and the three deeper boundaries, each with its triangles and a regular
/// grid (last column repeating the first, around the axis). A deeper level has one node per
/// outer triangle; its grid takes the first half of every cell (the triangle whose centroid
/// sits a third of a cell from corner `(c, r)`), `W × H` points, so a viewer can draw and
/// cut every boundary as it draws the skin.
fn surfaces_of(topo: &LayeredTopology) -> Vec<Surface> {
    let grid = topo.grid;
    let (w, h) = (grid.columns, grid.rows);
    let outer = Surface {
        name: Boundary::OuterSkin.name().into(),
        triangles: topo.outer_triangles.iter().map(|c| c.map(|v| grid.surface_node(v))).collect(),
        grid: Some((
            w + 1,
            h + 1,
            (0..=h).flat_map(|j| (0..=w).map(move |i| grid.surface_node(grid.vertex(i as i64, j)))).collect(),
        )),
    };
    let mut all = vec![outer];
    for (level, boundary) in [(1, Boundary::SkinFat), (2, Boundary::FatMuscle), (3, Boundary::MuscleBone)] {
        all.push(Surface {
            name: boundary.name().into(),
            triangles: topo.level_triangles.iter().map(|tri| tri.map(|t| grid.triangle_node(level, t))).collect(),
            grid: Some((
                w + 1,
                h,
                (0..h)
                    .flat_map(|r| (0..=w).map(move |c| grid.triangle_node(level, grid.triangle(c % w, r, 0))))
                    .collect(),
            )),
        });
    }
    all
}
