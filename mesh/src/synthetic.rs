//! Closed surfaces built in code, so tests and demos need no files.
//!
//! Every builder returns a welded, closed, outward-wound [`TriMesh`] in metres. Counts are
//! clamped to their minimum (segments ≥ 3, stacks ≥ 1, cells ≥ 1); radii are taken as
//! absolute values; a builder given a NaN or infinite size returns an empty mesh.
//!
//! # Examples
//! ```
//! use lamina_mesh::synthetic;
//! let limb = synthetic::cylinder(0.05, 0.0, 0.3, 64, 10);
//! assert!(limb.signed_volume() > 0.0);
//! ```

use std::collections::HashMap;
use std::f64::consts::TAU;

use crate::trimesh::TriMesh;
use crate::vec3::{self, V3};

fn finite(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// An axis-aligned box from `min` to `max` (m), each face split into `cells × cells` squares
/// (two triangles each): `12 cells²` triangles, `6 cells² + 2` vertices.
pub fn cuboid(min: [f64; 3], max: [f64; 3], cells: usize) -> TriMesh {
    if !finite(&min) || !finite(&max) {
        return TriMesh::default();
    }
    let n = cells.max(1);
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut vertices: Vec<V3> = Vec::new();
    let mut vertex = |g: [usize; 3]| -> u32 {
        *index.entry(g).or_insert_with(|| {
            vertices.push(std::array::from_fn(|k| min[k] + (max[k] - min[k]) * g[k] as f64 / n as f64));
            (vertices.len() - 1) as u32
        })
    };
    let mut triangles = Vec::with_capacity(12 * n * n);
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let g = |di: usize, dj: usize| {
                        let mut g = [0; 3];
                        g[a] = side;
                        g[u] = i + di;
                        g[v] = j + dj;
                        g
                    };
                    let q = [vertex(g(0, 0)), vertex(g(1, 0)), vertex(g(1, 1)), vertex(g(0, 1))];
                    if side == n {
                        triangles.push([q[0], q[1], q[2]]);
                        triangles.push([q[0], q[2], q[3]]);
                    } else {
                        triangles.push([q[0], q[2], q[1]]);
                        triangles.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    TriMesh::from_valid(vertices, triangles)
}

/// A geodesic sphere: an icosahedron whose faces are split in four `subdivisions` times and
/// whose vertices are pushed onto the sphere of `radius` (m) about `centre` (m):
/// `20 · 4^subdivisions` triangles (`subdivisions` is clamped to 8, 1.3 M triangles).
pub fn sphere(centre: [f64; 3], radius: f64, subdivisions: u32) -> TriMesh {
    if !finite(&centre) || !radius.is_finite() {
        return TriMesh::default();
    }
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut unit: Vec<V3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| vec3::normalize(v).unwrap_or(v))
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions.min(8) {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, unit: &mut Vec<V3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = vec3::scale(vec3::add(unit[a as usize], unit[b as usize]), 0.5);
                unit.push(vec3::normalize(m).unwrap_or(m));
                (unit.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for &[a, b, c] in &tris {
            let ab = midpoint(a, b, &mut unit);
            let bc = midpoint(b, c, &mut unit);
            let ca = midpoint(c, a, &mut unit);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let r = radius.abs();
    let vertices = unit.iter().map(|&u| vec3::add(centre, vec3::scale(u, r))).collect();
    outward(TriMesh::from_valid(vertices, tris))
}

/// A closed cylinder of `radius` (m) around the z axis from `z0` to `z1` (m), with
/// `segments` around and `stacks` along, capped by triangle fans.
pub fn cylinder(radius: f64, z0: f64, z1: f64, segments: usize, stacks: usize) -> TriMesh {
    cone(radius, radius, z0, z1, segments, stacks)
}

/// A closed truncated cone around the z axis: radius `r0` (m) at `z0` (m), `r1` at `z1`,
/// `segments` around and `stacks` along. A zero radius gives a pointed end (an apex vertex,
/// no cap); otherwise the ends are capped by triangle fans.
pub fn cone(r0: f64, r1: f64, z0: f64, z1: f64, segments: usize, stacks: usize) -> TriMesh {
    if !finite(&[r0, r1, z0, z1]) {
        return TriMesh::default();
    }
    let (segments, stacks) = (segments.max(3), stacks.max(1));
    let (r0, r1) = (r0.abs(), r1.abs());
    let mut vertices: Vec<V3> = Vec::new();
    let mut rings: Vec<Vec<u32>> = Vec::with_capacity(stacks + 1);
    for k in 0..=stacks {
        let s = k as f64 / stacks as f64;
        let (r, z) = (r0 + (r1 - r0) * s, z0 + (z1 - z0) * s);
        if r == 0.0 {
            vertices.push([0.0, 0.0, z]);
            rings.push(vec![(vertices.len() - 1) as u32; segments]);
        } else {
            let ring = (0..segments)
                .map(|j| {
                    let a = TAU * j as f64 / segments as f64;
                    vertices.push([r * a.cos(), r * a.sin(), z]);
                    (vertices.len() - 1) as u32
                })
                .collect();
            rings.push(ring);
        }
    }
    let mut triangles = Vec::new();
    let mut push = |t: [u32; 3]| {
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            triangles.push(t);
        }
    };
    for k in 0..stacks {
        for j in 0..segments {
            let jn = (j + 1) % segments;
            let (a, b, c, d) = (rings[k][j], rings[k][jn], rings[k + 1][jn], rings[k + 1][j]);
            push([a, b, c]);
            push([a, c, d]);
        }
    }
    for (k, z, r, up) in [(0, z0, r0, false), (stacks, z1, r1, true)] {
        if r > 0.0 {
            vertices.push([0.0, 0.0, z]);
            let centre = (vertices.len() - 1) as u32;
            for j in 0..segments {
                let (a, b) = (rings[k][j], rings[k][(j + 1) % segments]);
                push(if up { [centre, a, b] } else { [centre, b, a] });
            }
        }
    }
    outward(TriMesh::from_valid(vertices, triangles))
}

/// Turns a closed surface outward if it is wound inward (e.g. `z1 < z0`).
fn outward(mut mesh: TriMesh) -> TriMesh {
    if mesh.signed_volume() < 0.0 {
        mesh.flip_all();
    }
    mesh
}
