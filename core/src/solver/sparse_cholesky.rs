//! A prefactored sparse symmetric positive definite matrix, solved for three right-hand
//! sides at once (the x, y and z components of every node).
//!
//! The fill-reducing ordering (approximate minimum degree) and the numeric supernodal
//! Cholesky factorisation come from faer, in `f64`, once. The factor is then repacked for
//! the real-time solve. Each supernode (a dense block of columns) becomes four matrix-vector
//! products: the inverse of its triangular diagonal block and its rows below, each stored
//! once for the forward sweep and once transposed for the backward sweep. Each product is
//! packed in *tiles* of at most [`TILE`] outputs: a tile's coefficients lie input after
//! input in memory, so the sweep streams the factor front to back while a tile's sums stay
//! in registers, for the three right-hand sides at once. Triangular blocks store only their
//! non-zero tiles. Nothing allocates; the arithmetic is written once over [`Block`], so the
//! baseline and AVX builds give the same bits.
//!
//! Rows are addressed in factor order: [`CholeskyFactor::position`] maps a matrix row to
//! its place in the right-hand side, so callers assemble straight into solve order.

use crate::real::Real;
use crate::solver::lane_block::{Block, LANES, ScalarBlock};
use crate::solver::simd::SimdLevel;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
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
    /// The sparse factorisation failed (out of memory or index overflow).
    #[error("sparse Cholesky factorisation failed: {0}")]
    Factorisation(String),
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
        values: &mut Vec<T>,
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
                values.extend((o0..o0 + h).map(|i| T::from_f64(if i < outputs { m(i, j) } else { 0.0 })));
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

/// Scratch of one solve, sized once for its factor.
#[derive(Clone, Debug)]
pub struct SolveScratch<T> {
    /// Per component: a product's input.
    input: [Vec<T>; 3],
    /// Per component: a product's output.
    output: [Vec<T>; 3],
}

/// `A = L Lᵀ` of a sparse SPD matrix, ready to solve `A X = B` for three right-hand sides.
#[derive(Clone, Debug)]
pub struct CholeskyFactor<T> {
    n: usize,
    /// `position[row]`: where matrix row `row` sits in factor order.
    position: Vec<u32>,
    supernodes: Vec<Supernode>,
    pattern: Vec<u32>,
    values: Vec<T>,
    /// Largest product dimension, padded to whole lane blocks.
    longest: usize,
    simd: SimdLevel,
}

