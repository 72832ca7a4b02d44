//! A prefactored approximation of implicit Euler's matrix, applied as the preconditioner of
//! its conjugate-gradient solve.
//!
//! Implicit Euler solves `A Δv = b` with `A = c_m M + c_c C + c_k K(x)` (mass, dashpots,
//! tangent stiffness; `implicit.rs`). `K(x)` changes every step (directions, phases of the
//! bilinear springs, contacts), but its isotropic, soft-phase part does not:
//!
//! ```text
//! P = c_m M + Σ_springs (c_k k₁ + c_c c) (e_a − e_b)(e_a − e_b)ᵀ + Σ_tets c_k w_t (I − 11ᵀ/4)
//!     + Σ_handles (c_k k + c_c d) e_i e_iᵀ        (⊗ I₃, over free nodes)
//! ```
//!
//! is the graph Laplacian of the springs weighted by their first-phase stiffness (the
//! matrix of Liu et al.'s local/global solver), factored once by sparse Cholesky. As a
//! preconditioner it is exact for soft-phase motion along the springs and leaves the
//! conjugate gradients only what differs: directions, stiff phases, contacts. One or two
//! iterations then do what hundreds do with a diagonal preconditioner.

use super::dynamics::Dynamics;
use super::simd::SimdLevel;
use super::sparse_cholesky::{CholeskyFactor, FactorBuildError, FactorStorage, SolveScratch};
use super::vec3s::Vec3s;
use super::worker_pool::WorkerPool;
use crate::law::SpringLaw;
use crate::model::Model;
use crate::real::Real;

/// Marks a node that is not an unknown.
const HELD: u32 = u32::MAX;

/// `P⁻¹` for implicit Euler's system at one step size.
pub struct FactoredPreconditioner<T> {
    /// Per node: its row in factor order, or [`HELD`].
    row: Vec<u32>,
    /// Per node: `1/√P_ii`; the factor is of `S P S` (unit diagonal), so `P⁻¹ = S (S P S)⁻¹ S`.
    scale: Vec<T>,
    factor: CholeskyFactor<T>,
    scratch: SolveScratch<T>,
    work: Vec3s<T>,
}

impl<T: Real> FactoredPreconditioner<T> {
    /// Factors `P` for `model` under `dynamics`' effects with the coefficients of
    /// `c_m M + c_c C + c_k K`, stored as `storage` asks.
    pub fn new(
        model: &Model,
        dynamics: &Dynamics<T>,
        cm: f64,
        cc: f64,
        ck: f64,
        simd: SimdLevel,
        storage: FactorStorage,
    ) -> Result<Self, FactorBuildError> {
        let inputs = PreconditionerInputs::of(dynamics);
        Self::from_inputs(model, &inputs, cm, cc, ck, simd, storage)
    }

    /// [`FactoredPreconditioner::new`] from what it reads of the dynamics, which another
    /// thread can hold (a factor of a cut model built off the loop).
    pub(crate) fn from_inputs(
        model: &Model,
        inputs: &PreconditionerInputs,
        cm: f64,
        cc: f64,
        ck: f64,
        simd: SimdLevel,
        storage: FactorStorage,
    ) -> Result<Self, FactorBuildError> {
        let n = model.nodes.len();
        let mut row = vec![HELD; n];
        let mut m = 0u32;
        for (i, r) in row.iter_mut().enumerate() {
            if inputs.free[i] {
                *r = m;
                m += 1;
            }
        }
        let mut diag = vec![0.0f64; m as usize];
        for i in 0..n {
            if row[i] != HELD {
                diag[row[i] as usize] = cm * model.nodes.mass[i];
            }
        }
        let mut lower = Vec::new();
        let mut tie = |a: u32, b: u32, w: f64| {
            let (ra, rb) = (row[a as usize], row[b as usize]);
            for r in [ra, rb] {
                if r != HELD {
                    diag[r as usize] += w;
                }
            }
            if ra != HELD && rb != HELD && w != 0.0 {
                lower.push((ra.max(rb), ra.min(rb), -w));
            }
        };
        let s = &model.springs;
        let damping = inputs.spring_damping;
        for i in 0..s.len() {
            let k = match s.law[i] {
                SpringLaw::Linear { stiffness } => stiffness,
                SpringLaw::Bilinear(b) => b.k1,
            };
            let c = if damping { s.damping[i] } else { 0.0 };
            tie(s.a[i], s.b[i], ck * k + cc * c);
        }
        if let Some(k) = inputs.skin_volume_stiffness {
            let volume = &inputs.skin_volume;
            for (t, (tet, &v0)) in volume.tets.iter().zip(&volume.rest_volume).enumerate() {
                if !volume.is_intact(t) {
                    continue;
                }
                // The term's Gauss-Newton stiffness k/|V₀| ∇V ∇Vᵀ is bounded by
                // k/|V₀| |∇V|² times the projector onto centred displacements: the isotropic
                // centred Laplacian of that weight, which never underestimates it.
                let g2 = volume.rest_gradient_norm2(model, tet);
                let w = ck * k / v0.abs() * g2;
                for a in 0..4 {
                    for b in a + 1..4 {
                        tie(tet[a], tet[b], w / 4.0);
                    }
                }
            }
        }
        for hd in &inputs.handles {
            let r = row[hd.node as usize];
            if r != HELD {
                diag[r as usize] += ck * hd.stiffness + cc * hd.damping;
            }
        }
        // Scaled to a unit diagonal: the factor's entries then lie within [-1, 1], as binary16
        // storage needs (`CholeskyFactor` refuses an entry beyond its range).
        let inv_sqrt: Vec<f64> = diag.iter().map(|&d| 1.0 / d.sqrt()).collect();
        for (r, c, v) in lower.iter_mut() {
            *v *= inv_sqrt[*r as usize] * inv_sqrt[*c as usize];
        }
        lower.extend((0..m).map(|r| (r, r, 1.0)));
        let factor = if inputs.threads >= 2 {
            // Split at a plane across x, y or z, its two halves' sweeps on two threads.
            let keys = rest_coordinates(model, &row);
            CholeskyFactor::<T>::new_bisected(m as usize, &lower, &keys, simd, storage)?
        } else {
            CholeskyFactor::<T>::new(m as usize, &lower, simd, storage)?
        };
        let scale = row.iter().map(|&r| if r == HELD { T::ZERO } else { T::from_f64(inv_sqrt[r as usize]) }).collect();
        for r in row.iter_mut().filter(|r| **r != HELD) {
            *r = factor.position(*r as usize) as u32;
        }
        Ok(Self { row, scale, scratch: factor.scratch(), work: Vec3s::zeros(factor.rhs_len()), factor })
    }

