//! A prefactored sparse symmetric positive definite matrix, solved for three right-hand
//! sides at once (the x, y and z components of every node).
//!
//! The fill-reducing ordering (approximate minimum degree) and the numeric supernodal
//! Cholesky factorisation come from faer, in `f64`, once. The factor is then repacked for
//! the real-time solve, in the solve's precision or as binary16 ([`FactorStorage`]). Each
//! supernode (a dense block of columns) becomes four matrix-vector products: the inverse of
//! its triangular diagonal block and its rows below, each stored once for the forward sweep
//! and once transposed for the backward sweep. Each product is
//! packed in *tiles* of at most [`TILE`] outputs: a tile's coefficients lie input after
//! input in memory, so the sweep streams the factor front to back while a tile's sums stay
//! in registers, for the three right-hand sides at once. Triangular blocks store only their
//! non-zero tiles. Nothing allocates; the arithmetic is written once over [`Block`], so the
//! baseline and AVX builds give the same bits.
//!
//! Rows are addressed in factor order: [`CholeskyFactor::position`] maps a matrix row to
//! its place in the right-hand side, so callers assemble straight into solve order.

use crate::real::Real;
use crate::solver::bisected_ordering::bisect;
use crate::solver::disjoint::DisjointSlice;
use crate::solver::lane_block::{Block, LANES, ScalarBlock, f16_from_f64};
use crate::solver::simd::SimdLevel;
use crate::solver::worker_pool::WorkerPool;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Par, Side};

/// Outputs per tile: two lane blocks, whose sums for three right-hand sides fill six
/// registers.
pub const TILE: usize = 2 * LANES;

/// Why a matrix could not be factored.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FactorBuildError {
    /// An entry names a row or column outside the matrix, or is not finite.
    #[error("matrix entry ({row}, {col}) is out of range or not finite")]
    BadEntry {
        /// Row.
        row: u32,
        /// Column.
        col: u32,
    },
    /// The matrix is not numerically positive definite.
    #[error("the system matrix is not positive definite")]
    NotPositiveDefinite,
    /// A factor entry lies beyond the range of the storage asked for (binary16: 65,504).
    #[error("a factor entry lies beyond the range of its storage (binary16: 65,504)")]
    BeyondStorage,
    /// The sparse factorisation failed (out of memory or index overflow).
    #[error("sparse Cholesky factorisation failed: {0}")]
    Factorisation(String),
}

/// How the factor's coefficients are stored for the solve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FactorStorage {
    /// In the solve's precision `T`.
    #[default]
    Full,
    /// As IEEE binary16 (2 bytes each, 11 significant bits), widened to `T` in registers: half
    /// the bytes of `f32`, so a sweep that streams a factor larger than the caches takes about
    /// half the memory traffic. Meant for matrices scaled to a unit diagonal, whose factor
    /// entries lie within binary16's range (up to 65,504); a factor with an entry beyond it is
    /// refused when the factor is built.
    Half,
}

impl FactorStorage {
    /// Both storages.
    pub const ALL: [FactorStorage; 2] = [FactorStorage::Full, FactorStorage::Half];

    /// The scene file's name for it (`[solver] factor_storage`): `"full"` or `"f16"`.
    ///
    /// # Examples
    ///
    /// ```
    /// use lamina_core::solver::FactorStorage;
    ///
    /// assert_eq!(FactorStorage::parse("f16"), Some(FactorStorage::Half));
    /// assert_eq!(FactorStorage::Half.name(), "f16");
    /// assert_eq!(FactorStorage::parse("f8"), None);
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            FactorStorage::Full => "full",
            FactorStorage::Half => "f16",
        }
    }

    /// Parses [`FactorStorage::name`]'s output.
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// The packed coefficients, in the precision [`FactorStorage`] asks.
#[derive(Clone, Debug)]
enum Coefficients<T> {
    Full(Vec<T>),
    /// binary16 bits.
    Half(Vec<u16>),
}

impl<T: Real> Coefficients<T> {
    fn new(storage: FactorStorage) -> Self {
        match storage {
            FactorStorage::Full => Self::Full(Vec::new()),
            FactorStorage::Half => Self::Half(Vec::new()),
        }
    }

    fn len(&self) -> usize {
        match self {
            Self::Full(v) => v.len(),
            Self::Half(v) => v.len(),
        }
    }

    fn extend(&mut self, values: impl Iterator<Item = f64>) {
        match self {
            Self::Full(v) => v.extend(values.map(T::from_f64)),
            Self::Half(v) => v.extend(values.map(f16_from_f64)),
        }
    }

    /// True when every coefficient stored from `start` on is finite (a binary16 beyond
    /// 65,504 is infinite).
    fn all_finite_from(&self, start: usize) -> bool {
        match self {
            Self::Full(v) => v[start..].iter().all(|x| x.is_finite()),
            Self::Half(v) => v[start..].iter().all(|&h| h & 0x7c00 != 0x7c00),
        }
    }
}

/// Where a product's kernel reads its coefficients, a lane block at a time.
trait CoefficientSource<T: Real>: Copy {
    fn block<B: Block<T>>(self, at: usize) -> B;
}

/// Coefficients in `T`.
#[derive(Clone, Copy)]
struct FullValues<'a, T>(&'a [T]);

impl<T: Real> CoefficientSource<T> for FullValues<'_, T> {
    #[inline(always)]
    fn block<B: Block<T>>(self, at: usize) -> B {
        B::load(self.0, at)
    }
}

/// Coefficients as binary16 bits.
#[derive(Clone, Copy)]
struct HalfValues<'a>(&'a [u16]);

