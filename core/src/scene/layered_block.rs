//! The built-in layered block: muscle, fat and skin rows over a fixed bone plane, on a
//! regular lattice with the yardstick's edge and face-diagonal springs
//! (`config/scenes/block.toml`; the default scene is the generator's limb).

use crate::law::{Bilinear, SpringLaw};
use crate::model::{
    Cell, CellKind, Layer, Model, ModelSize, ModelSizeError, NodeKind, RUN_MEMORY_FACTOR, Surface, Tissue,
};
use crate::yardstick::lattice::{OFFSETS, lattice_model_size};
use serde::Deserialize;

/// A layer's spring law in scene files. Stiffnesses N/m, strains unitless.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum LayerMaterial {
    /// Linear spring.
    Linear {
        /// Stiffness, N/m.
        k: f64,
        /// Dashpot, N·s/m. Default 0.
        #[serde(default)]
        damping: f64,
    },
    /// Bilinear spring; the turning length is `rest · (1 + turn_strain)`.
    Bilinear {
        /// First-phase stiffness, N/m.
        k1: f64,
        /// Second-phase stiffness, N/m.
        k2: f64,
        /// Strain at the turning point (unitless, ≥ 0).
        turn_strain: f64,
        /// Compression stiffness, N/m. Default `k1`.
        kc: Option<f64>,
        /// Dashpot, N·s/m. Default 0.
        #[serde(default)]
        damping: f64,
    },
}

impl LayerMaterial {
    fn law(&self, rest: f64) -> (SpringLaw, f64) {
        match *self {
            LayerMaterial::Linear { k, damping } => (SpringLaw::Linear { stiffness: k }, damping),
            LayerMaterial::Bilinear { k1, k2, turn_strain, kc, damping } => (
                SpringLaw::Bilinear(Bilinear {
                    k1,
                    k2,
                    turn_length: rest * (1.0 + turn_strain),
                    k_compression: kc.unwrap_or(k1),
                }),
                damping,
            ),
        }
    }

    /// All parameters finite and non-negative.
    pub fn is_valid(&self) -> bool {
        let v: Vec<f64> = match *self {
            LayerMaterial::Linear { k, damping } => vec![k, damping],
            LayerMaterial::Bilinear { k1, k2, turn_strain, kc, damping } => {
                vec![k1, k2, turn_strain, kc.unwrap_or(k1), damping]
            }
        };
        v.iter().all(|x| x.is_finite() && *x >= 0.0)
    }
}

/// Dimensions and materials of the layered block. Defaults: 24 × 12 nodes in plan,
/// 1 cm spacing, rows: 1 bone, 2 muscle, 2 fat, 1 skin; density 1000 kg/m³.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BlockSpec {
    /// Nodes along x.
    pub nx: usize,
    /// Nodes along z.
    pub nz: usize,
    /// Node spacing, m.
    pub spacing: f64,
    /// Node rows of muscle above the bone row.
    pub muscle_rows: usize,
    /// Node rows of fat.
    pub fat_rows: usize,
    /// Node rows of skin (top).
    pub skin_rows: usize,
    /// Tissue density, kg/m³: a node carries `density · spacing³`.
    pub density: f64,
    /// Skin springs.
    pub skin: LayerMaterial,
    /// Fat springs.
    pub fat: LayerMaterial,
    /// Muscle springs.
    pub muscle: LayerMaterial,
}

impl Default for BlockSpec {
    fn default() -> Self {
        Self {
            nx: 24,
            nz: 12,
            spacing: 0.01,
            muscle_rows: 2,
            fat_rows: 2,
            skin_rows: 1,
            density: 1000.0,
            skin: LayerMaterial::Bilinear { k1: 400.0, k2: 4000.0, turn_strain: 0.3, kc: None, damping: 0.02 },
            fat: LayerMaterial::Linear { k: 30.0, damping: 0.01 },
            muscle: LayerMaterial::Bilinear { k1: 150.0, k2: 1500.0, turn_strain: 0.4, kc: None, damping: 0.02 },
        }
    }
}

impl BlockSpec {
    /// Rows of nodes including the bone row (saturating: an overflowing row count is
    /// refused by [`check_size`](Self::check_size)).
    pub fn rows(&self) -> usize {
        1usize.saturating_add(self.muscle_rows).saturating_add(self.fat_rows).saturating_add(self.skin_rows)
    }

    /// Refuses a block whose node or spring count overflows `u32` indices, or whose run
    /// would need more memory than is available ([`RUN_MEMORY_FACTOR`] times the model);
    /// counts are computed without overflow (`nx = nz = 2^32` is refused, not wrapped).
    ///
    /// # Errors
    /// [`ModelSizeError`], naming the block's dimensions.
    pub fn check_size(&self) -> Result<(), ModelSizeError> {
        let rows = 1u64
            .checked_add(self.muscle_rows as u64)
            .and_then(|r| r.checked_add(self.fat_rows as u64))
            .and_then(|r| r.checked_add(self.skin_rows as u64));
        let what = format!("layered block {} x {} x {} nodes", self.nx, self.rows(), self.nz);
        let size = match rows {
            Some(rows) => lattice_model_size(self.nx as u64, rows, self.nz as u64),
            None => ModelSize::counted(None, None, None),
        };
        size.check(&what, RUN_MEMORY_FACTOR)
    }

