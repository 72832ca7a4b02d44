//! The virtual tensile test (the paper's Fig. 8): a slab of a layer's spring lattice, one end
//! held, the other pulled by `n` increasing loads, each solved to static equilibrium by
//! Newton's method with a residual-based stop.

use crate::generator::SpringMaterial;
use nalgebra::{DMatrix, DVector};

/// Forward neighbour offsets of the slab lattice: edges and both diagonals of every face, so
/// every cell is braced on all six faces and the slab has no mechanism.
const OFFSETS: [[i64; 3]; 9] =
    [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, -1, 0], [1, 0, 1], [1, 0, -1], [0, 1, 1], [0, 1, -1]];

/// A slab of a layer's lattice: `nx` nodes along the pull (x) at spacing `h`, two node rows
/// through the layer's thickness (y), `nz` nodes across (z) at spacing `h`.
#[derive(Clone, Debug, PartialEq)]
pub struct Specimen {
    /// Rest positions, m.
    pub positions: Vec<[f64; 3]>,
    /// Springs `(a, b, rest length m)`.
    pub springs: Vec<(usize, usize, f64)>,
    /// Nodes held (the `x = 0` end).
    pub held: Vec<bool>,
    /// Nodes pulled (the far end), sharing the load equally.
    pub pulled: Vec<usize>,
    /// Gauge length, m.
    pub length_m: f64,
    /// Undeformed cross-section, m².
    pub area_m2: f64,
}

impl Specimen {
    /// A slab of grid spacing `h` (m) and thickness `thickness` (m), `nx` × 2 × `nz` nodes.
    /// Defaults used by the fitting: `nx = 6`, `nz = 3`.
    pub fn layer_slab(h: f64, thickness: f64, nx: usize, nz: usize) -> Self {
        let dims = [nx, 2, nz];
        let spacing = [h, thickness, h];
        let index = |i: usize, j: usize, k: usize| (k * 2 + j) * nx + i;
        let mut positions = vec![[0.0; 3]; nx * 2 * nz];
        for k in 0..nz {
            for j in 0..2 {
                for i in 0..nx {
                    positions[index(i, j, k)] = [i as f64 * h, j as f64 * thickness, k as f64 * h];
                }
            }
        }
        let mut springs = Vec::new();
        for k in 0..nz {
            for j in 0..2 {
                for i in 0..nx {
                    for o in OFFSETS {
                        let n = [i as i64 + o[0], j as i64 + o[1], k as i64 + o[2]];
                        if (0..3).all(|c| n[c] >= 0 && (n[c] as usize) < dims[c]) {
                            let (a, b) = (index(i, j, k), index(n[0] as usize, n[1] as usize, n[2] as usize));
                            let d: f64 = (0..3).map(|c| (o[c] as f64 * spacing[c]).powi(2)).sum::<f64>();
                            springs.push((a, b, d.sqrt()));
                        }
                    }
                }
            }
        }
        let held = positions.iter().map(|p| p[0] == 0.0).collect();
        let pulled = (0..positions.len()).filter(|&n| n % nx == nx - 1).collect();
        Self {
            positions,
            springs,
            held,
            pulled,
            length_m: (nx - 1) as f64 * h,
            area_m2: (nz - 1) as f64 * h * thickness,
        }
    }
}

/// One tensile test's curve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TensileCurve {
    /// Engineering strain of each load (mean stretch of the pulled end over the gauge
    /// length), unitless; starts with 0 at no load.
    pub strain: Vec<f64>,
    /// Engineering stress (load over the undeformed cross-section), Pa.
    pub stress_pa: Vec<f64>,
    /// Newton iterations over all loads.
    pub newton_iterations: u32,
    /// Largest final residual over all loads, relative to the load per pulled node.
    pub worst_residual: f64,
}

/// Why a tensile test could not finish.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum TensileTestError {
    /// Newton's method did not reach the residual tolerance.
    #[error("load {load}: no static equilibrium (relative residual {residual:.2e})")]
    NotConverged {
        /// Index of the load (1-based).
        load: usize,
        /// Residual reached, relative to the load per pulled node.
        residual: f64,
    },
    /// The tangent stiffness matrix was singular.
    #[error("load {load}: singular tangent stiffness")]
    Singular {
        /// Index of the load (1-based).
        load: usize,
    },
}

/// Largest net force on any free node, relative to the load per pulled node, at which a
/// load step counts as in static equilibrium (or the Newton step falls below 1e-10 of the
/// gauge length: round-off). Default 1e-6.
pub const RESIDUAL_TOLERANCE: f64 = 1e-6;