impl<T: Real> CoefficientSource<T> for HalfValues<'_> {
    #[inline(always)]
    fn block<B: Block<T>>(self, at: usize) -> B {
        B::load_f16(self.0, at)
    }
}

/// Which inputs of a packed product can be non-zero for a given output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    /// Every input.
    Full,
    /// Inputs `j ≤ i` for output `i` (a lower-triangular block).
    Lower,
    /// Inputs `j ≥ i` for output `i` (an upper-triangular block).
    Upper,
}

/// A matrix-vector product `y = M x` packed tile by tile at `values[start..]`.
#[derive(Clone, Copy, Debug)]
struct Packed {
    start: usize,
    outputs: u32,
    inputs: u32,
    shape: Shape,
}

impl Packed {
    /// Inputs tile `o0..o0 + h` reads.
    #[inline(always)]
    fn inputs_of(&self, o0: usize, h: usize) -> std::ops::Range<usize> {
        let n = self.inputs as usize;
        match self.shape {
            Shape::Full => 0..n,
            Shape::Lower => 0..(o0 + h).min(n),
            Shape::Upper => o0.min(n)..n,
        }
    }

    /// Appends `m(i, j)` (output `i`, input `j`) packed, and describes it.
    fn pack<T: Real>(
        values: &mut Coefficients<T>,
        outputs: usize,
        inputs: usize,
        shape: Shape,
        m: impl Fn(usize, usize) -> f64,
    ) -> Self {
        let packed = Self { start: values.len(), outputs: outputs as u32, inputs: inputs as u32, shape };
        let padded = outputs.div_ceil(LANES) * LANES;
        let mut o0 = 0;
        while o0 < padded {
            let h = (padded - o0).min(TILE);
            for j in packed.inputs_of(o0, h) {
                values.extend((o0..o0 + h).map(|i| if i < outputs { m(i, j) } else { 0.0 }));
            }
            o0 += h;
        }
        packed
    }
}

/// One supernode of the repacked factor.
#[derive(Clone, Copy, Debug)]
struct Supernode {
    /// First column (factor order).
    first: u32,
    /// Number of columns.
    width: u32,
    /// Its off-diagonal row indices: `pattern[pattern_start..pattern_start + rows]`.
    pattern_start: u32,
    /// Number of off-diagonal rows.
    rows: u32,
    /// `D⁻¹` (forward), `L_below` (forward), `L_belowᵀ` (backward), `D⁻ᵀ` (backward).
    inverse: Packed,
    below: Packed,
    below_t: Packed,
    inverse_t: Packed,
}

/// Scratch of one solve, sized once for its factor: one per half of a split factor.
#[derive(Clone, Debug)]
pub struct SolveScratch<T> {
    parts: [SweepScratch<T>; 2],
}

/// Scratch of one thread's sweeps.
#[derive(Clone, Debug)]
struct SweepScratch<T> {
    /// Per component: a product's input.
    input: [Vec<T>; 3],
    /// Per component: a product's output.
    output: [Vec<T>; 3],
}

/// Where the halves of a split factor lie (see [`CholeskyFactor::new_bisected`]).
#[derive(Clone, Copy, Debug)]
struct Split {
    /// A's supernodes are `..a_end`, B's `a_end..b_end`, the separator's `b_end..`.
    a_end: usize,
    b_end: usize,
    /// Rows in the separator; their copy for B's half is at positions `..separator`.
    separator: usize,
    /// B's half addresses positions `..boundary`, A's half `boundary..` (separator first).
    boundary: usize,
}

/// `A = L Lᵀ` of a sparse SPD matrix, ready to solve `A X = B` for three right-hand sides.
#[derive(Clone, Debug)]
pub struct CholeskyFactor<T> {
    /// Right-hand side length: `n`, plus the separator's copy when split.
    len: usize,
    /// `position[row]`: where matrix row `row` sits in factor order.
    position: Vec<u32>,
    supernodes: Vec<Supernode>,
    pattern: Vec<u32>,
    values: Coefficients<T>,
    /// Largest product dimension, padded to whole lane blocks.
    longest: usize,
    simd: SimdLevel,
    split: Option<Split>,
}

impl<T: Real> CholeskyFactor<T> {
    /// Factors the `n × n` symmetric matrix given by its lower-triangle entries
    /// `(row, col, value)` with `row ≥ col` (duplicates are summed); solves run with the
    /// kernels of `simd` (lowered to what the CPU has), on one thread, reading coefficients
    /// stored as `storage` asks.
    pub fn new(
        n: usize,
        lower: &[(u32, u32, f64)],
        simd: SimdLevel,
        storage: FactorStorage,
    ) -> Result<Self, FactorBuildError> {
        let (symbolic, l_values) = factor_numeric(n, lower, None)?;
        let mut position = vec![0u32; n];
        match symbolic.perm() {
            Some(perm) => {
                let (forward, _) = perm.arrays();
                for (pos, &row) in forward.iter().enumerate() {
                    position[row] = pos as u32;
                }
            }
            None => position.iter_mut().enumerate().for_each(|(i, p)| *p = i as u32),
        }
        let mut packer = Packer::<T>::new(storage);
        let place = |first: usize, _width: usize, rows: &[usize]| Some((first, rows.to_vec()));
        pack_factor(&symbolic, &l_values, &mut packer, place)?;
        let Packer { supernodes, pattern, values, longest } = packer;
        Ok(Self { len: n, position, supernodes, pattern, values, longest, simd: simd.clamp_to_cpu(), split: None })
    }

