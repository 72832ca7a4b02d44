//! The yardstick's plain-C baseline (`cli/yardstick_c/lattice.c`), compiled by `build.rs`
//! with `-O3 -march=native` (and `-fopenmp`): the specification's loop in plain C (node
//! triples, per-spring arrays), one thread, and an OpenMP version (per-thread force buffers, reduced per node). When
//! the build found no working C compiler (or no OpenMP), [`CStepper::new`] says why and the
//! bench skips those rows.

use lamina_core::model::{Model, NodeKind};
use lamina_core::yardstick;

#[cfg(lamina_yardstick_c)]
mod ffi {
    use std::ffi::c_int;

    /// `yardstick_c_state` of lattice.c, field for field.
    #[repr(C)]
    pub struct State {
        pub nodes: c_int,
        pub springs: c_int,
        pub a: *const c_int,
        pub b: *const c_int,
        pub k: *const f32,
        pub rest: *const f32,
        pub c: *const f32,
        pub fixed: *const u8,
        pub x: *mut [f32; 3],
        pub v: *mut [f32; 3],
        pub f: *mut [f32; 3],
        pub mass: f32,
        pub gy: f32,
        pub dt: f32,
    }

    unsafe extern "C" {
        pub fn yardstick_c_step(s: *mut State);
        pub fn yardstick_c_step_omp(s: *mut State, threads: c_int, buffers: *mut f32);
        pub fn yardstick_c_has_openmp() -> c_int;
    }
}

/// Whether this binary carries the C baseline and its OpenMP version: `Err` names what is
/// missing.
pub fn available(threads: usize) -> Result<(), String> {
    #[cfg(lamina_yardstick_c)]
    {
        // SAFETY: a plain query of the C library, no arguments.
        if threads > 1 && unsafe { ffi::yardstick_c_has_openmp() } == 0 {
            return Err("the C baseline was built without OpenMP (-fopenmp failed at build time)".into());
        }
        Ok(())
    }
    #[cfg(not(lamina_yardstick_c))]
    {
        let _ = threads;
        Err("no working C compiler when this binary was built: no C baseline".into())
    }
}

/// The C baseline's arrays (owned here) and its step.
pub struct CStepper {
    a: Vec<i32>,
    b: Vec<i32>,
    k: Vec<f32>,
    rest: Vec<f32>,
    c: Vec<f32>,
    fixed: Vec<u8>,
    /// Positions, m.
    pub x: Vec<[f32; 3]>,
    v: Vec<[f32; 3]>,
    f: Vec<[f32; 3]>,
    buffers: Vec<f32>,
    threads: usize,
    mass: f32,
}

impl CStepper {
    /// The yardstick `model` (linear springs, one node mass) stepped by C on `threads`
    /// threads (1: the plain loop; more: the OpenMP version).
    ///
    /// # Errors
    /// The C baseline is not in this binary ([`available`]), or the model is not a
    /// yardstick lattice (a spring not linear, unequal masses, too many nodes for C `int`).
    pub fn new(model: &Model, threads: usize) -> Result<Self, String> {
        available(threads)?;
        let n = model.nodes.len();
        let s = &model.springs;
        if n > i32::MAX as usize / 3 || s.len() > i32::MAX as usize {
            return Err(format!("{} nodes and {} springs are too many for the C baseline's int indices", n, s.len()));
        }
        let mass = model.nodes.mass.first().copied().ok_or("the C baseline needs nodes")?;
        if model.nodes.mass.iter().any(|&m| m != mass) {
            return Err("the C baseline takes one node mass; this model's masses differ".into());
        }
        let k = s
            .law
            .iter()
            .map(|l| match l {
                lamina_core::law::SpringLaw::Linear { stiffness } => Ok(*stiffness as f32),
                _ => Err("the C baseline takes linear springs only".to_string()),
            })
            .collect::<Result<Vec<f32>, String>>()?;
        Ok(Self {
            a: s.a.iter().map(|&a| a as i32).collect(),
            b: s.b.iter().map(|&b| b as i32).collect(),
            k,
            rest: s.rest_length.iter().map(|&r| r as f32).collect(),
            c: s.damping.iter().map(|&c| c as f32).collect(),
            fixed: model.nodes.kind.iter().map(|k| u8::from(*k != NodeKind::Free)).collect(),
            x: model.nodes.position.iter().map(|p| p.map(|c| c as f32)).collect(),
            v: vec![[0.0; 3]; n],
            f: vec![[0.0; 3]; n],
            buffers: if threads > 1 { vec![0.0; 3 * n * threads] } else { Vec::new() },
            threads: threads.max(1),
            mass: mass as f32,
        })
    }

    /// One step of the specification: clear forces, springs in order, integrate.
    pub fn step(&mut self) {
        #[cfg(lamina_yardstick_c)]
        {
            let mut state = ffi::State {
                nodes: self.x.len() as i32,
                springs: self.a.len() as i32,
                a: self.a.as_ptr(),
                b: self.b.as_ptr(),
                k: self.k.as_ptr(),
                rest: self.rest.as_ptr(),
                c: self.c.as_ptr(),
                fixed: self.fixed.as_ptr(),
                x: self.x.as_mut_ptr(),
                v: self.v.as_mut_ptr(),
                f: self.f.as_mut_ptr(),
                mass: self.mass,
                gy: yardstick::GRAVITY[1] as f32,
                dt: yardstick::DT as f32,
            };
            // SAFETY: every pointer is to a live Vec of the length the C code indexes: node
            // arrays have `nodes` entries, spring arrays `springs`, indices were taken from a
            // valid model (< nodes), and `buffers` has 3·nodes·threads floats.
            unsafe {
                if self.threads > 1 {
                    ffi::yardstick_c_step_omp(&mut state, self.threads as i32, self.buffers.as_mut_ptr());
                } else {
                    ffi::yardstick_c_step(&mut state);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_core::yardstick::{LatticeSize, ReferenceStepper};

    /// After 1000 steps of the small size, C (one thread and OpenMP on two) and the Rust
    /// scalar reference agree to f32 round-off: the same operations in the same order on
    /// one thread (so only the compilers' contraction choices may differ), a different
    /// summation order of a node's forces on two.
    #[test]
    fn yardstick_c_matches_rust_reference_works() {
        if let Err(why) = available(2) {
            eprintln!("skipped: {why}");
            return;
        }
        let model = yardstick::lattice_model(LatticeSize::SMALL);
        let mut r = ReferenceStepper::<f32>::new(&model, yardstick::GRAVITY, yardstick::DT).unwrap();
        let mut c1 = CStepper::new(&model, 1).unwrap();
        let mut c2 = CStepper::new(&model, 2).unwrap();
        for _ in 0..1000 {
            r.step();
            c1.step();
            c2.step();
        }
        let want = yardstick::checksum(&model, |i| r.x[i].map(|c| c as f64));
        for c in [&c1, &c2] {
            let got = yardstick::checksum(&model, |i| c.x[i].map(f64::from));
            // 1e-5 relative: the summation order differs on two threads, and gcc contracts
            // a·b + c into fused multiply-adds (its default for GNU C), rounding once less.
            assert!((got.sum_uy - want.sum_uy).abs() <= 1e-5 * want.sum_uy.abs(), "{got:?} vs {want:?}");
            assert!((got.max_u - want.max_u).abs() <= 1e-5 * want.max_u, "{got:?} vs {want:?}");
            assert!((got.rms_u - want.rms_u).abs() <= 1e-5 * want.rms_u, "{got:?} vs {want:?}");
            assert!(want.sum_uy < -0.5, "the block sags under gravity: {want:?}");
        }
    }
}
