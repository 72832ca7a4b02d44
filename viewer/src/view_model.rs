//! What the viewer draws, independent of where the frames come from: tissue boundary grids,
//! other triangle surfaces, the spring network and each node's tissue.
//!
//! A [`ViewModel`] is static (it changes only when the core publishes a new topology);
//! a [`Frame`] carries the positions of one instant plus the tool and the core's statistics.

use glam::Vec3;

/// The tissues the viewer tells apart, each drawn in its own material: the core's.
pub use lamina_core::model::Tissue;

/// A set of tissues (e.g. the layers the user has hidden). `Default`: empty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TissueSet(u8);

impl TissueSet {
    fn bit(tissue: Tissue) -> u8 {
        match tissue {
            Tissue::Skin => 1,
            Tissue::Fat => 2,
            Tissue::Muscle => 4,
            Tissue::Bone => 8,
            Tissue::Other => 16,
        }
    }

    /// Whether `tissue` is in the set.
    pub fn contains(self, tissue: Tissue) -> bool {
        self.0 & Self::bit(tissue) != 0
    }

    /// Adds `tissue` if absent, removes it if present.
    pub fn toggle(&mut self, tissue: Tissue) {
        self.0 ^= Self::bit(tissue);
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// A tissue boundary sampled on a regular grid (the surfaces the paper re-patches).
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryGrid {
    /// Surface name, e.g. `skin_outer`.
    pub name: String,
    /// Grid points per row (around the limb).
    pub cols: usize,
    /// Grid rows (along the limb).
    pub rows: usize,
    /// Whether the last column connects back to the first (a closed tube).
    pub wrap: bool,
    /// Node index of each grid point, row-major.
    pub nodes: Vec<u32>,
    /// Tissue on the inner side of this boundary (the outer skin surface has skin beneath).
    pub beneath: Tissue,
}

/// A triangle surface without grid structure, drawn as is (smooth shading, no patches).
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleSurface {
    /// Surface name.
    pub name: String,
    /// Node index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Tissue the surface is drawn as.
    pub tissue: Tissue,
}

/// The static description of a model as the viewer needs it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ViewModel {
    /// Model name shown in the overlay.
    pub name: String,
    /// Number of nodes in every frame.
    pub node_count: usize,
    /// Grid boundaries, outermost first (outer skin, skin/fat, fat/muscle, muscle/bone).
    pub grids: Vec<BoundaryGrid>,
    /// Surfaces without a grid.
    pub triangle_surfaces: Vec<TriangleSurface>,
    /// Springs as node index pairs.
    pub springs: Vec<[u32; 2]>,
    /// Tissue of each spring (same length as `springs`).
    pub spring_tissue: Vec<Tissue>,
    /// Radius of the scene's tool, m (0: no tool); a tool command with radius 0 is drawn
    /// with it.
    pub tool_radius_m: f32,
    /// Each node's rest position, metres, model frame: where its 3D texture coordinate is
    /// fixed, so the texture moves with the tissue. Empty: the first frame's positions.
    pub rest_positions: Vec<Vec3>,
    /// Each node's tissue (its layer's), for the procedural volume texture. Empty: unknown
    /// (the tissue is then taken from the boundary grids the node lies on).
    pub node_tissue: Vec<Tissue>,
    /// The user's volume texture, if any (else a procedural one is baked from the tissues).
    pub volume: Option<VolumeSpec>,
}

/// Where the viewer finds a user's volume texture (a NIfTI-1 or NRRD file) and how it places it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VolumeSpec {
    /// The file: NIfTI-1 (`.nii`, `.nii.gz`) or NRRD (`.nrrd`, `.nhdr`), told apart by its name.
    pub path: std::path::PathBuf,
    /// Position of the first voxel's centre, metres, model frame (within `f32` when read).
    /// `None`: the header's origin.
    pub origin_m: Option<[f64; 3]>,
    /// Intensities mapped to black and white, `[lo, hi]` (within `f32`, `lo` below `hi`,
    /// when read). `None`: the data's minimum and maximum.
    pub window: Option<[f64; 2]>,
}

impl VolumeSpec {
    /// The volume of a scene's `[visual]` table, if it names one.
    pub fn from_scene(scene: &lamina_core::scene::Scene) -> Option<Self> {
        let visual = scene.visual.as_ref()?;
        Some(Self { path: visual.volume.clone(), origin_m: visual.origin_m, window: visual.window })
    }
}

impl ViewModel {
    /// Whether every index is below `node_count` and the per-spring table matches.
    pub fn is_consistent(&self) -> bool {
        let n = self.node_count as u32;
        self.grids.iter().all(|g| {
            g.nodes.len() == g.cols * g.rows
                && g.rows >= 2
                && g.cols >= if g.wrap { 3 } else { 2 }
                && g.nodes.iter().all(|&i| i < n)
        }) && self.triangle_surfaces.iter().all(|s| s.triangles.iter().flatten().all(|&i| i < n))
            && self.springs.iter().flatten().all(|&i| i < n)
            && self.springs.len() == self.spring_tissue.len()
    }