    /// As [`CholeskyFactor::new`], ordered so that the triangular sweeps run on two threads:
    /// the rows are split at the median of one of `keys` (each one value per row; the one with
    /// the smallest separator) into two halves and the separator between them
    /// (`bisected_ordering.rs`). Falls back to [`CholeskyFactor::new`]
    /// when the matrix does not split (a half empty, a separator over a quarter of the rows).
    pub fn new_bisected(
        n: usize,
        lower: &[(u32, u32, f64)],
        keys: &[Vec<f64>],
        simd: SimdLevel,
        storage: FactorStorage,
    ) -> Result<Self, FactorBuildError> {
        check_entries(n, lower)?;
        let Some(bisection) = bisect(n, lower, keys).map_err(|e| FactorBuildError::Factorisation(e.to_string()))?
        else {
            return Self::new(n, lower, simd, storage);
        };
        let (symbolic, l_values) = factor_numeric(n, lower, Some(&bisection.order))?;
        let (na, nb, ns) = (bisection.a, bisection.b, bisection.separator);
        // Positions: separator copy | B | separator | A. B's region is 0..boundary, A's
        // boundary..len; a supernode's rows are addressed within its region.
        let boundary = ns + nb;
        let class = |col: usize| {
            if col < na {
                0
            } else if col < na + nb {
                1
            } else {
                2
            }
        };
        let absolute = |col: usize| match class(col) {
            0 => 2 * ns + nb + col,
            1 => ns + (col - na),
            _ => boundary + (col - na - nb),
        };
        let mut position = vec![0u32; n];
        for (col, &row) in bisection.order.iter().enumerate() {
            position[row] = absolute(col) as u32;
        }
        let mut classes = Vec::new();
        let place = |first: usize, width: usize, rows: &[usize]| {
            let last = first + width - 1;
            let c = if class(last) == 0 {
                0
            } else if class(first) == 1 && class(last) == 1 {
                1
            } else if class(first) == 0 {
                return None; // spans A and the separator: B is empty
            } else {
                2
            };
            classes.push(c);
            let mapped: Option<Vec<usize>> = rows
                .iter()
                .map(|&r| match (c, class(r)) {
                    (0, 0 | 2) => Some(absolute(r) - boundary),
                    (1, 1) => Some(absolute(r)),
                    (1, 2) => Some(absolute(r) - boundary),
                    (2, 2) => Some(absolute(r)),
                    _ => None,
                })
                .collect();
            let first = if c == 0 { absolute(first) - boundary } else { absolute(first) };
            Some((first, mapped?))
        };
        let mut packer = Packer::<T>::new(storage);
        if !pack_factor(&symbolic, &l_values, &mut packer, place)? || !classes.is_sorted() {
            return Self::new(n, lower, simd, storage);
        }
        let a_end = classes.iter().filter(|&&c| c == 0).count();
        let b_end = a_end + classes.iter().filter(|&&c| c == 1).count();
        let Packer { supernodes, pattern, values, longest } = packer;
        Ok(Self {
            len: n + ns,
            position,
            supernodes,
            pattern,
            values,
            longest,
            simd: simd.clamp_to_cpu(),
            split: Some(Split { a_end, b_end, separator: ns, boundary }),
        })
    }

    /// Where matrix row `row` sits in the right-hand side and solution.
    #[inline]
    pub fn position(&self, row: usize) -> usize {
        self.position[row] as usize
    }

    /// Length of a right-hand side: the matrix's rows, plus a copy of the separator's rows
    /// when the sweeps run on two threads (positions no row maps to; their content is
    /// overwritten).
    pub fn rhs_len(&self) -> usize {
        self.len
    }

    /// True when the sweeps run on two threads.
    pub fn is_split(&self) -> bool {
        self.split.is_some()
    }

    /// Stored coefficients of the packed factor (both sweeps).
    pub fn stored_entries(&self) -> usize {
        self.values.len()
    }

    /// Scratch for [`CholeskyFactor::solve_in_place`].
    pub fn scratch(&self) -> SolveScratch<T> {
        let part = || {
            let v = || vec![T::ZERO; self.longest];
            SweepScratch { input: [v(), v(), v()], output: [v(), v(), v()] }
        };
        SolveScratch { parts: [part(), part()] }
    }

    /// Overwrites `b` (three components of [`CholeskyFactor::rhs_len`], factor order) with
    /// `A⁻¹ b`; a split factor's two halves run on `pool`'s first two workers (one after the
    /// other on a one-thread pool). Allocates nothing.
    pub fn solve_in_place(&self, mut b: [&mut [T]; 3], scratch: &mut SolveScratch<T>, pool: &WorkerPool) {
        for c in &b {
            assert_eq!(c.len(), self.len, "right-hand side has the wrong length");
        }
        let all = 0..self.supernodes.len();
        let Some(split) = self.split else {
            self.sweep(all.clone(), Sweep::Forward, &mut b, &mut scratch.parts[0]);
            self.sweep(all, Sweep::Backward, &mut b, &mut scratch.parts[0]);
            return;
        };
        let (ns, boundary) = (split.separator, split.boundary);
        let halves = [split.a_end..split.b_end, 0..split.a_end];
        for c in b.iter_mut() {
            c[..ns].fill(T::ZERO);
        }
        self.sweep_halves(&halves, Sweep::Forward, &mut b, scratch, pool);
        // The separator's rows gather what B's half subtracted into their copy.
        for c in b.iter_mut() {
            let (copy, rest) = c.split_at_mut(boundary);
            for (s, &d) in rest[..ns].iter_mut().zip(&copy[..ns]) {
                *s += d;
            }
        }
        let separator = split.b_end..self.supernodes.len();
        self.sweep(separator.clone(), Sweep::Forward, &mut b, &mut scratch.parts[0]);
        self.sweep(separator, Sweep::Backward, &mut b, &mut scratch.parts[0]);
        for c in b.iter_mut() {
            c.copy_within(boundary..boundary + ns, 0);
        }
        self.sweep_halves(&halves, Sweep::Backward, &mut b, scratch, pool);
    }