    /// Stored entries of the factor.
    pub fn factor_entries(&self) -> usize {
        self.factor.stored_entries()
    }

    /// True when the triangular sweeps run on two threads.
    pub fn is_split(&self) -> bool {
        self.factor.is_split()
    }

    /// `z = P⁻¹ r` over free nodes (held nodes get 0), the sweeps on `pool`. Allocates
    /// nothing.
    pub fn apply(&mut self, pool: &WorkerPool, r: &Vec3s<T>, z: &mut Vec3s<T>) {
        {
            let [w0, w1, w2] = self.work.slices_mut();
            let [r0, r1, r2] = r.slices();
            for ((((&p, &s), &v0), &v1), &v2) in self.row.iter().zip(&self.scale).zip(r0).zip(r1).zip(r2) {
                if p != HELD {
                    let p = p as usize;
                    (w0[p], w1[p], w2[p]) = (s * v0, s * v1, s * v2);
                }
            }
        }
        self.factor.solve_in_place(self.work.slices_mut(), &mut self.scratch, pool);
        let [w0, w1, w2] = self.work.slices();
        let [z0, z1, z2] = z.slices_mut();
        let nodes = self.row.iter().zip(&self.scale);
        for ((((&p, &s), z0), z1), z2) in nodes.zip(z0.iter_mut()).zip(z1.iter_mut()).zip(z2.iter_mut()) {
            (*z0, *z1, *z2) = if p != HELD {
                let p = p as usize;
                (s * w0[p], s * w1[p], s * w2[p])
            } else {
                (T::ZERO, T::ZERO, T::ZERO)
            };
        }
    }
}

/// What the preconditioner reads of a simulation's dynamics, owned.
#[derive(Clone, Debug)]
pub(crate) struct PreconditionerInputs {
    /// Per node: whether it moves.
    pub free: Vec<bool>,
    /// Whether the springs' dashpots count.
    pub spring_damping: bool,
    /// The skin volume term's stiffness, Pa, when on.
    pub skin_volume_stiffness: Option<f64>,
    /// The skin's tetrahedra (a cut one has no volume term).
    pub skin_volume: super::skin_volume::SkinVolume,
    /// The drag handles.
    pub handles: Vec<super::effects::DragHandle>,
    /// Threads of the pool the sweeps run on.
    pub threads: usize,
}

impl PreconditionerInputs {
    pub(crate) fn of<T: Real>(dynamics: &Dynamics<T>) -> Self {
        Self {
            free: dynamics.free.iter().map(|f| *f != T::ZERO).collect(),
            spring_damping: dynamics.effects.spring_damping,
            skin_volume_stiffness: dynamics.effects.skin_volume,
            skin_volume: dynamics.skin_volume.clone(),
            handles: dynamics.effects.handles.clone(),
            threads: dynamics.pool.threads(),
        }
    }
}

/// Per axis, the free nodes' rest coordinates (in `row` order), m.
fn rest_coordinates(model: &Model, row: &[u32]) -> Vec<Vec<f64>> {
    (0..3)
        .map(|axis| (0..row.len()).filter(|&i| row[i] != HELD).map(|i| model.nodes.position[i][axis]).collect())
        .collect()
}