impl<T: Real> CholeskyFactor<T> {
    /// Factors the `n × n` symmetric matrix given by its lower-triangle entries
    /// `(row, col, value)` with `row ≥ col` (duplicates are summed); solves run with the
    /// kernels of `simd` (lowered to what the CPU has).
    pub fn new(n: usize, lower: &[(u32, u32, f64)], simd: SimdLevel) -> Result<Self, FactorBuildError> {
        let mut triplets = Vec::with_capacity(lower.len());
        for &(r, c, v) in lower {
            if r as usize >= n || c > r || !v.is_finite() {
                return Err(FactorBuildError::BadEntry { row: r, col: c });
            }
            triplets.push(Triplet::new(r as usize, c as usize, v));
        }
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets)
            .map_err(|e| FactorBuildError::Factorisation(format!("{e:?}")))?;
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(a.symbolic(), Side::Lower, SymmetricOrdering::Amd, params)
            .map_err(|e| FactorBuildError::Factorisation(format!("{e:?}")))?;
        let mut l_values = vec![0.0f64; symbolic.len_val()];
        let mut buffer =
            MemBuffer::try_new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()))
                .map_err(|e| FactorBuildError::Factorisation(format!("{e:?}")))?;
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
        let mut packer = Packer::<T>::new();
        match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(supernodal) => {
                let factor = SupernodalLltRef::<usize, f64>::new(supernodal, &l_values);
                for s in 0..supernodal.n_supernodes() {
                    let node = factor.supernode(s);
                    let block = node.val();
                    packer.push(node.start(), block.ncols(), node.pattern(), |i, j| block[(i, j)])?;
                }
            }
            // Very sparse matrices (a diagonal one, say) get a column-by-column factor:
            // each column is a supernode of width 1, its diagonal entry first.
            SymbolicCholeskyRaw::Simplicial(simplicial) => {
                let (col_ptr, row_idx) = (simplicial.col_ptr(), simplicial.row_idx());
                for j in 0..n {
                    let range = col_ptr[j]..col_ptr[j + 1];
                    let (rows, vals) = (&row_idx[range.clone()], &l_values[range]);
                    if rows.first() != Some(&j) {
                        return Err(FactorBuildError::Factorisation(format!(
                            "column {j} of the factor has no diagonal"
                        )));
                    }
                    packer.push(j, 1, &rows[1..], |i, _| vals[i])?;
                }
            }
        }
        let Packer { supernodes, pattern, values, longest } = packer;
        Ok(Self { n, position, supernodes, pattern, values, longest, simd: simd.clamp_to_cpu() })
    }

    /// Where matrix row `row` sits in the right-hand side and solution.
    #[inline]
    pub fn position(&self, row: usize) -> usize {
        self.position[row] as usize
    }

    /// Stored coefficients of the packed factor (both sweeps).
    pub fn stored_entries(&self) -> usize {
        self.values.len()
    }

    /// Scratch for [`CholeskyFactor::solve_in_place`].
    pub fn scratch(&self) -> SolveScratch<T> {
        let v = || vec![T::ZERO; self.longest];
        SolveScratch { input: [v(), v(), v()], output: [v(), v(), v()] }
    }

    /// Overwrites `b` (three components, factor order) with `A⁻¹ b`. Allocates nothing.
    pub fn solve_in_place(&self, b: [&mut [T]; 3], scratch: &mut SolveScratch<T>) {
        for c in &b {
            assert_eq!(c.len(), self.n, "right-hand side has the wrong length");
        }
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `simd` was clamped to what this CPU has.
            SimdLevel::Avx2 | SimdLevel::Avx512 => unsafe { solve_avx2(self, b, scratch) },
            _ => solve::<T, ScalarBlock<T>>(self, b, scratch),
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve_avx2<T: Real>(f: &CholeskyFactor<T>, b: [&mut [T]; 3], scratch: &mut SolveScratch<T>) {
    solve::<T, T::AvxBlock>(f, b, scratch);
}

#[inline(always)]
fn solve<T: Real, B: Block<T>>(f: &CholeskyFactor<T>, mut b: [&mut [T]; 3], scratch: &mut SolveScratch<T>) {
    for s in &f.supernodes {
        forward::<T, B>(f, s, &mut b, scratch);
    }
    for s in f.supernodes.iter().rev() {
        backward::<T, B>(f, s, &mut b, scratch);
    }
}

/// `out = M x` for a packed product, the three components at once; `out` must hold the
/// outputs padded to whole lane blocks.
#[inline(always)]
fn product<T: Real, B: Block<T>>(values: &[T], m: &Packed, x: [&[T]; 3], out: &mut [Vec<T>; 3]) {
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
                let (l0, l1) = (B::load(values, at), B::load(values, at + LANES));
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
                let l0 = B::load(values, at);
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
fn forward<T: Real, B: Block<T>>(
    f: &CholeskyFactor<T>,
    s: &Supernode,
    b: &mut [&mut [T]; 3],
    scratch: &mut SolveScratch<T>,
) {
    let (first, width, rows) = (s.first as usize, s.width as usize, s.rows as usize);
    // x = D⁻¹ b_block, into the block's columns.
    {
        let x = [&b[0][first..first + width], &b[1][first..first + width], &b[2][first..first + width]];
        product::<T, B>(&f.values, &s.inverse, x, &mut scratch.output);
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
        product::<T, B>(&f.values, &s.below, x, &mut scratch.output);
    }
    let pattern = &f.pattern[s.pattern_start as usize..][..rows];
    for c in 0..3 {
        for (&p, &v) in pattern.iter().zip(&scratch.output[c][..rows]) {
            b[c][p as usize] -= v;
        }
    }
}

/// One supernode of `b ← L⁻ᵀ b`.
#[inline(always)]
fn backward<T: Real, B: Block<T>>(
    f: &CholeskyFactor<T>,
    s: &Supernode,
    b: &mut [&mut [T]; 3],
    scratch: &mut SolveScratch<T>,
) {
    let (first, width, rows) = (s.first as usize, s.width as usize, s.rows as usize);
    // a = b_block − L_belowᵀ b[pattern].
    if rows > 0 {
        let pattern = &f.pattern[s.pattern_start as usize..][..rows];
        for c in 0..3 {
            for (g, &p) in scratch.input[c].iter_mut().zip(pattern) {
                *g = b[c][p as usize];
            }
        }
        let [g0, g1, g2] = &scratch.input;
        product::<T, B>(&f.values, &s.below_t, [&g0[..rows], &g1[..rows], &g2[..rows]], &mut scratch.output);
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
    product::<T, B>(&f.values, &s.inverse_t, [&a0[..width], &a1[..width], &a2[..width]], &mut scratch.output);
    for c in 0..3 {
        b[c][first..first + width].copy_from_slice(&scratch.output[c][..width]);
    }
}

/// Collects supernodes into the packed layout of [`CholeskyFactor`].
struct Packer<T> {
    supernodes: Vec<Supernode>,
    pattern: Vec<u32>,
    values: Vec<T>,
    longest: usize,
}

impl<T: Real> Packer<T> {
    fn new() -> Self {
        Self { supernodes: Vec::new(), pattern: Vec::new(), values: Vec::new(), longest: 0 }
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
        // Inverse of the lower-triangular diagonal block (forward substitution per column
        // of the identity, in f64), row-major.
        let mut inv = vec![0.0f64; width * width];
        for col in 0..width {
            for i in col..width {
                let mut s = if i == col { 1.0 } else { 0.0 };
                for k in col..i {
                    s -= entry(i, k) * inv[k * width + col];
                }
                inv[i * width + col] = s / entry(i, i);
            }
        }
        if inv.iter().any(|v| !v.is_finite()) {
            return Err(FactorBuildError::NotPositiveDefinite);
        }
        let values = &mut self.values;
        let inverse = Packed::pack::<T>(values, width, width, Shape::Lower, |i, j| inv[i * width + j]);
        let below = Packed::pack::<T>(values, rows, width, Shape::Full, |r, j| entry(width + r, j));
        let below_t = Packed::pack::<T>(values, width, rows, Shape::Full, |j, r| entry(width + r, j));
        let inverse_t = Packed::pack::<T>(values, width, width, Shape::Upper, |j, i| inv[i * width + j]);
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
        let mut rhs = [vec![T::ZERO; b.len()], vec![T::ZERO; b.len()], vec![T::ZERO; b.len()]];
        for (row, v) in b.iter().enumerate() {
            for c in 0..3 {
                rhs[c][factor.position(row)] = T::from_f64(v[c]);
            }
        }
        let mut scratch = factor.scratch();
        let [x, y, z] = &mut rhs;
        factor.solve_in_place([x, y, z], &mut scratch);
        (0..b.len()).map(|row| [0, 1, 2].map(|c| rhs[c][factor.position(row)].to_f64())).collect()
    }

    #[test]
    fn factor_solves_a_grid_laplacian_to_round_off_works() {
        let (n, lower) = grid_matrix(9, 7, 5);
        let b: Vec<[f64; 3]> = (0..n).map(|i| [(i % 7) as f64 - 3.0, (i % 3) as f64, 1.0]).collect();
        let f64_factor = CholeskyFactor::<f64>::new(n, &lower, SimdLevel::detect()).unwrap();
        assert!(residual(n, &lower, &solve(&f64_factor, &b), &b) < 1e-12);
        let f32_factor = CholeskyFactor::<f32>::new(n, &lower, SimdLevel::detect()).unwrap();
        // Cholesky's backward error bound, n·ε of the precision the factor is stored in.
        let r32 = residual(n, &lower, &solve(&f32_factor, &b), &b);
        assert!(r32 < n as f64 * f32::EPSILON as f64, "f32 residual {r32:e}");
        // Every instruction-set level gives the same bits.
        let levels: Vec<Vec<[f64; 3]>> = SimdLevel::available()
            .into_iter()
            .map(|level| solve(&CholeskyFactor::<f32>::new(n, &lower, level).unwrap(), &b))
            .collect();
        assert!(levels.windows(2).all(|w| w[0] == w[1]));
    }

    #[test]
    fn factor_of_a_diagonal_matrix_divides_works() {
        let lower = vec![(0, 0, 2.0), (1, 1, 4.0), (2, 2, 8.0)];
        let f = CholeskyFactor::<f64>::new(3, &lower, SimdLevel::Baseline).unwrap();
        let x = solve(&f, &[[2.0, 4.0, 6.0], [4.0, 8.0, 12.0], [8.0, 8.0, 8.0]]);
        let expected = [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 1.0, 1.0]];
        for (got, want) in x.iter().flatten().zip(expected.iter().flatten()) {
            assert!((got - want).abs() <= 4.0 * f64::EPSILON * want, "{x:?}");
        }
    }

    #[test]
    fn factor_refuses_indefinite_and_bad_entries_fails() {
        let indefinite = vec![(0, 0, 1.0), (1, 0, 2.0), (1, 1, 1.0)];
        assert_eq!(
            CholeskyFactor::<f64>::new(2, &indefinite, SimdLevel::Baseline).unwrap_err(),
            FactorBuildError::NotPositiveDefinite
        );
        assert!(matches!(
            CholeskyFactor::<f64>::new(2, &[(2, 0, 1.0)], SimdLevel::Baseline),
            Err(FactorBuildError::BadEntry { row: 2, col: 0 })
        ));
        assert!(matches!(
            CholeskyFactor::<f64>::new(2, &[(0, 0, f64::NAN)], SimdLevel::Baseline),
            Err(FactorBuildError::BadEntry { .. })
        ));
    }
}