    /// One sweep over `halves[0]` (B's supernodes, on region `..boundary`) and `halves[1]`
    /// (A's, on region `boundary..`), on two workers.
    fn sweep_halves(
        &self,
        halves: &[std::ops::Range<usize>; 2],
        dir: Sweep,
        b: &mut [&mut [T]; 3],
        scratch: &mut SolveScratch<T>,
        pool: &WorkerPool,
    ) {
        let boundary = self.split.map_or(0, |s| s.boundary);
        let [b0, b1, b2] = b;
        let (l0, h0) = b0.split_at_mut(boundary);
        let (l1, h1) = b1.split_at_mut(boundary);
        let (l2, h2) = b2.split_at_mut(boundary);
        let mut regions = [[l0, l1, l2], [h0, h1, h2]];
        let regions = DisjointSlice::new(&mut regions);
        let parts = DisjointSlice::new(&mut scratch.parts);
        let threads = pool.threads();
        pool.run(&|worker| {
            let mine: &[usize] = match (threads, worker) {
                (1, _) => &[0, 1],
                (_, 0) => &[1],
                (_, 1) => &[0],
                _ => &[],
            };
            for &half in mine {
                // SAFETY: half `i` (its region and scratch) is taken by one worker only.
                let (region, part) =
                    unsafe { (&mut regions.range_mut(half..half + 1)[0], &mut parts.range_mut(half..half + 1)[0]) };
                self.sweep(halves[half].clone(), dir, region, part);
            }
        });
    }

