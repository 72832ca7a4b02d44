//! Centreline of a limb-like closed surface from cross-sections along an axis.
//!
//! How it works:
//! 1. choose a unit axis `a` ([`AxisChoice`]); a point's height is `a · p` (m);
//! 2. at each station height `h`, intersect every triangle with the plane `a · p = h`. A
//!    vertex exactly on the plane counts as above it, so each crossed triangle gives exactly
//!    one segment, whose ends lie on two of its edges;
//! 3. chain segments into loops by the edge each end lies on (exact, no distance matching):
//!    on a closed manifold surface every loop closes. Segments are directed by the
//!    triangle's winding, so an outward surface gives loops counter-clockwise about `a`;
//! 4. the largest loop by area gives the section: its polygon area, area centroid, perimeter
//!    and mean radius (perimeter-weighted mean distance from the centroid).
//!
//! # Examples
//! ```
//! # fn main() -> Result<(), lamina_mesh::CentrelineComputeError> {
//! use lamina_mesh::{CentrelineOptions, centreline, synthetic};
//! let limb = synthetic::cylinder(0.05, 0.0, 0.4, 128, 4);
//! let line = centreline(&limb, &CentrelineOptions { stations: 5, range: Some((0.1, 0.3)), ..Default::default() })?;
//! assert_eq!(line.sections.len(), 5);
//! assert!(line.sections[2].centroid[0].abs() < 1e-9);
//! assert!((line.sections[2].area - std::f64::consts::PI * 0.05 * 0.05).abs() < 1e-4);
//! # Ok(())
//! # }
//! ```

use rustc_hash::{FxHashMap, FxHashSet};

use crate::error::CentrelineComputeError;
use crate::trimesh::TriMesh;
use crate::vec3::{self, V3};

/// Which axis the stations are spaced along.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AxisChoice {
    /// The longest side of the bounding box (x, y or z, pointing +). The default.
    #[default]
    LongestBoxAxis,
    /// The principal axis of the vertices (largest variance), signed so that its largest
    /// component is positive. Weighted by vertex density, not by area.
    Principal,
    /// This direction (need not be unit length).
    Given([f64; 3]),
}

/// Settings of [`centreline()`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CentrelineOptions {
    /// Axis along which the stations are spaced. Default [`AxisChoice::LongestBoxAxis`].
    pub axis: AxisChoice,
    /// Number of stations. Default 32.
    pub stations: usize,
    /// Heights `(from, to)` along the axis (m), both included (`from` alone when
    /// `stations == 1`). Default `None`: the surface's extent along the axis cut into
    /// `stations` equal slabs, one station at the middle of each (so never at the very ends).
    pub range: Option<(f64, f64)>,
}

impl Default for CentrelineOptions {
    fn default() -> Self {
        Self { axis: AxisChoice::LongestBoxAxis, stations: 32, range: None }
    }
}

/// One cross-section of the surface by a plane perpendicular to the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossSection {
    /// Height of the plane along the axis (m).
    pub height: f64,
    /// Area centroid of the largest loop (m).
    pub centroid: [f64; 3],
    /// Area enclosed by the largest loop (m²).
    pub area: f64,
    /// Perimeter of the largest loop (m).
    pub perimeter: f64,
    /// Perimeter-weighted mean distance from the centroid to the largest loop (m).
    pub mean_radius: f64,
    /// Radius of the circle of the same area, `√(area / π)` (m).
    pub equivalent_radius: f64,
    /// Closed loops in the plane (1 for a single limb; more where, e.g., toes are cut).
    pub loops: usize,
    /// Chains that did not close (0 on a closed surface).
    pub open_chains: usize,
}

/// A centreline: the sections found at each station, in station order.
#[derive(Clone, Debug, PartialEq)]
pub struct Centreline {
    /// Unit axis used.
    pub axis: [f64; 3],
    /// Sections at the stations where the plane cut the surface in a closed loop.
    pub sections: Vec<CrossSection>,
    /// Heights (m) of stations where it did not.
    pub missed: Vec<f64>,
}

impl Centreline {
    /// The centroids as a polyline (m).
    pub fn points(&self) -> Vec<[f64; 3]> {
        self.sections.iter().map(|s| s.centroid).collect()
    }

    /// The section whose station is nearest `height` (m); `None` without sections.
    pub fn nearest(&self, height: f64) -> Option<&CrossSection> {
        self.sections.iter().min_by(|a, b| (a.height - height).abs().total_cmp(&(b.height - height).abs()))
    }
}

