//! Our model sizes beside the paper's Table 3.

use super::families::paper_springs;
use super::grid::GridSize;
use super::topology::LayeredTopology;
use std::fmt;

/// One row of the paper's Table 3 ("Quantitative comparison between different size of
/// deformable models").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperRow {
    /// W.
    pub columns: u32,
    /// H.
    pub rows: u32,
    /// Mass number.
    pub masses: usize,
    /// Spring number.
    pub springs: usize,
    /// Frame rate on the paper's PPU, frames/s.
    pub frame_rate: f64,
}

const fn row(columns: u32, rows: u32, masses: usize, springs: usize, frame_rate: f64) -> PaperRow {
    PaperRow { columns, rows, masses, springs, frame_rate }
}

/// The paper's Table 3, as printed.
pub const PAPER_TABLE3: [PaperRow; 11] = [
    row(12, 3, 264, 1848, 63.9),
    row(12, 5, 432, 3096, 62.5),
    row(15, 5, 540, 3870, 61.0),
    row(18, 5, 648, 4644, 58.1),
    row(21, 6, 903, 6510, 43.9),
    row(24, 6, 1032, 7440, 39.0),
    row(27, 6, 1161, 8370, 35.1),
    row(30, 7, 1500, 10860, 28.5),
    row(33, 8, 1881, 13662, 21.5),
    row(36, 9, 2304, 16776, 13.9),
    row(39, 10, 2769, 20202, 11.2),
];

/// Our counts beside the paper's for one grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Table3Row {
    /// W.
    pub columns: u32,
    /// H.
    pub rows: u32,
    /// Our masses, `W(7H+1)`.
    pub masses: usize,
    /// The paper's masses.
    pub paper_masses: usize,
    /// Our distinct springs, `W(55H−13)`.
    pub springs: usize,
    /// The paper's springs, `W(52H−2)`.
    pub paper_springs: usize,
    /// `100 · (springs − paper_springs) / paper_springs`, %.
    pub difference_percent: f64,
}

/// The comparison table; `Display` prints it with a header and a footnote.
#[derive(Clone, Debug, PartialEq)]
pub struct Table3 {
    /// One row per grid of the paper, in its order.
    pub rows: Vec<Table3Row>,
}

/// Our mass and spring counts for every grid of the paper's Table 3, from the same
/// topology the generator builds (a test checks that generated models have these counts).
pub fn table3_rows() -> Table3 {
    let rows = PAPER_TABLE3
        .iter()
        .map(|p| {
            let grid = GridSize::new(p.columns, p.rows);
            let springs = LayeredTopology::new(grid).springs.len();
            debug_assert_eq!(p.springs, paper_springs(grid));
            Table3Row {
                columns: p.columns,
                rows: p.rows,
                masses: grid.masses(),
                paper_masses: p.masses,
                springs,
                paper_springs: p.springs,
                difference_percent: 100.0 * (springs as f64 - p.springs as f64) / p.springs as f64,
            }
        })
        .collect();
    Table3 { rows }
}

impl fmt::Display for Table3 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "Paper Table 3 beside Lamina's layered generator")?;
        writeln!(f, "{:>6} {:>7} {:>7} {:>8} {:>8} {:>7}", "grid", "masses", "paper", "springs", "paper", "diff %")?;
        for r in &self.rows {
            writeln!(
                f,
                "{:>6} {:>7} {:>7} {:>8} {:>8} {:>+7.2}",
                format!("{}x{}", r.columns, r.rows),
                r.masses,
                r.paper_masses,
                r.springs,
                r.paper_springs,
                r.difference_percent
            )?;
        }
        write!(
            f,
            "masses W(7H+1) as in the paper; springs: ours W(55H-13) distinct, paper W(52H-2) \
             (see lamina_core::generator::families)"
        )
    }
}