    /// The model's layers as the user toggles them (keys `1`, `2`, …): the tissues of its
    /// boundary grids, outermost first (the outer skin surface counts as skin), then those of
    /// its other surfaces, each once. The default limb: skin, fat, muscle, bone.
    pub fn layers(&self) -> Vec<Tissue> {
        let grids = self.grids.iter().enumerate().map(|(g, grid)| if g == 0 { Tissue::Skin } else { grid.beneath });
        let mut out: Vec<Tissue> = Vec::new();
        for t in grids.chain(self.triangle_surfaces.iter().map(|s| s.tissue)) {
            if !out.contains(&t) {
                out.push(t);
            }
        }
        out
    }

    /// Builds the view of a core model: every surface with a grid becomes a [`BoundaryGrid`]
    /// (a grid whose last column repeats its first is turned into a wrapping one), the others
    /// triangle surfaces; springs keep their layer's tissue.
    pub fn from_core_model(model: &lamina_core::model::Model) -> Self {
        let layer_tissue: Vec<Tissue> = model.layers.iter().map(|l| l.tissue).collect();
        let mut view = ViewModel { name: model.name.clone(), node_count: model.nodes.len(), ..Self::default() };
        for surface in &model.surfaces {
            let tissue = surface.tissue_beneath();
            match &surface.grid {
                Some((cols, rows, nodes)) => view.grids.push(boundary_grid(&surface.name, *cols, *rows, nodes, tissue)),
                None => view.triangle_surfaces.push(TriangleSurface {
                    name: surface.name.clone(),
                    triangles: surface.triangles.clone(),
                    tissue,
                }),
            }
        }
        let springs = &model.springs;
        for s in 0..springs.len() {
            view.springs.push([springs.a[s], springs.b[s]]);
            view.spring_tissue.push(layer_tissue.get(springs.layer[s] as usize).copied().unwrap_or(Tissue::Other));
        }
        view.rest_positions =
            model.nodes.position.iter().map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)).collect();
        view.node_tissue =
            model.nodes.layer.iter().map(|&l| layer_tissue.get(l as usize).copied().unwrap_or(Tissue::Other)).collect();
        view
    }

    /// Builds the view from the core's topology message alone: its surface grids become
    /// [`BoundaryGrid`]s as in [`ViewModel::from_core_model`], its springs keep their layer's
    /// tissue, and the tool radius is the scene's. A topology without surfaces (a publisher
    /// other than Lamina's core) is drawn from its triangles, their edges as the wireframe.
    pub fn from_topology(topology: &lamina_bridge::Topology) -> Self {
        let mut view = ViewModel {
            name: if topology.name.is_empty() { "live model".into() } else { topology.name.clone() },
            node_count: topology.node_count as usize,
            tool_radius_m: if topology.tool.source == 0 { 0.0 } else { topology.tool.radius_m as f32 },
            ..Self::default()
        };
        let layer_tissue =
            |l: u32| topology.layers.get(l as usize).map_or(Tissue::Other, |layer| tissue_of(layer.tissue));
        for surface in &topology.surfaces {
            let tissue = tissue_of(surface.tissue);
            match surface.grid {
                Some((cols, rows)) => {
                    view.grids.push(boundary_grid(&surface.name, cols, rows, &surface.indices, tissue))
                }
                None => view.triangle_surfaces.push(TriangleSurface {
                    name: surface.name.clone(),
                    triangles: surface.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
                    tissue,
                }),
            }
        }
        if topology.surfaces.is_empty() {
            view.triangle_surfaces.push(TriangleSurface {
                name: "surface".into(),
                triangles: topology.triangles.clone(),
                tissue: Tissue::Skin,
            });
        }
        if topology.springs.is_empty() {
            let mut edges: Vec<[u32; 2]> = topology
                .triangles
                .iter()
                .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
                .map(|[a, b]| [a.min(b), a.max(b)])
                .collect();
            edges.sort_unstable();
            edges.dedup();
            view.spring_tissue = vec![Tissue::Skin; edges.len()];
            view.springs = edges;
        } else {
            view.springs = topology.springs.clone();
            view.spring_tissue = topology.spring_layer.iter().map(|&l| layer_tissue(l)).collect();
        }
        view.rest_positions = topology.rest_positions.iter().map(|p| Vec3::from_array(*p)).collect();
        view.node_tissue = topology.node_layer.iter().map(|&l| layer_tissue(l)).collect();
        view.volume = topology.volume.as_ref().filter(|v| !v.path.is_empty()).map(|v| VolumeSpec {
            path: v.path.clone().into(),
            origin_m: v.origin_m,
            window: v.window,
        });
        view
    }
}