    /// Forward or backward over the supernodes `range` of `b`, with the SIMD kernels.
    fn sweep(&self, range: std::ops::Range<usize>, dir: Sweep, b: &mut [&mut [T]; 3], scratch: &mut SweepScratch<T>) {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` was clamped to what this CPU has.
            SimdLevel::Avx2 | SimdLevel::Avx512 => unsafe { sweep_avx2(self, range, dir, b, scratch) },
            _ => sweep::<T, ScalarBlock<T>>(self, range, dir, b, scratch),
        }
    }
}

/// Which triangular sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sweep {
    /// `b ← L⁻¹ b`, supernodes in order.
    Forward,
    /// `b ← L⁻ᵀ b`, supernodes in reverse.
    Backward,
}

/// Refuses an entry outside the lower triangle of an `n × n` matrix, or not finite.
fn check_entries(n: usize, lower: &[(u32, u32, f64)]) -> Result<(), FactorBuildError> {
    match lower.iter().find(|&&(r, c, v)| r as usize >= n || c > r || !v.is_finite()) {
        Some(&(row, col, _)) => Err(FactorBuildError::BadEntry { row, col }),
        None => Ok(()),
    }
}

/// Runs faer's fill-reducing ordering (`order`, when given, instead) and numeric supernodal
/// factorisation of the lower-triangle entries `lower`, in `f64`.
fn factor_numeric(
    n: usize,
    lower: &[(u32, u32, f64)],
    order: Option<&[usize]>,
) -> Result<(faer::sparse::linalg::cholesky::SymbolicCholesky<usize>, Vec<f64>), FactorBuildError> {
    check_entries(n, lower)?;
    let triplets: Vec<_> = lower.iter().map(|&(r, c, v)| Triplet::new(r as usize, c as usize, v)).collect();
    let fail = |e: &dyn std::fmt::Debug| FactorBuildError::Factorisation(format!("{e:?}"));
    let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets).map_err(|e| fail(&e))?;
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let inverse: Option<Vec<usize>> = order.map(|o| {
        let mut inv = vec![0; n];
        o.iter().enumerate().for_each(|(pos, &row)| inv[row] = pos);
        inv
    });
    let ordering = match (order, &inverse) {
        (Some(fwd), Some(inv)) if fwd.len() == n => SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, n)),
        _ => SymmetricOrdering::Amd,
    };
    let symbolic = factorize_symbolic_cholesky(a.symbolic(), Side::Lower, ordering, params).map_err(|e| fail(&e))?;
    let mut l_values = vec![0.0f64; symbolic.len_val()];
    let mut buffer = MemBuffer::try_new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()))
        .map_err(|e| fail(&e))?;
    symbolic
        .factorize_numeric_llt::<f64>(
            &mut l_values,
            a.as_ref(),
            Side::Lower,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut buffer),
            Default::default(),
        )
        .map_err(|_| FactorBuildError::NotPositiveDefinite)?;
    Ok((symbolic, l_values))
}

/// Packs every supernode of a numeric factor, placed by `place(first, width, rows)` (factor
/// order in, stored column and rows out). `Ok(false)` when `place` refuses a supernode.
fn pack_factor<T: Real>(
    symbolic: &faer::sparse::linalg::cholesky::SymbolicCholesky<usize>,
    l_values: &[f64],
    packer: &mut Packer<T>,
    mut place: impl FnMut(usize, usize, &[usize]) -> Option<(usize, Vec<usize>)>,
) -> Result<bool, FactorBuildError> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(supernodal) => {
            let factor = SupernodalLltRef::<usize, f64>::new(supernodal, l_values);
            for s in 0..supernodal.n_supernodes() {
                let node = factor.supernode(s);
                let block = node.val();
                let Some((first, rows)) = place(node.start(), block.ncols(), node.pattern()) else {
                    return Ok(false);
                };
                packer.push(first, block.ncols(), &rows, |i, j| block[(i, j)])?;
            }
        }
        // Very sparse matrices (a diagonal one, say) get a column-by-column factor: each
        // column is a supernode of width 1, its diagonal entry first.
        SymbolicCholeskyRaw::Simplicial(simplicial) => {
            let (col_ptr, row_idx) = (simplicial.col_ptr(), simplicial.row_idx());
            for j in 0..col_ptr.len() - 1 {
                let range = col_ptr[j]..col_ptr[j + 1];
                let (rows, vals) = (&row_idx[range.clone()], &l_values[range]);
                if rows.first() != Some(&j) {
                    return Err(FactorBuildError::Factorisation(format!("column {j} of the factor has no diagonal")));
                }
                let Some((first, below)) = place(j, 1, &rows[1..]) else {
                    return Ok(false);
                };
                packer.push(first, 1, &below, |i, _| vals[i])?;
            }
        }
    }
    Ok(true)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,f16c")]
fn sweep_avx2<T: Real>(
    f: &CholeskyFactor<T>,
    range: std::ops::Range<usize>,
    dir: Sweep,
    b: &mut [&mut [T]; 3],
    scratch: &mut SweepScratch<T>,
) {
    sweep::<T, T::AvxBlock>(f, range, dir, b, scratch);
}

#[inline(always)]
fn sweep<T: Real, B: Block<T>>(
    f: &CholeskyFactor<T>,
    range: std::ops::Range<usize>,
    dir: Sweep,
    b: &mut [&mut [T]; 3],
    scratch: &mut SweepScratch<T>,
) {
    // Plain loops, not closures: a closure is compiled outside the caller's
    // `#[target_feature]` context and its SIMD intrinsics become calls unless it is inlined.
    match &f.values {
        Coefficients::Full(v) => sweep_with::<T, B, _>(f, FullValues(v), range, dir, b, scratch),
        Coefficients::Half(v) => sweep_with::<T, B, _>(f, HalfValues(v), range, dir, b, scratch),
    }
}

#[inline(always)]
fn sweep_with<T: Real, B: Block<T>, V: CoefficientSource<T>>(
    f: &CholeskyFactor<T>,
    values: V,
    range: std::ops::Range<usize>,
    dir: Sweep,
    b: &mut [&mut [T]; 3],
    scratch: &mut SweepScratch<T>,
) {
    let supernodes = &f.supernodes[range];
    match dir {
        Sweep::Forward => {
            for s in supernodes {
                forward::<T, B, V>(f, values, s, b, scratch);
            }
        }
        Sweep::Backward => {
            for s in supernodes.iter().rev() {
                backward::<T, B, V>(f, values, s, b, scratch);
            }
        }
    }
}

/// `out = M x` for a packed product, the three components at once; `out` must hold the
/// outputs padded to whole lane blocks.
#[inline(always)]
fn product<T: Real, B: Block<T>, V: CoefficientSource<T>>(values: V, m: &Packed, x: [&[T]; 3], out: &mut [Vec<T>; 3]) {
    let padded = (m.outputs as usize).div_ceil(LANES) * LANES;
    let zero = B::splat(T::ZERO);
    let mut at = m.start;
    let mut o0 = 0;
    while o0 < padded {
        let h = (padded - o0).min(TILE);
        let inputs = m.inputs_of(o0, h);
        let mut acc = [[zero; 2]; 3];
        if h == TILE {
            for j in inputs {
                let (l0, l1): (B, B) = (values.block(at), values.block(at + LANES));
                for c in 0..3 {
                    let xj = B::splat(x[c][j]);
                    acc[c][0] = acc[c][0].add(l0.mul(xj));
                    acc[c][1] = acc[c][1].add(l1.mul(xj));
                }
                at += TILE;
            }
            for c in 0..3 {
                acc[c][0].store(&mut out[c], o0);
                acc[c][1].store(&mut out[c], o0 + LANES);
            }
        } else {
            for j in inputs {
                let l0: B = values.block(at);
                for c in 0..3 {
                    acc[c][0] = acc[c][0].add(l0.mul(B::splat(x[c][j])));
                }
                at += LANES;
            }
            for c in 0..3 {
                acc[c][0].store(&mut out[c], o0);
            }
        }
        o0 += h;
    }
}

/// One supernode of `b ← L⁻¹ b`.
#[inline(always)]
fn forward<T: Real, B: Block<T>, V: CoefficientSource<T>>(
    f: &CholeskyFactor<T>,
    values: V,
    s: &Supernode,
    b: &mut [&mut [T]; 3],
    scratch: &mut SweepScratch<T>,
) {
    let (first, width, rows) = (s.first as usize, s.width as usize, s.rows as usize);
    // x = D⁻¹ b_block, into the block's columns.
    {
        let x = [&b[0][first..first + width], &b[1][first..first + width], &b[2][first..first + width]];
        product::<T, B, V>(values, &s.inverse, x, &mut scratch.output);
    }
    for c in 0..3 {
        b[c][first..first + width].copy_from_slice(&scratch.output[c][..width]);
    }
    if rows == 0 {
        return;
    }
    // b[pattern] −= L_below x.
    {
        let x = [&b[0][first..first + width], &b[1][first..first + width], &b[2][first..first + width]];
        product::<T, B, V>(values, &s.below, x, &mut scratch.output);
    }
    // The three components in one pass over the pattern.
    let pattern = &f.pattern[s.pattern_start as usize..][..rows];
    let [o0, o1, o2] = &scratch.output;
    let [b0, b1, b2] = b;
    for (((&p, &v0), &v1), &v2) in pattern.iter().zip(&o0[..rows]).zip(&o1[..rows]).zip(&o2[..rows]) {
        let p = p as usize;
        b0[p] -= v0;
        b1[p] -= v1;
        b2[p] -= v2;
    }
}

/// One supernode of `b ← L⁻ᵀ b`.
#[inline(always)]
fn backward<T: Real, B: Block<T>, V: CoefficientSource<T>>(
    f: &CholeskyFactor<T>,
    values: V,
    s: &Supernode,
    b: &mut [&mut [T]; 3],
    scratch: &mut SweepScratch<T>,
) {
    let (first, width, rows) = (s.first as usize, s.width as usize, s.rows as usize);
    // a = b_block − L_belowᵀ b[pattern].
    if rows > 0 {
        let pattern = &f.pattern[s.pattern_start as usize..][..rows];
        let [g0, g1, g2] = &mut scratch.input;
        let (b0, b1, b2) = (&*b[0], &*b[1], &*b[2]);
        for (((&p, g0), g1), g2) in pattern.iter().zip(&mut g0[..rows]).zip(&mut g1[..rows]).zip(&mut g2[..rows]) {
            let p = p as usize;
            (*g0, *g1, *g2) = (b0[p], b1[p], b2[p]);
        }
        let [g0, g1, g2] = &scratch.input;
        product::<T, B, V>(values, &s.below_t, [&g0[..rows], &g1[..rows], &g2[..rows]], &mut scratch.output);
        for c in 0..3 {
            for (a, (&bv, &v)) in scratch.input[c][..width]
                .iter_mut()
                .zip(b[c][first..first + width].iter().zip(&scratch.output[c][..width]))
            {
                *a = bv - v;
            }
        }
    } else {
        for c in 0..3 {
            scratch.input[c][..width].copy_from_slice(&b[c][first..first + width]);
        }
    }
    // x_block = D⁻ᵀ a.
    let [a0, a1, a2] = &scratch.input;
    product::<T, B, V>(values, &s.inverse_t, [&a0[..width], &a1[..width], &a2[..width]], &mut scratch.output);
    for c in 0..3 {
        b[c][first..first + width].copy_from_slice(&scratch.output[c][..width]);
    }
}

/// Collects supernodes into the packed layout of [`CholeskyFactor`].
struct Packer<T> {
    supernodes: Vec<Supernode>,
    pattern: Vec<u32>,
    values: Coefficients<T>,
    longest: usize,
}

/// `Σ a[k] b[k]` in eight running sums (which the compiler vectorises).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0f64; 8];
    let (a8, b8) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = a8.remainder().iter().zip(b8.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in a8.zip(b8) {
        for k in 0..8 {
            sums[k] += x[k] * y[k];
        }
    }
    sums.iter().sum::<f64>() + tail
}

impl<T: Real> Packer<T> {
    fn new(storage: FactorStorage) -> Self {
        Self { supernodes: Vec::new(), pattern: Vec::new(), values: Coefficients::new(storage), longest: 0 }
    }

