//! A fill-reducing ordering that splits a matrix's graph into two halves and a separator, so
//! the triangular sweeps of its Cholesky factor run on two threads.
//!
//! Rows are split at the median of a key (for the solver, each node's rest coordinate along x,
//! y or z, whichever gives the smallest separator): the lower half is `A`, the upper `B`. The rows of `B` coupled to a
//! row of `A` form the separator `S`, so no entry couples what is left of `B` to `A`. Ordered
//! `A`, then `B`, then `S`, each by approximate minimum degree within itself (faer's AMD), the
//! factor has no entry coupling `A` and `B` either (fill only follows paths through rows
//! eliminated earlier, and every path from `A` to `B` passes through `S`, eliminated last): the
//! sweeps over `A`'s columns and over `B`'s are independent until they meet at the separator.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::{SparseColMat, Triplet};

/// Largest separator accepted, as a fraction of the rows: a larger one leaves too little
/// work to the two halves to be worth splitting.
const MAX_SEPARATOR_FRACTION: f64 = 0.25;

/// The minimum-degree ordering of a part failed (out of memory or index overflow).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("minimum-degree ordering failed: {0}")]
pub struct OrderingError(String);

/// Part of a row: the lower half, the upper half, the separator.
const PART_A: u8 = 0;
const PART_B: u8 = 1;
const SEPARATOR: u8 = 2;

/// Rows in factor order: `A`'s, then `B`'s, then the separator's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Bisection {
    /// `order[position] = row`.
    pub order: Vec<usize>,
    /// Rows in `A`.
    pub a: usize,
    /// Rows in `B` (the separator excluded).
    pub b: usize,
    /// Rows in the separator.
    pub separator: usize,
}

/// Splits the symmetric `n × n` matrix whose lower-triangle entries are `lower` at the median
/// of one of `keys` (each one value per row): the key whose split has the smallest separator.
/// Entries outside the matrix are ignored (the factorisation refuses them).
/// `None` when no key splits (a half empty, or a separator larger than a quarter of the rows).
///
/// # Errors
/// [`OrderingError`] when the minimum-degree ordering fails (out of memory).
pub fn bisect(n: usize, lower: &[(u32, u32, f64)], keys: &[Vec<f64>]) -> Result<Option<Bisection>, OrderingError> {
    let best = keys
        .iter()
        .filter(|key| n >= 4 && key.len() == n)
        .map(|key| {
            let part = split_at_median(lower, key);
            let counts = [PART_A, PART_B, SEPARATOR].map(|p| part.iter().filter(|&&q| q == p).count());
            (part, counts)
        })
        .filter(|(_, [a, b, s])| *a > 0 && *b > 0 && *s as f64 <= MAX_SEPARATOR_FRACTION * n as f64)
        .min_by_key(|(_, [_, _, s])| *s);
    let Some((part, [a, b, separator])) = best else {
        return Ok(None);
    };
    let mut order = Vec::with_capacity(n);
    for p in [PART_A, PART_B, SEPARATOR] {
        let rows: Vec<usize> = (0..n).filter(|&i| part[i] == p).collect();
        order.extend(minimum_degree(&rows, lower, &part, p)?.into_iter().map(|local| rows[local]));
    }
    Ok(Some(Bisection { order, a, b, separator }))
}

/// Each row's part when split at the median of `key`: rows of the upper half coupled to one
/// of the lower half join the separator.
fn split_at_median(lower: &[(u32, u32, f64)], key: &[f64]) -> Vec<u8> {
    let n = key.len();
    let mut by_key: Vec<usize> = (0..n).collect();
    by_key.sort_by(|&i, &j| key[i].total_cmp(&key[j]).then(i.cmp(&j)));
    let mut part = vec![PART_B; n];
    for &row in &by_key[..n / 2] {
        part[row] = PART_A;
    }
    for &(r, c, _) in lower {
        let (r, c) = (r as usize, c as usize);
        if r < n && c < n && (part[r] == PART_A) != (part[c] == PART_A) {
            // A row of A coupled to one outside it: that one joins the separator.
            let other = if part[r] == PART_A { c } else { r };
            part[other] = SEPARATOR;
        }
    }
    part
}

