//! The springs in the order the implicit solvers' per-spring kernels stream them.
//!
//! Springs are sorted into *runs* `(a0 + i, b0 + i)` of one material (the stiffnesses and
//! dashpot a run shares), so positions, velocities and per-spring results move as
//! unit-stride blocks of [`LANES`] lanes with no branch per spring. Runs bridge short gaps,
//! and are padded to whole blocks, with *null* springs (a lane mask zeroes whatever they
//! compute), so almost every spring is computed in a full block. A material is read once
//! per run; each spring streams only its rest and turning lengths and its mask.
//!
//! Springs between two held nodes move nothing and are left out; each worker thread takes
//! a share of the runs and accumulates into its own node-ordered window (no atomics).

use super::lane_block::LANES;
use super::vec3s::Vec3s;
use crate::law::SpringLaw;
use crate::model::SpringSet;
use crate::real::Real;

/// Longest gap of missing springs a run bridges with null springs. Default 8.
const MAX_GAP: usize = 8;

/// Springs `(a0 + i, b0 + i)`, `i < len`, whose data sit at `first + i`, of one material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// First node of the first spring.
    pub a0: u32,
    /// Second node of the first spring.
    pub b0: u32,
    /// Springs, null ones included.
    pub len: u32,
    /// Index of the first spring's data.
    pub first: u32,
    /// Index of the run's material.
    pub material: u32,
}

/// A spring law and dashpot shared by the springs of a run, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Compression stiffness, N/m.
    pub kc: f64,
    /// First-phase stiffness, N/m.
    pub k1: f64,
    /// Second-phase stiffness, N/m (`k1` for a linear spring).
    pub k2: f64,
    /// Dashpot, N·s/m (0 when the scene's spring damping is off).
    pub c: f64,
}

/// The springs with a free end, in run order.
#[derive(Clone, Debug)]
pub struct SpringRuns<T> {
    /// Runs, sorted by offset, material and first node.
    pub runs: Vec<Run>,
    /// Per worker: its range of runs.
    pub parts: Vec<std::ops::Range<usize>>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Per spring: rest length, m.
    pub rest: Vec<T>,
    /// Per spring: turning length, m (the rest length for a linear spring, whose phases are
    /// one line).
    pub turn: Vec<T>,
    /// Per spring: 1 for a real spring, 0 for a null one or one that was cut.
    pub real: Vec<u8>,
    /// Per model spring (file order): the index of its data, or [`LEFT_OUT`] for a spring
    /// between two held nodes.
    pub slot: Vec<u32>,
}

/// [`SpringRuns::slot`] of a spring the runs leave out (both its nodes held).
pub const LEFT_OUT: u32 = u32::MAX;

/// `law`'s material and turning length.
fn material_of(law: SpringLaw, rest: f64, c: f64) -> (Material, f64) {
    match law {
        SpringLaw::Linear { stiffness: k } => (Material { kc: k, k1: k, k2: k, c }, rest),
        SpringLaw::Bilinear(b) => (Material { kc: b.k_compression, k1: b.k1, k2: b.k2, c }, b.turn_length),
    }
}