/// The model's tissue for the wire's.
fn tissue_of(kind: lamina_bridge::TissueKind) -> Tissue {
    use lamina_bridge::TissueKind as K;
    match kind {
        K::Skin => Tissue::Skin,
        K::Fat => Tissue::Fat,
        K::Muscle => Tissue::Muscle,
        K::Bone => Tissue::Bone,
        K::Other => Tissue::Other,
    }
}

/// A surface grid as drawn: a grid whose last column repeats its first (the generator's seam
/// convention for a closed tube) becomes a wrapping grid without the repeated column.
fn boundary_grid(name: &str, cols: u32, rows: u32, nodes: &[u32], beneath: Tissue) -> BoundaryGrid {
    let (cols, rows) = (cols as usize, rows as usize);
    let seam_repeated = cols > 3 && (0..rows).all(|r| nodes[r * cols] == nodes[r * cols + cols - 1]);
    let (cols, nodes) = if seam_repeated {
        (cols - 1, (0..rows).flat_map(|r| nodes[r * cols..r * cols + cols - 1].to_vec()).collect())
    } else {
        (cols, nodes.to_vec())
    };
    BoundaryGrid { name: name.to_owned(), cols, rows, wrap: seam_repeated, nodes, beneath }
}

/// The haptic tool as drawn: a sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolPose {
    /// Tip centre, metres, model frame.
    pub center: Vec3,
    /// Tip radius, metres.
    pub radius: f32,
}

/// The core's real-time figures shown in the overlay.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoreStats {
    /// Core tick rate, Hz (from the period median), 0 if unknown.
    pub rate_hz: f64,
    /// Ticks that missed their budget since the core started.
    pub misses: u64,
    /// Ticks run since the core started.
    pub ticks: u64,
}

/// One instant to draw.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Frame {
    /// Publisher's frame counter.
    pub sequence: u64,
    /// Simulated time, seconds.
    pub sim_time_s: f64,
    /// `CLOCK_MONOTONIC` when the core published it, ns (0 for synthetic frames).
    pub publish_time_ns: u64,
    /// Node positions, metres (`ViewModel::node_count` entries).
    pub positions: Vec<Vec3>,
    /// The tool, when known.
    pub tool: Option<ToolPose>,
    /// The core's latest statistics, when known.
    pub stats: Option<CoreStats>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_of_core_default_scene_works() {
        let scene = lamina_core::scene::Scene::builtin_default();
        let model = scene.build_model().expect("built-in scene builds");
        let view = ViewModel::from_core_model(&model);
        assert!(view.is_consistent());
        assert_eq!(view.node_count, model.nodes.len());
        assert_eq!(view.springs.len(), model.springs.len());
        let skin = &view.grids[0];
        // The default limb's skin grid closes around its axis.
        assert_eq!((skin.name.as_str(), skin.beneath, skin.wrap), ("skin_outer", Tissue::Skin, true));
        assert_eq!(view.grids.len(), 4, "skin, skin/fat, fat/muscle and muscle/bone boundaries");
    }

    #[test]
    fn layers_of_the_default_scene_works() {
        let model = lamina_core::scene::Scene::builtin_default().build_model().expect("built-in scene builds");
        let view = ViewModel::from_core_model(&model);
        assert_eq!(view.layers(), [Tissue::Skin, Tissue::Fat, Tissue::Muscle, Tissue::Bone]);
    }

    #[test]
    fn tissue_set_toggles_works() {
        let mut set = TissueSet::default();
        assert!(set.is_empty());
        set.toggle(Tissue::Fat);
        assert!(set.contains(Tissue::Fat) && !set.contains(Tissue::Skin));
        set.toggle(Tissue::Fat);
        assert!(set.is_empty());
    }

    #[test]
    fn view_of_core_grid_with_repeated_seam_wraps_works() {
        use lamina_core::model::{Model, NodeKind, Surface};
        let (w, h) = (6u32, 3u32);
        let mut model = Model::default();
        for _ in 0..w * h {
            model.nodes.push([0.0; 3], 1.0, NodeKind::Free, 0);
        }
        // Columns 0..w, then column 0 again as column w (the generator's seam convention).
        let grid = (0..h).flat_map(|r| (0..=w).map(move |c| r * w + c % w)).collect();
        model.surfaces.push(Surface { name: "skin_outer".into(), triangles: Vec::new(), grid: Some((w + 1, h, grid)) });
        let view = ViewModel::from_core_model(&model);
        let g = &view.grids[0];
        assert!(g.wrap);
        assert_eq!((g.cols, g.rows, g.nodes.len()), (w as usize, h as usize, (w * h) as usize));
        assert!(view.is_consistent());
    }

    #[test]
    fn view_of_bare_wire_topology_works() {
        let topology = lamina_bridge::Topology {
            node_count: 4,
            triangles: vec![[0, 1, 2], [2, 1, 3]],
            ..lamina_bridge::Topology::default()
        };
        let view = ViewModel::from_topology(&topology);
        assert_eq!(view.springs.len(), 5, "shared edge counted once");
        assert!(view.is_consistent());
    }
}