/// Approximate minimum-degree order of the rows `rows` (all in part `p`), as local indices.
fn minimum_degree(rows: &[usize], lower: &[(u32, u32, f64)], part: &[u8], p: u8) -> Result<Vec<usize>, OrderingError> {
    let k = rows.len();
    let mut local = vec![usize::MAX; part.len()];
    for (l, &row) in rows.iter().enumerate() {
        local[row] = l;
    }
    let mut triplets: Vec<Triplet<usize, usize, f64>> = (0..k).map(|l| Triplet::new(l, l, 1.0)).collect();
    for &(r, c, _) in lower {
        let (r, c) = (r as usize, c as usize);
        if r != c && r < part.len() && c < part.len() && part[r] == p && part[c] == p {
            triplets.push(Triplet::new(local[r], local[c], 1.0));
        }
    }
    let fail = |e: &dyn std::fmt::Debug| OrderingError(format!("{e:?}"));
    let pattern = SparseColMat::<usize, f64>::try_new_from_triplets(k, k, &triplets).map_err(|e| fail(&e))?;
    let (mut fwd, mut inv) = (vec![0usize; k], vec![0usize; k]);
    let mut buffer = MemBuffer::try_new(amd::order_scratch::<usize>(k, pattern.compute_nnz())).map_err(|e| fail(&e))?;
    amd::order(&mut fwd, &mut inv, pattern.symbolic(), amd::Control::default(), MemStack::new(&mut buffer))
        .map_err(|e| fail(&e))?;
    Ok(fwd)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 5-point Laplacian pattern of an `nx × ny` grid, row `i * ny + j`.
    fn grid(nx: usize, ny: usize) -> Vec<(u32, u32, f64)> {
        let mut lower = Vec::new();
        for i in 0..nx {
            for j in 0..ny {
                let a = (i * ny + j) as u32;
                lower.push((a, a, 4.0));
                if i + 1 < nx {
                    lower.push((a + ny as u32, a, -1.0));
                }
                if j + 1 < ny {
                    lower.push((a + 1, a, -1.0));
                }
            }
        }
        lower
    }

    #[test]
    fn bisection_of_a_grid_cuts_one_grid_line_works() {
        let (nx, ny) = (20, 7);
        // Across the grid lines (rows of one line share a key) and along them: the first
        // cuts 7 rows, the second 20, so the first is taken.
        let across: Vec<f64> = (0..nx * ny).map(|r| (r / ny) as f64).collect();
        let along: Vec<f64> = (0..nx * ny).map(|r| (r % ny) as f64).collect();
        let s = bisect(nx * ny, &grid(nx, ny), &[along, across]).unwrap().expect("a grid splits");
        // Split between grid lines 9 and 10: line 10 (ny rows, in B) separates.
        assert_eq!((s.a, s.b, s.separator), (10 * ny, 9 * ny, ny));
        let mut sorted = s.order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..nx * ny).collect::<Vec<_>>(), "a permutation");
        let line = |pos: usize| s.order[pos] / ny;
        assert!((0..s.a).all(|p| line(p) < 10));
        assert!((s.a..s.a + s.b).all(|p| line(p) > 10));
        assert!((s.a + s.b..nx * ny).all(|p| line(p) == 10));
    }

    #[test]
    fn bisection_refuses_a_dense_coupling_fails() {
        // Every row coupled to every other: the separator would be half the rows.
        let n = 12;
        let mut lower = Vec::new();
        for r in 0..n as u32 {
            for c in 0..=r {
                lower.push((r, c, if r == c { n as f64 } else { -1.0 }));
            }
        }
        let key: Vec<f64> = (0..n).map(|i| i as f64).collect();
        assert_eq!(bisect(n, &lower, &[key]).unwrap(), None);
    }
}
