//! The lattice, node by node and spring by spring, as the specification lists them.

use crate::law::SpringLaw;
use crate::model::{Layer, Model, ModelSize, ModelSizeError, NodeKind, RUN_MEMORY_FACTOR, Tissue};

/// Lattice spacing, m.
pub const SPACING: f64 = 0.01;
/// Node mass, kg.
pub const NODE_MASS: f64 = 1.0e-3;
/// Dashpot of every spring, N·s/m.
pub const SPRING_DAMPING: f64 = 0.02;
/// Stiffness of skin, fat and muscle springs, N/m.
pub const STIFFNESS_SKIN: f64 = 400.0;
/// Fat spring stiffness, N/m.
pub const STIFFNESS_FAT: f64 = 50.0;
/// Muscle spring stiffness, N/m.
pub const STIFFNESS_MUSCLE: f64 = 150.0;

/// Forward neighbour offsets `(di, dj, dk)`, in the specification's order.
pub const OFFSETS: [(i64, i64, i64); 9] =
    [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, -1, 0), (1, 0, 1), (1, 0, -1), (0, 1, 1), (0, 1, -1)];

/// Lattice dimensions: `nx × ny × nz` nodes, y vertical.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LatticeSize {
    /// Nodes along x.
    pub nx: usize,
    /// Node rows along y (vertical).
    pub ny: usize,
    /// Nodes along z.
    pub nz: usize,
}

impl LatticeSize {
    /// 39 × 7 × 10: 2,730 nodes, 21,017 springs.
    pub const SMALL: Self = Self { nx: 39, ny: 7, nz: 10 };
    /// 60 × 10 × 50: 30,000 nodes, 249,740 springs.
    pub const MEDIUM: Self = Self { nx: 60, ny: 10, nz: 50 };
    /// 100 × 25 × 100: 250,000 nodes, 2,175,450 springs.
    pub const LARGE: Self = Self { nx: 100, ny: 25, nz: 100 };

    /// `small`, `medium`, `large`, or `NXxNYxNZ`.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "small" => Some(Self::SMALL),
            "medium" => Some(Self::MEDIUM),
            "large" => Some(Self::LARGE),
            _ => {
                let dims: Vec<usize> = name.split('x').map(|d| d.parse().ok()).collect::<Option<_>>()?;
                match dims[..] {
                    [nx, ny, nz] if nx >= 1 && ny >= 1 && nz >= 1 => Some(Self { nx, ny, nz }),
                    _ => None,
                }
            }
        }
    }

    /// The name it was given: `small`, `medium`, `large`, or `NXxNYxNZ`.
    pub fn name(&self) -> String {
        match *self {
            Self::SMALL => "small".into(),
            Self::MEDIUM => "medium".into(),
            Self::LARGE => "large".into(),
            Self { nx, ny, nz } => format!("{nx}x{ny}x{nz}"),
        }
    }

    /// Number of nodes (saturating at `usize::MAX`: [`check`](Self::check) refuses such a
    /// lattice).
    pub fn nodes(&self) -> usize {
        self.nx.saturating_mul(self.ny).saturating_mul(self.nz)
    }

    /// Node index of `(i, j, k)`: x fastest, then z, then y.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (j * self.nz + k) * self.nx + i
    }
}

/// Counts of a lattice of `nx × ny × nz` nodes with the `OFFSETS` springs (the yardstick
/// and the layered block), without overflow: nodes, springs by [`spring_count`]'s closed
/// form, and `2·nx·nz` surface triangles at most.
pub fn lattice_model_size(nx: u64, ny: u64, nz: u64) -> ModelSize {
    let nodes = nx.checked_mul(ny).and_then(|n| n.checked_mul(nz));
    let (xm, ym, zm) = (nx.saturating_sub(1), ny.saturating_sub(1), nz.saturating_sub(1));
    let product = |a: u64, b: u64, c: u64| a.checked_mul(b).and_then(|p| p.checked_mul(c));
    let springs = [
        product(xm, ny, nz),
        product(nx, ym, nz),
        product(nx, ny, zm),
        product(xm, ym, nz).and_then(|p| p.checked_mul(2)),
        product(xm, ny, zm).and_then(|p| p.checked_mul(2)),
        product(nx, ym, zm).and_then(|p| p.checked_mul(2)),
    ]
    .into_iter()
    .try_fold(0u64, |sum, t| t.and_then(|t| sum.checked_add(t)));
    ModelSize::counted(nodes, springs, product(2, nx, nz))
}

impl LatticeSize {
    /// Refuses a lattice whose counts overflow `u32` indices or whose run would need more
    /// memory than is available ([`RUN_MEMORY_FACTOR`] times the model).
    ///
    /// # Errors
    /// [`ModelSizeError`], naming the size.
    pub fn check(&self) -> Result<(), ModelSizeError> {
        lattice_model_size(self.nx as u64, self.ny as u64, self.nz as u64)
            .check(&format!("yardstick lattice {}", self.name()), RUN_MEMORY_FACTOR)
    }

    /// The yardstick model ([`lattice_model`]) once [`check`](Self::check) has passed: a
    /// lattice too large for the indices or for the memory available is refused before any
    /// of it is allocated.
    ///
    /// # Errors
    /// [`ModelSizeError`], naming the size, the estimate and the budget.
    pub fn checked_model(&self) -> Result<Model, ModelSizeError> {
        self.check()?;
        Ok(lattice_model(*self))
    }
}