    /// The block's model ([`layered_block`]) once [`check_size`](Self::check_size) has
    /// passed: a block too large for the indices or for the memory available is refused
    /// before any of it is allocated.
    ///
    /// # Errors
    /// [`ModelSizeError`], naming the block's dimensions, the estimate and the budget.
    pub fn checked_model(&self) -> Result<Model, ModelSizeError> {
        self.check_size()?;
        Ok(layered_block(self))
    }
}

/// Layer indices of the block's model.
const BONE: u16 = 0;
const MUSCLE: u16 = 1;
const FAT: u16 = 2;
const SKIN: u16 = 3;

/// Builds the block: node `(i, j, k)` at `(i, j, k) · spacing` with y up, index
/// `(j·nz + k)·nx + i`; row 0 is bone (fixed). A spring belongs to the layer of its upper
/// node's row. The top face is the `skin_outer` surface (a grid). Sizes are not checked
/// here: [`BlockSpec::checked_model`] refuses a block too large before building it.
pub fn layered_block(spec: &BlockSpec) -> Model {
    let (nx, ny, nz) = (spec.nx, spec.rows(), spec.nz);
    let mut model = Model { name: "layered-block".into(), ..Model::default() };
    for (name, tissue) in
        [("bone", Tissue::Bone), ("muscle", Tissue::Muscle), ("fat", Tissue::Fat), ("skin", Tissue::Skin)]
    {
        model.layers.push(Layer { name: name.into(), tissue });
    }
    let layer_of_row = |j: usize| -> u16 {
        if j == 0 {
            BONE
        } else if j <= spec.muscle_rows {
            MUSCLE
        } else if j <= spec.muscle_rows + spec.fat_rows {
            FAT
        } else {
            SKIN
        }
    };
    let h = spec.spacing;
    let mass = spec.density * h * h * h;
    let index = |i: usize, j: usize, k: usize| (j * nz + k) * nx + i;
    for j in 0..ny {
        for k in 0..nz {
            for i in 0..nx {
                let kind = if j == 0 { NodeKind::Fixed } else { NodeKind::Free };
                let id = model.nodes.push([i as f64 * h, j as f64 * h, k as f64 * h], mass, kind, layer_of_row(j));
                model.nodes.texcoord[id as usize] = [i as f32 / nx as f32, j as f32 / ny as f32, k as f32 / nz as f32];
            }
        }
    }
    for n in 0..nx * ny * nz {
        let (i, k, j) = ((n % nx) as i64, ((n / nx) % nz) as i64, (n / (nx * nz)) as i64);
        for (di, dj, dk) in OFFSETS {
            let (i2, j2, k2) = (i + di, j + dj, k + dk);
            if !(0..nx as i64).contains(&i2) || !(0..ny as i64).contains(&j2) || !(0..nz as i64).contains(&k2) {
                continue;
            }
            let m = index(i2 as usize, j2 as usize, k2 as usize);
            let (pa, pb) = (model.nodes.position[n], model.nodes.position[m]);
            let rest = ((pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2) + (pb[2] - pa[2]).powi(2)).sqrt();
            let layer = layer_of_row(j.max(j2) as usize);
            let material = match layer {
                SKIN => &spec.skin,
                FAT => &spec.fat,
                _ => &spec.muscle,
            };
            let (law, damping) = material.law(rest);
            model.springs.push(n as u32, m as u32, rest, law, damping, layer);
        }
    }
    // One hexahedron per lattice cube, in the layer of its upper row: bottom face at row j
    // counter-clockwise seen from above (+y), top face at row j + 1.
    for j in 0..ny - 1 {
        for k in 0..nz - 1 {
            for i in 0..nx - 1 {
                let face = |j: usize| [index(i, j, k), index(i, j, k + 1), index(i + 1, j, k + 1), index(i + 1, j, k)];
                let nodes: Vec<u32> = face(j).into_iter().chain(face(j + 1)).map(|n| n as u32).collect();
                let cell = Cell::new(CellKind::Hexahedron, layer_of_row(j + 1), &nodes);
                model.cells.extend(cell);
            }
        }
    }
    let top = ny - 1;
    let mut triangles = Vec::new();
    for k in 0..nz - 1 {
        for i in 0..nx - 1 {
            let (a, b, c, d) = (index(i, top, k), index(i + 1, top, k), index(i, top, k + 1), index(i + 1, top, k + 1));
            // Counter-clockwise seen from +y (outside).
            triangles.push([a as u32, c as u32, b as u32]);
            triangles.push([b as u32, c as u32, d as u32]);
        }
    }
    let grid = (0..nz).flat_map(|k| (0..nx).map(move |i| index(i, top, k) as u32)).collect();
    model.surfaces.push(Surface { name: "skin_outer".into(), triangles, grid: Some((nx as u32, nz as u32, grid)) });
    model.provenance.push(("generator".into(), format!("layered_block nx={nx} nz={nz} rows={ny} spacing={h}")));
    model
}