/// Net force on every node (spring forces plus `load` per pulled node along +x), and
/// optionally the tangent stiffness `K = −∂g/∂x` over the free DOFs.
fn residual(
    spec: &Specimen,
    material: &SpringMaterial,
    x: &[[f64; 3]],
    load: f64,
    dof: &[Option<usize>],
    mut k: Option<&mut DMatrix<f64>>,
) -> Vec<[f64; 3]> {
    let mut g = vec![[0.0; 3]; x.len()];
    for &n in &spec.pulled {
        g[n][0] += load;
    }
    if let Some(k) = k.as_deref_mut() {
        k.fill(0.0);
    }
    for &(a, b, rest) in &spec.springs {
        let d = [x[b][0] - x[a][0], x[b][1] - x[a][1], x[b][2] - x[a][2]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-15);
        let u = d.map(|c| c / len);
        let law = material.law(rest);
        let t = law.force(len, rest);
        for c in 0..3 {
            g[a][c] += t * u[c];
            g[b][c] -= t * u[c];
        }
        if let Some(k) = k.as_deref_mut() {
            let kt = law.tangent(len, rest);
            // Geometric term only in tension keeps the tangent positive semi-definite.
            let geo = (t / len).max(0.0);
            let mut blk = [[0.0; 3]; 3];
            for r in 0..3 {
                for c in 0..3 {
                    let eye = if r == c { 1.0 } else { 0.0 };
                    blk[r][c] = kt * u[r] * u[c] + geo * (eye - u[r] * u[c]);
                }
            }
            for (p, q, sign) in [(a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)] {
                for r in 0..3 {
                    for c in 0..3 {
                        if let (Some(i), Some(j)) = (dof[p * 3 + r], dof[q * 3 + c]) {
                            k[(i, j)] += sign * blk[r][c];
                        }
                    }
                }
            }
        }
    }
    g
}

fn residual_norm(g: &[[f64; 3]], held: &[bool]) -> f64 {
    g.iter().zip(held).filter(|(_, h)| !**h).flat_map(|(v, _)| v.iter()).fold(0.0, |m, v| m.max(v.abs()))
}

/// Pulls `spec` made of `material` with the loads `stresses_pa` (Pa over the undeformed
/// cross-section, increasing), each solved to static equilibrium starting from the previous
/// one; the curve starts at (0, 0). Stops early (keeping the points so far) once the strain
/// passes `strain_limit`.
pub fn tensile_test(
    spec: &Specimen,
    material: &SpringMaterial,
    stresses_pa: &[f64],
    strain_limit: f64,
) -> Result<TensileCurve, TensileTestError> {
    let n = spec.positions.len();
    let mut dof = vec![None; 3 * n];
    let mut count = 0;
    for node in 0..n {
        if !spec.held[node] {
            for c in 0..3 {
                dof[node * 3 + c] = Some(count);
                count += 1;
            }
        }
    }
    let mut x = spec.positions.clone();
    let mut k = DMatrix::<f64>::zeros(count, count);
    let mut curve = TensileCurve { strain: vec![0.0], stress_pa: vec![0.0], ..Default::default() };
    let x_end0: f64 = spec.pulled.iter().map(|&p| spec.positions[p][0]).sum::<f64>() / spec.pulled.len() as f64;
    for (step, &stress) in (1..).zip(stresses_pa) {
        let per_node = stress * spec.area_m2 / spec.pulled.len() as f64;
        let scale = per_node.abs().max(1e-300);
        let mut converged = false;
        let mut last = f64::INFINITY;
        for _ in 0..60 {
            let g = residual(spec, material, &x, per_node, &dof, Some(&mut k));
            let r = residual_norm(&g, &spec.held) / scale;
            last = r;
            if r <= RESIDUAL_TOLERANCE {
                converged = true;
                break;
            }
            curve.newton_iterations += 1;
            let mut rhs = DVector::<f64>::zeros(count);
            for node in 0..n {
                for c in 0..3 {
                    if let Some(i) = dof[node * 3 + c] {
                        rhs[i] = g[node][c];
                    }
                }
            }
            let Some(dx) = k.clone().lu().solve(&rhs) else {
                return Err(TensileTestError::Singular { load: step });
            };
            // A Newton step below 1e-10 of the gauge length moves nothing but round-off:
            // the residual left is the floating-point floor of the spring forces.
            if dx.amax() <= 1e-10 * spec.length_m {
                converged = true;
                break;
            }
            // Backtracking on the residual: the bilinear kink can make a full step overshoot.
            let mut alpha = 1.0;
            loop {
                let trial: Vec<[f64; 3]> = (0..n)
                    .map(|node| [0, 1, 2].map(|c| x[node][c] + dof[node * 3 + c].map_or(0.0, |i| alpha * dx[i])))
                    .collect();
                let gt = residual(spec, material, &trial, per_node, &dof, None);
                if residual_norm(&gt, &spec.held) / scale < r || alpha < 1e-3 {
                    x = trial;
                    break;
                }
                alpha *= 0.5;
            }
        }
        if !converged {
            return Err(TensileTestError::NotConverged { load: step, residual: last });
        }
        curve.worst_residual = curve.worst_residual.max(last);
        let x_end: f64 = spec.pulled.iter().map(|&p| x[p][0]).sum::<f64>() / spec.pulled.len() as f64;
        let strain = (x_end - x_end0) / spec.length_m;
        curve.strain.push(strain);
        curve.stress_pa.push(stress);
        if strain > strain_limit {
            break;
        }
    }
    Ok(curve)
}