/// The unit axis `choice` selects for `mesh`.
///
/// # Errors
/// [`CentrelineComputeError::EmptyMesh`] without vertices; [`CentrelineComputeError::InvalidAxis`]
/// for a zero or non-finite given axis.
pub fn resolve_axis(mesh: &TriMesh, choice: AxisChoice) -> Result<[f64; 3], CentrelineComputeError> {
    let bbox = mesh.bounding_box().ok_or(CentrelineComputeError::EmptyMesh)?;
    let mut longest = [0.0; 3];
    longest[bbox.longest_axis()] = 1.0;
    match choice {
        AxisChoice::LongestBoxAxis => Ok(longest),
        AxisChoice::Given(a) => {
            vec3::normalize(a).filter(|a| vec3::is_finite(*a)).ok_or(CentrelineComputeError::InvalidAxis)
        }
        AxisChoice::Principal => Ok(principal_axis(mesh.vertices()).unwrap_or(longest)),
    }
}

fn principal_axis(points: &[V3]) -> Option<V3> {
    let n = points.len() as f64;
    let mean = vec3::scale(points.iter().fold([0.0; 3], |s, p| vec3::add(s, *p)), 1.0 / n);
    let mut c = [[0.0; 3]; 3];
    for p in points {
        let d = vec3::sub(*p, mean);
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] += d[i] * d[j];
            }
        }
    }
    // Power iteration from the row of largest diagonal: converges to the top eigenvector.
    let start = (0..3).max_by(|&i, &j| c[i][i].total_cmp(&c[j][j]))?;
    let mut v = vec3::normalize(c[start])?;
    for _ in 0..200 {
        let w = [vec3::dot(c[0], v), vec3::dot(c[1], v), vec3::dot(c[2], v)];
        v = vec3::normalize(w)?;
    }
    let big = (0..3).max_by(|&i, &j| v[i].abs().total_cmp(&v[j].abs()))?;
    Some(if v[big] < 0.0 { vec3::scale(v, -1.0) } else { v })
}

/// Computes the centreline of `mesh` (see the [module docs](self)).
///
/// # Errors
/// [`CentrelineComputeError`]: empty mesh, invalid axis or range, zero stations, or no
/// station cuts the surface in a closed loop.
pub fn centreline(mesh: &TriMesh, options: &CentrelineOptions) -> Result<Centreline, CentrelineComputeError> {
    if mesh.is_empty() {
        return Err(CentrelineComputeError::EmptyMesh);
    }
    if options.stations == 0 {
        return Err(CentrelineComputeError::NoStations);
    }
    let axis = resolve_axis(mesh, options.axis)?;
    let n = options.stations;
    let heights: Vec<f64> = match options.range {
        Some((from, to)) => {
            if !from.is_finite() || !to.is_finite() {
                return Err(CentrelineComputeError::InvalidRange);
            }
            if n == 1 { vec![from] } else { (0..n).map(|i| from + (to - from) * i as f64 / (n - 1) as f64).collect() }
        }
        None => {
            let (lo, hi) = mesh
                .vertices()
                .iter()
                .map(|p| vec3::dot(*p, axis))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), h| (lo.min(h), hi.max(h)));
            (0..n).map(|i| lo + (hi - lo) * (i as f64 + 0.5) / n as f64).collect()
        }
    };
    let mut line = Centreline { axis, sections: Vec::with_capacity(n), missed: Vec::new() };
    for h in heights {
        match cross_section(mesh, axis, h) {
            Some(s) => line.sections.push(s),
            None => line.missed.push(h),
        }
    }
    if line.sections.is_empty() {
        return Err(CentrelineComputeError::NoCrossSection);
    }
    Ok(line)
}

/// Segment of a slice: from point `p` on edge `from` to the point on edge `to`.
struct Segment {
    from: u64,
    to: u64,
    p: V3,
}

fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// The section of `mesh` by the plane `axis · p = height` (m); `axis` need not be unit.
/// `None` when the plane cuts no closed loop of positive area, or `axis` is zero or not
/// finite.
pub fn cross_section(mesh: &TriMesh, axis: [f64; 3], height: f64) -> Option<CrossSection> {
    let n = vec3::normalize(axis)?;
    if !height.is_finite() {
        return None;
    }
    let verts = mesh.vertices();
    let dist: Vec<f64> = verts.iter().map(|p| vec3::dot(*p, n) - height).collect();
    let cut = |a: u32, b: u32| {
        // Canonical order so both triangles on an edge compute the same point.
        let (a, b) = (a.min(b) as usize, a.max(b) as usize);
        let s = dist[a] / (dist[a] - dist[b]);
        vec3::lerp(verts[a], verts[b], s)
    };
    let mut segs: Vec<Segment> = Vec::new();
    for tri in mesh.triangles() {
        let above = tri.map(|i| dist[i as usize] >= 0.0);
        if above[0] == above[1] && above[1] == above[2] {
            continue;
        }
        let lone = (0..3).find(|&k| above[k] != above[(k + 1) % 3] && above[k] != above[(k + 2) % 3])?;
        let (l, nx, pv) = (tri[lone], tri[(lone + 1) % 3], tri[(lone + 2) % 3]);
        let (e1, e2) = ((l, nx), (pv, l));
        let (f, t) = if above[lone] { (e1, e2) } else { (e2, e1) };
        segs.push(Segment { from: edge_key(f.0, f.1), to: edge_key(t.0, t.1), p: cut(f.0, f.1) });
    }
    if segs.is_empty() {
        return None;
    }
    let mut by_start: FxHashMap<u64, usize> = FxHashMap::default();
    let ends: FxHashSet<u64> = segs.iter().map(|s| s.to).collect();
    for (i, s) in segs.iter().enumerate() {
        by_start.insert(s.from, i);
    }
    let mut visited = vec![false; segs.len()];
    let mut open_chains = 0;
    // Chains that start where no segment ends are open; walk them off first.
    for i in 0..segs.len() {
        if !visited[i] && !ends.contains(&segs[i].from) {
            open_chains += 1;
            let mut j = i;
            while !visited[j] {
                visited[j] = true;
                match by_start.get(&segs[j].to) {
                    Some(&k) => j = k,
                    None => break,
                }
            }
        }
    }
    let (u, v) = plane_basis(n);
    let mut loops = 0;
    let mut best: Option<(f64, Vec<V3>)> = None;
    let mut poly: Vec<V3> = Vec::new();
    for i in 0..segs.len() {
        if visited[i] {
            continue;
        }
        poly.clear();
        let mut j = i;
        let closed = loop {
            visited[j] = true;
            poly.push(segs[j].p);
            match by_start.get(&segs[j].to) {
                Some(&k) if k == i => break true,
                Some(&k) if !visited[k] => j = k,
                _ => break false,
            }
        };
        if !closed || poly.len() < 3 {
            open_chains += usize::from(!closed);
            continue;
        }
        loops += 1;
        let area = polygon_area(&poly, u, v).abs();
        if best.as_ref().is_none_or(|(a, _)| area > *a) {
            best = Some((area, poly.clone()));
        }
    }
    // A plane that only touches the surface (at a vertex or along an edge) encloses nothing.
    let (_, poly) = best.filter(|(a, _)| *a > 0.0)?;
    let (area, c2) = polygon_area_centroid(&poly, u, v);
    let origin = poly[0];
    let centroid = vec3::add(origin, vec3::add(vec3::scale(u, c2[0]), vec3::scale(v, c2[1])));
    let (mut perimeter, mut weighted) = (0.0, 0.0);
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let len = vec3::norm(vec3::sub(b, a));
        perimeter += len;
        weighted += len * vec3::norm(vec3::sub(vec3::lerp(a, b, 0.5), centroid));
    }
    let area = area.abs();
    Some(CrossSection {
        height,
        centroid,
        area,
        perimeter,
        mean_radius: if perimeter > 0.0 { weighted / perimeter } else { 0.0 },
        equivalent_radius: (area / std::f64::consts::PI).sqrt(),
        loops,
        open_chains,
    })
}

/// Orthonormal `u`, `v` with `u × v = n`.
fn plane_basis(n: V3) -> (V3, V3) {
    let k = (0..3).min_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs())).unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let u = vec3::normalize(vec3::cross(n, e)).unwrap_or([1.0, 0.0, 0.0]);
    (u, vec3::cross(n, u))
}

fn polygon_area(poly: &[V3], u: V3, v: V3) -> f64 {
    polygon_area_centroid(poly, u, v).0
}

/// Signed area and centroid `(x, y)` in the `u, v` frame with origin `poly[0]`.
fn polygon_area_centroid(poly: &[V3], u: V3, v: V3) -> (f64, [f64; 2]) {
    let o = poly[0];
    let xy = |p: V3| {
        let d = vec3::sub(p, o);
        (vec3::dot(d, u), vec3::dot(d, v))
    };
    let (mut a2, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for k in 0..poly.len() {
        let (x0, y0) = xy(poly[k]);
        let (x1, y1) = xy(poly[(k + 1) % poly.len()]);
        let w = x0 * y1 - x1 * y0;
        a2 += w;
        cx += (x0 + x1) * w;
        cy += (y0 + y1) * w;
    }
    if a2 == 0.0 {
        return (0.0, [0.0, 0.0]);
    }
    (a2 / 2.0, [cx / (3.0 * a2), cy / (3.0 * a2)])
}