impl<T: Real> SpringRuns<T> {
    /// The springs of `springs` with at least one free end (`free[i]`), cut into `threads`
    /// parts of equal length; dashpots are kept when `spring_damping`.
    pub fn new(springs: &SpringSet, free: &[bool], spring_damping: bool, threads: usize) -> Self {
        let n = free.len();
        let mut materials: Vec<Material> = Vec::new();
        // (offset, material, a, spring) of every kept spring.
        let mut order: Vec<(i64, u32, u32, u32)> = Vec::with_capacity(springs.len());
        for s in 0..springs.len() {
            let (a, b) = (springs.a[s], springs.b[s]);
            if !free[a as usize] && !free[b as usize] {
                continue;
            }
            let c = if spring_damping { springs.damping[s] } else { 0.0 };
            let (m, _) = material_of(springs.law[s], springs.rest_length[s], c);
            let bits = |m: &Material| [m.kc, m.k1, m.k2, m.c].map(f64::to_bits);
            let id = match materials.iter().position(|x| bits(x) == bits(&m)) {
                Some(i) => i,
                None => {
                    materials.push(m);
                    materials.len() - 1
                }
            } as u32;
            order.push((b as i64 - a as i64, id, a, s as u32));
        }
        order.sort_unstable();
        let mut out = Self {
            runs: Vec::new(),
            parts: Vec::new(),
            materials,
            rest: Vec::with_capacity(order.len()),
            turn: Vec::with_capacity(order.len()),
            real: Vec::with_capacity(order.len()),
            slot: vec![LEFT_OUT; springs.len()],
        };
        // A null spring at first node `a` with offset `off` exists if both its nodes do.
        let fits = |a: usize, off: i64| a < n && (a as i64 + off) >= 0 && ((a as i64 + off) as usize) < n;
        let mut k = 0;
        while k < order.len() {
            let (off, material, a0, _) = order[k];
            let b0 = (a0 as i64 + off) as u32;
            let first = out.rest.len();
            let mut next = a0 as usize;
            while k < order.len() && order[k].0 == off && order[k].1 == material {
                let (_, _, a, s) = order[k];
                match (a as usize).checked_sub(next) {
                    Some(g) if g <= MAX_GAP && (next..a as usize).all(|x| fits(x, off)) => {
                        (0..g).for_each(|_| out.push_null());
                    }
                    _ => break,
                }
                let s = s as usize;
                let (_, turn) = material_of(springs.law[s], springs.rest_length[s], 0.0);
                let rest = springs.rest_length[s];
                out.rest.push(T::from_f64(rest));
                out.turn.push(T::from_f64(if turn.is_finite() { turn } else { rest }));
                out.slot[s] = out.real.len() as u32;
                out.real.push(1);
                next = a as usize + 1;
                k += 1;
            }
            while !(out.rest.len() - first).is_multiple_of(LANES) && fits(next, off) {
                out.push_null();
                next += 1;
            }
            let len = (out.rest.len() - first) as u32;
            out.runs.push(Run { a0, b0, len, first: first as u32, material });
        }
        let threads = threads.max(1);
        let total = out.rest.len().max(1);
        let (mut start, mut done) = (0usize, 0usize);
        for (i, r) in out.runs.iter().enumerate() {
            done += r.len as usize;
            if out.parts.len() + 1 < threads && done * threads >= total * (out.parts.len() + 1) {
                out.parts.push(start..i + 1);
                start = i + 1;
            }
        }
        out.parts.push(start..out.runs.len());
        while out.parts.len() < threads {
            out.parts.push(out.runs.len()..out.runs.len());
        }
        out
    }

    fn push_null(&mut self) {
        self.rest.push(T::ONE);
        self.turn.push(T::ONE);
        self.real.push(0);
    }

    /// Takes model spring `s` out of the runs (its lane mask zeroed: no force, no tangent);
    /// returns whether it was in them and not cut before. Allocates nothing.
    pub fn cut(&mut self, s: usize) -> bool {
        match self.slot.get(s) {
            Some(&k) if k != LEFT_OUT && self.real[k as usize] == 1 => {
                self.real[k as usize] = 0;
                true
            }
            _ => false,
        }
    }

    /// Springs computed per pass, null springs included.
    pub fn padded_len(&self) -> usize {
        self.rest.len()
    }

    /// One node-ordered window per worker, for `n` nodes.
    pub fn windows(&self, n: usize) -> Vec<Vec3s<T>> {
        (0..self.parts.len()).map(|_| Vec3s::zeros(n)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_cover_every_spring_once_and_bridge_gaps_with_null_springs_works() {
        // A ring of 20 nodes with springs (i, i+1) missing one, and (i, i+3), plus springs
        // between held nodes 0 and 1 (left out).
        let mut s = SpringSet::default();
        for i in 0..19u32 {
            if i != 7 {
                s.push(i, i + 1, 0.01, SpringLaw::Linear { stiffness: 10.0 }, 0.0, 0);
            }
        }
        for i in 2..17u32 {
            s.push(i, i + 3, 0.03, SpringLaw::Linear { stiffness: 5.0 }, 0.0, 0);
        }
        let free: Vec<bool> = (0..20).map(|i| i >= 2).collect();
        let runs = SpringRuns::<f64>::new(&s, &free, false, 2);
        // Spring (0, 1) has no free end.
        assert_eq!(runs.real.iter().filter(|&&r| r == 1).count(), s.len() - 1);
        let mut covered = vec![0u32; s.len()];
        for r in &runs.runs {
            for i in 0..r.len {
                let k = (r.first + i) as usize;
                if runs.real[k] == 1 {
                    let (a, b) = (r.a0 + i, r.b0 + i);
                    let idx = (0..s.len()).find(|&j| s.a[j] == a && s.b[j] == b).expect("a model spring");
                    covered[idx] += 1;
                    assert_eq!(runs.rest[k], s.rest_length[idx]);
                    assert_eq!(runs.slot[idx] as usize, k);
                }
            }
        }
        assert_eq!(covered.iter().filter(|&&c| c == 1).count(), s.len() - 1);
        assert!(covered.iter().all(|&c| c <= 1));
        // The gap at (7, 8) is bridged: offset 1 is one run from node 1 on.
        assert_eq!(runs.runs.iter().filter(|r| r.b0 == r.a0 + 1).count(), 1);
        assert_eq!(runs.parts.len(), 2);
    }
}