/// Spring count by the specification's closed form.
pub fn spring_count(s: LatticeSize) -> usize {
    let (x, y, z) = (s.nx, s.ny, s.nz);
    let (xm, ym, zm) = (x.saturating_sub(1), y.saturating_sub(1), z.saturating_sub(1));
    xm * y * z + x * ym * z + x * y * zm + 2 * (xm * ym * z + xm * y * zm + x * ym * zm)
}

/// The yardstick model: nodes in index order, springs in the specification's order.
/// Layers: 0 muscle, 1 fat, 2 skin (by row, as the stiffness rule). Sizes are not checked
/// here: [`LatticeSize::checked_model`] refuses a lattice too large before building it.
pub fn lattice_model(size: LatticeSize) -> Model {
    let mut model = Model { name: format!("yardstick-{}", size.name()), ..Model::default() };
    for (name, tissue) in [("muscle", Tissue::Muscle), ("fat", Tissue::Fat), ("skin", Tissue::Skin)] {
        model.layers.push(Layer { name: name.into(), tissue });
    }
    let layer_of_row = |j: usize| -> u16 {
        if j == size.ny - 1 {
            2
        } else if j >= size.ny / 2 {
            1
        } else {
            0
        }
    };
    for j in 0..size.ny {
        for k in 0..size.nz {
            for i in 0..size.nx {
                let kind = if j == 0 { NodeKind::Fixed } else { NodeKind::Free };
                let p = [i as f64 * SPACING, j as f64 * SPACING, k as f64 * SPACING];
                model.nodes.push(p, NODE_MASS, kind, layer_of_row(j));
            }
        }
    }
    let (nx, ny, nz) = (size.nx as i64, size.ny as i64, size.nz as i64);
    for n in 0..size.nodes() {
        let i = (n % size.nx) as i64;
        let k = ((n / size.nx) % size.nz) as i64;
        let j = (n / (size.nx * size.nz)) as i64;
        for (di, dj, dk) in OFFSETS {
            let (i2, j2, k2) = (i + di, j + dj, k + dk);
            if !(0..nx).contains(&i2) || !(0..ny).contains(&j2) || !(0..nz).contains(&k2) {
                continue;
            }
            let m = size.index(i2 as usize, j2 as usize, k2 as usize);
            let (pa, pb) = (model.nodes.position[n], model.nodes.position[m]);
            let rest = ((pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2) + (pb[2] - pa[2]).powi(2)).sqrt();
            let jt = j.max(j2) as usize;
            let layer = layer_of_row(jt);
            let stiffness = [STIFFNESS_MUSCLE, STIFFNESS_FAT, STIFFNESS_SKIN][layer as usize];
            model.springs.push(n as u32, m as u32, rest, SpringLaw::Linear { stiffness }, SPRING_DAMPING, layer);
        }
    }
    model.provenance.push(("scene".into(), "docs/yardstick-scene.md".into()));
    model
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_counts_match_specification_table_works() {
        for (size, nodes, springs) in [
            (LatticeSize::SMALL, 2_730, 21_017),
            (LatticeSize::MEDIUM, 30_000, 249_740),
            (LatticeSize::LARGE, 250_000, 2_175_450),
        ] {
            assert_eq!(size.nodes(), nodes);
            assert_eq!(spring_count(size), springs);
        }
        let m = lattice_model(LatticeSize::SMALL);
        assert_eq!(m.springs.len(), 21_017);
        m.validate().unwrap();
    }

    #[test]
    fn lattice_spring_order_and_stiffness_follow_specification_works() {
        let s = LatticeSize { nx: 3, ny: 4, nz: 2 };
        let m = lattice_model(s);
        // Node 0 = (0,0,0): (1,0,0) -> 1, (0,1,0) -> idx(0,1,0), (0,0,1) -> idx(0,0,1),
        // (1,1,0) -> idx(1,1,0); (1,-1,0) outside; (1,0,1) -> idx(1,0,1); (1,0,-1) outside;
        // (0,1,1) -> idx(0,1,1); (0,1,-1) outside.
        let expect = [
            s.index(1, 0, 0),
            s.index(0, 1, 0),
            s.index(0, 0, 1),
            s.index(1, 1, 0),
            s.index(1, 0, 1),
            s.index(0, 1, 1),
        ];
        for (q, &b) in expect.iter().enumerate() {
            assert_eq!((m.springs.a[q], m.springs.b[q] as usize), (0, b));
        }
        assert!((m.springs.rest_length[3] - (2.0f64).sqrt() * 0.01).abs() < 1e-17);
        // Top row NY-1 = 3 is skin; NY/2 = 2 <= jt < 3 fat; below muscle.
        for q in 0..m.springs.len() {
            let jt = [m.springs.a[q], m.springs.b[q]].iter().map(|&n| n as usize / (s.nx * s.nz)).max().unwrap();
            let k = match m.springs.law[q] {
                SpringLaw::Linear { stiffness } => stiffness,
                _ => unreachable!(),
            };
            let want = if jt == 3 {
                400.0
            } else if jt >= 2 {
                50.0
            } else {
                150.0
            };
            assert_eq!(k, want);
        }
        assert_eq!(m.nodes.kind.iter().filter(|k| **k == NodeKind::Fixed).count(), s.nx * s.nz);
    }
}