    /// Adds the supernode of columns `first..first + width`, its rows below the diagonal
    /// block being `below_rows`; `entry(i, j)` is the factor's entry at row `i` of the
    /// supernode (the diagonal block's rows first) and column `j`.
    fn push(
        &mut self,
        first: usize,
        width: usize,
        below_rows: &[usize],
        entry: impl Fn(usize, usize) -> f64,
    ) -> Result<(), FactorBuildError> {
        let rows = below_rows.len();
        // The supernode's entries, row-major: the diagonal block's rows, then those below.
        let mut l = vec![0.0f64; (width + rows) * width];
        for j in 0..width {
            for i in j..width + rows {
                l[i * width + j] = entry(i, j);
            }
        }
        // Inverse of the lower-triangular diagonal block (forward substitution per column
        // of the identity, in f64), column-major: each entry one contiguous dot product.
        let mut inv = vec![0.0f64; width * width];
        for col in 0..width {
            for i in col..width {
                let (l_row, inv_col) = (&l[i * width + col..i * width + i], &inv[col * width + col..col * width + i]);
                let dot = dot(l_row, inv_col);
                inv[col * width + i] = (if i == col { 1.0 } else { 0.0 } - dot) / l[i * width + i];
            }
        }
        if inv.iter().any(|v| !v.is_finite()) {
            return Err(FactorBuildError::NotPositiveDefinite);
        }
        let values = &mut self.values;
        let start = values.len();
        let inverse = Packed::pack::<T>(values, width, width, Shape::Lower, |i, j| inv[j * width + i]);
        let below = Packed::pack::<T>(values, rows, width, Shape::Full, |r, j| l[(width + r) * width + j]);
        let below_t = Packed::pack::<T>(values, width, rows, Shape::Full, |j, r| l[(width + r) * width + j]);
        let inverse_t = Packed::pack::<T>(values, width, width, Shape::Upper, |j, i| inv[j * width + i]);
        if !values.all_finite_from(start) {
            return Err(FactorBuildError::BeyondStorage);
        }
        self.supernodes.push(Supernode {
            first: first as u32,
            width: width as u32,
            pattern_start: self.pattern.len() as u32,
            rows: rows as u32,
            inverse,
            below,
            below_t,
            inverse_t,
        });
        self.pattern.extend(below_rows.iter().map(|&p| p as u32));
        self.longest = self.longest.max(width.max(rows).div_ceil(LANES) * LANES);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A weighted graph Laplacian of a 3D grid plus a positive diagonal: the shape of the
    /// local/global system matrix.
    fn grid_matrix(nx: usize, ny: usize, nz: usize) -> (usize, Vec<(u32, u32, f64)>) {
        let id = |i: usize, j: usize, k: usize| (i * ny + j) * nz + k;
        let n = nx * ny * nz;
        let mut diag = vec![0.0; n];
        let mut lower = Vec::new();
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) as f64) / (1u64 << 31) as f64
        };
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    let a = id(i, j, k);
                    diag[a] += 0.5 + rand();
                    for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1)] {
                        let (ii, jj, kk) = (i + di, j + dj, k + dk);
                        if ii < nx && jj < ny && kk < nz {
                            let b = id(ii, jj, kk);
                            let w = 10.0 + 100.0 * rand();
                            diag[a] += w;
                            diag[b] += w;
                            lower.push((a.max(b) as u32, a.min(b) as u32, -w));
                        }
                    }
                }
            }
        }
        lower.extend(diag.iter().enumerate().map(|(i, &d)| (i as u32, i as u32, d)));
        (n, lower)
    }

    fn residual(n: usize, lower: &[(u32, u32, f64)], x: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        let mut r: Vec<[f64; 3]> = b.iter().map(|v| v.map(|c| -c)).collect();
        for &(i, j, v) in lower {
            let (i, j) = (i as usize, j as usize);
            for c in 0..3 {
                r[i][c] += v * x[j][c];
                if i != j {
                    r[j][c] += v * x[i][c];
                }
            }
        }
        let norm = |v: &[[f64; 3]]| v.iter().flatten().map(|c| c * c).sum::<f64>().sqrt();
        let _ = n;
        norm(&r) / norm(b)
    }

    fn solve<T: Real>(factor: &CholeskyFactor<T>, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        solve_on(factor, b, &WorkerPool::new(1, false))
    }

    fn solve_on<T: Real>(factor: &CholeskyFactor<T>, b: &[[f64; 3]], pool: &WorkerPool) -> Vec<[f64; 3]> {
        let len = factor.rhs_len();
        let mut rhs = [vec![T::ZERO; len], vec![T::ZERO; len], vec![T::ZERO; len]];
        for (row, v) in b.iter().enumerate() {
            for c in 0..3 {
                rhs[c][factor.position(row)] = T::from_f64(v[c]);
            }
        }
        let mut scratch = factor.scratch();
        let [x, y, z] = &mut rhs;
        factor.solve_in_place([x, y, z], &mut scratch, pool);
        (0..b.len()).map(|row| [0, 1, 2].map(|c| rhs[c][factor.position(row)].to_f64())).collect()
    }

    #[test]
    fn factor_solves_a_grid_laplacian_to_round_off_works() {
        let (n, lower) = grid_matrix(9, 7, 5);
        let b: Vec<[f64; 3]> = (0..n).map(|i| [(i % 7) as f64 - 3.0, (i % 3) as f64, 1.0]).collect();
        let f64_factor = CholeskyFactor::<f64>::new(n, &lower, SimdLevel::detect(), FactorStorage::Full).unwrap();
        assert!(residual(n, &lower, &solve(&f64_factor, &b), &b) < 1e-12);
        let f32_factor = CholeskyFactor::<f32>::new(n, &lower, SimdLevel::detect(), FactorStorage::Full).unwrap();
        // Cholesky's backward error bound, n·ε of the precision the factor is stored in.
        let r32 = residual(n, &lower, &solve(&f32_factor, &b), &b);
        assert!(r32 < n as f64 * f32::EPSILON as f64, "f32 residual {r32:e}");
        // Every instruction-set level gives the same bits.
        let levels: Vec<Vec<[f64; 3]>> = SimdLevel::available()
            .into_iter()
            .map(|level| solve(&CholeskyFactor::<f32>::new(n, &lower, level, FactorStorage::Full).unwrap(), &b))
            .collect();
        assert!(levels.windows(2).all(|w| w[0] == w[1]));
    }

    #[test]
    fn split_factor_solves_on_two_threads_as_on_one_works() {
        let (nx, ny, nz) = (16, 6, 4);
        let (n, lower) = grid_matrix(nx, ny, nz);
        let b: Vec<[f64; 3]> = (0..n).map(|i| [(i % 5) as f64 - 2.0, (i % 11) as f64, -1.0]).collect();
        // Keys: each row's grid coordinates; the cut across x (6 × 4 rows) is the smallest.
        let keys: Vec<Vec<f64>> = vec![
            (0..n).map(|r| (r / (ny * nz)) as f64).collect(),
            (0..n).map(|r| (r / nz % ny) as f64).collect(),
            (0..n).map(|r| (r % nz) as f64).collect(),
        ];
        let split =
            CholeskyFactor::<f64>::new_bisected(n, &lower, &keys, SimdLevel::detect(), FactorStorage::Full).unwrap();
        assert!(split.is_split());
        assert_eq!(split.rhs_len() - n, ny * nz, "one grid plane separates");
        let two = WorkerPool::new(2, false);
        let x2 = solve_on(&split, &b, &two);
        assert!(residual(n, &lower, &x2, &b) < 1e-12);
        // The same arithmetic whichever thread runs a half: same bits on one thread, and on
        // a second solve (the separator's copy is cleared each time).
        assert_eq!(solve(&split, &b), x2);
        assert_eq!(solve_on(&split, &b, &two), x2);
        let f32_split =
            CholeskyFactor::<f32>::new_bisected(n, &lower, &keys, SimdLevel::detect(), FactorStorage::Full).unwrap();
        let r32 = residual(n, &lower, &solve_on(&f32_split, &b, &two), &b);
        assert!(r32 < n as f64 * f32::EPSILON as f64, "f32 residual {r32:e}");
        // A dense matrix does not split (its separator would be half the rows): one thread.
        let m = 8;
        let dense: Vec<(u32, u32, f64)> =
            (0..m as u32).flat_map(|r| (0..=r).map(move |c| (r, c, if r == c { 10.0 } else { -1.0 }))).collect();
        let order = vec![(0..m).map(|i| i as f64).collect()];
        assert!(
            !CholeskyFactor::<f64>::new_bisected(m, &dense, &order, SimdLevel::Baseline, FactorStorage::Full)
                .unwrap()
                .is_split()
        );
        // A diagonal one splits with an empty separator (column-by-column factor).
        let diagonal: Vec<(u32, u32, f64)> = (0..m as u32).map(|i| (i, i, 2.0)).collect();
        let f = CholeskyFactor::<f64>::new_bisected(m, &diagonal, &order, SimdLevel::Baseline, FactorStorage::Full)
            .unwrap();
        assert!(f.is_split() && f.rhs_len() == m);
        let ones = vec![[2.0, 4.0, -2.0]; m];
        for (got, want) in solve_on(&f, &ones, &two).iter().flatten().zip([1.0, 2.0, -1.0].iter().cycle()) {
            assert!((got - want).abs() <= 4.0 * f64::EPSILON * want.abs(), "{got} against {want}");
        }
    }

    #[test]
    fn factor_of_a_diagonal_matrix_divides_works() {
        let lower = vec![(0, 0, 2.0), (1, 1, 4.0), (2, 2, 8.0)];
        let f = CholeskyFactor::<f64>::new(3, &lower, SimdLevel::Baseline, FactorStorage::Full).unwrap();
        let x = solve(&f, &[[2.0, 4.0, 6.0], [4.0, 8.0, 12.0], [8.0, 8.0, 8.0]]);
        let expected = [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 1.0, 1.0]];
        for (got, want) in x.iter().flatten().zip(expected.iter().flatten()) {
            assert!((got - want).abs() <= 4.0 * f64::EPSILON * want, "{x:?}");
        }
    }

    #[test]
    fn half_storage_solves_a_unit_diagonal_matrix_to_binary16_precision_works() {
        let (n, lower) = grid_matrix(9, 7, 5);
        // Scaled to a unit diagonal, as `FactoredPreconditioner` scales its matrix.
        let mut diag = vec![0.0; n];
        lower.iter().filter(|e| e.0 == e.1).for_each(|&(r, _, v)| diag[r as usize] += v);
        let scaled: Vec<(u32, u32, f64)> =
            lower.iter().map(|&(r, c, v)| (r, c, v / (diag[r as usize] * diag[c as usize]).sqrt())).collect();
        let b: Vec<[f64; 3]> = (0..n).map(|i| [(i % 7) as f64 - 3.0, (i % 3) as f64, 1.0]).collect();
        let half = CholeskyFactor::<f32>::new(n, &scaled, SimdLevel::detect(), FactorStorage::Half).unwrap();
        // Each coefficient rounded to 11 significant bits in place of 24: the residual grows
        // with the unit round-off, 2^13 times f32's, within the spread of how the rounding
        // errors add up.
        let r16 = residual(n, &scaled, &solve(&half, &b), &b);
        let full = CholeskyFactor::<f32>::new(n, &scaled, SimdLevel::detect(), FactorStorage::Full).unwrap();
        let r32 = residual(n, &scaled, &solve(&full, &b), &b);
        let growth = r16 / r32;
        assert!((512.0..32768.0).contains(&growth), "binary16 residual {r16:e}, f32 {r32:e}");
        // Every instruction-set level widens binary16 exactly: the same bits.
        let levels: Vec<Vec<[f64; 3]>> = SimdLevel::available()
            .into_iter()
            .map(|level| solve(&CholeskyFactor::<f32>::new(n, &scaled, level, FactorStorage::Half).unwrap(), &b))
            .collect();
        assert!(levels.windows(2).all(|w| w[0] == w[1]));
        // An entry beyond binary16's range is refused, not stored as infinity: a diagonal of
        // 1e-10 has a factor inverse of 1e5.
        assert_eq!(
            CholeskyFactor::<f32>::new(1, &[(0, 0, 1e-10)], SimdLevel::Baseline, FactorStorage::Half).unwrap_err(),
            FactorBuildError::BeyondStorage
        );
    }

    #[test]
    fn factor_refuses_indefinite_and_bad_entries_fails() {
        let indefinite = vec![(0, 0, 1.0), (1, 0, 2.0), (1, 1, 1.0)];
        assert_eq!(
            CholeskyFactor::<f64>::new(2, &indefinite, SimdLevel::Baseline, FactorStorage::Full).unwrap_err(),
            FactorBuildError::NotPositiveDefinite
        );
        assert!(matches!(
            CholeskyFactor::<f64>::new(2, &[(2, 0, 1.0)], SimdLevel::Baseline, FactorStorage::Full),
            Err(FactorBuildError::BadEntry { row: 2, col: 0 })
        ));
        assert!(matches!(
            CholeskyFactor::<f64>::new(2, &[(0, 0, f64::NAN)], SimdLevel::Baseline, FactorStorage::Full),
            Err(FactorBuildError::BadEntry { .. })
        ));
        let keys = vec![vec![0.0, 1.0]];
        assert!(matches!(
            CholeskyFactor::<f64>::new_bisected(2, &[(2, 0, 1.0)], &keys, SimdLevel::Baseline, FactorStorage::Full),
            Err(FactorBuildError::BadEntry { row: 2, col: 0 })
        ));
    }
}
