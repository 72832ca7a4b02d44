//! The tool's contact with the skin *surface*, not only its nodes: a point shell on the outer
//! skin's triangles (the Voxmap-PointShell idea, McNeely et al. 1999). Each triangle carries
//! `m²` sample points, the centroids of its `m × m` sub-triangles, spaced at most half the tool's
//! (smallest) radius apart, so a sphere pressing anywhere on the skin meets samples; a node-only contact
//! lets the tool slip between nodes of a coarse grid (40 mm rows on the default limb against a
//! 12 mm tool) and sink through the skin with no force.
//!
//! A sample at barycentric `w` of triangle `(a, b, c)` sits at `Σ wᵢ xᵢ`; inside the sphere it
//! is pushed out along the centre-to-sample direction with `k_s (r − d)`, and its force goes to
//! the triangle's nodes by the same weights. `k_s` is the penalty pressure times the sample's
//! share of the triangle's rest area, the pressure chosen so that a skin node whose whole
//! neighbourhood is in contact feels at most the tool's per-node `stiffness`: the critical time
//! step's allowance for the tool (`stiffness / m_min`) still holds.

use crate::model::{Model, Surface};

/// The name of the outer skin surface the generator and the layered block write.
pub const SKIN_SURFACE: &str = "skin_outer";

/// The largest sub-division of a triangle's sides (`m`): `m²` samples per triangle. A contact
/// visits only the samples under the sphere ([`for_each_sample_near`]), so a fine shell costs
/// in proportion to the contact's area, not the triangle's: 64 keeps samples at most half a
/// 3 mm tool's radius apart on the default limb's 40 mm cells.
const MAX_SUBDIVISION: u32 = 64;

/// One skin triangle's point shell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellTriangle {
    /// Its nodes.
    pub nodes: [u32; 3],
    /// Sub-divisions per side: `m²` samples.
    pub subdivision: u32,
    /// Each sample's penalty stiffness as a fraction of the tool's per-node stiffness.
    pub sample_weight: f64,
}

/// The point shell of a model's outer skin for a tool of a given radius and per-node stiffness.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinShell {
    /// Triangles with their sampling.
    pub triangles: Vec<ShellTriangle>,
    /// Whether node `i` is a vertex of the shell (its contact goes through the samples).
    pub on_shell: Vec<bool>,
}

/// `model`'s outer skin ([`SKIN_SURFACE`]) and, per node, whether it is a corner of one of
/// its triangles (triangles naming a node out of range are skipped); `None` without one.
pub(super) fn outer_skin(model: &Model) -> Option<(&Surface, Vec<bool>)> {
    let n = model.nodes.len();
    let skin = model.surfaces.iter().find(|s| s.name == SKIN_SURFACE)?;
    let mut on_skin = vec![false; n];
    for t in skin.triangles.iter().filter(|t| t.iter().all(|&i| (i as usize) < n)) {
        for &i in t {
            on_skin[i as usize] = true;
        }
    }
    Some((skin, on_skin))
}

/// The largest share of `model`'s outer skin (the surface named `skin_outer`) any node
/// carries, m²: a third of the area of each skin triangle it is a corner of. The tool's
/// per-node stiffness over this area is the shell's penalty pressure per metre of penetration,
/// so a tool given a stiffness per area (N/m per m² of skin) feels the same on any grid with
/// this per-node stiffness.
/// `None` when the model has no outer skin or it has no area.
///
/// # Examples
///
/// ```
/// use lamina_core::scene::Scene;
/// use lamina_core::solver::largest_skin_node_area;
///
/// let model = Scene::builtin_default().build_model()?;
/// let area = largest_skin_node_area(&model).expect("the default limb has an outer skin");
/// // The default limb's skin cells are about 40 mm along and 16 mm around.
/// assert!(area > 4e-4 && area < 8e-4, "{area} m²");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn largest_skin_node_area(model: &Model) -> Option<f64> {
    skin_areas(model, outer_skin(model)?.0).0
}

/// A skin triangle's nodes, its area (m²) and its longest edge (m).
type TriangleArea = ([u32; 3], f64, f64);

/// The largest node share of `skin`'s area (a third of each adjacent triangle's), m², when
/// positive and finite, and each triangle naming nodes in range with its area and longest edge.
fn skin_areas(model: &Model, skin: &Surface) -> (Option<f64>, Vec<TriangleArea>) {
    let n = model.nodes.len();
    let p = &model.nodes.position;
    let valid = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < n);
    let mut share = vec![0.0_f64; n];
    let mut areas = Vec::with_capacity(skin.triangles.len());
    for t in skin.triangles.iter().filter(|t| valid(t)) {
        let [a, b, c] = t.map(|i| p[i as usize]);
        let area = 0.5 * norm(cross(sub(b, a), sub(c, a)));
        for &i in t {
            share[i as usize] += area / 3.0;
        }
        areas.push((*t, area, longest_edge(a, b, c)));
    }
    let largest = share.into_iter().fold(0.0, f64::max);
    ((largest > 0.0 && largest.is_finite()).then_some(largest), areas)
}

impl SkinShell {
    /// The shell of `model`'s [`SKIN_SURFACE`] for a sphere of `radius` m (samples at most
    /// `radius / 2` apart); empty (node contact only) when the model has no such surface or it
    /// has no area. A sample's stiffness is `weight ×` the tool's per-node stiffness.
    pub fn of_model(model: &Model, radius: f64) -> Self {
        let Some((skin, on_shell)) = outer_skin(model) else {
            return Self::default();
        };
        let (Some(largest_share), areas) = skin_areas(model, skin) else {
            return Self::default();
        };
        // Penalty pressure per unit node stiffness: 1 / (largest node share), per m² of skin.
        let pressure = 1.0 / largest_share;
        let spacing = 0.5 * radius;
        let triangles = areas
            .into_iter()
            .filter(|(_, area, _)| *area > 0.0)
            .map(|(nodes, area, edge)| {
                let subdivision = ((edge / spacing).ceil() as u32).clamp(1, MAX_SUBDIVISION);
                let samples = f64::from(subdivision * subdivision);
                ShellTriangle { nodes, subdivision, sample_weight: pressure * area / samples }
            })
            .collect();
        Self { triangles, on_shell }
    }
}

/// Calls `f(w)` with the barycentric weights of the `m²` sub-triangle centroids of a triangle
/// divided `m` times per side: the `m(m+1)/2` upward ones, then the `m(m−1)/2` downward ones.
pub fn for_each_sample(m: u32, mut f: impl FnMut([f64; 3])) {
    let inv = 1.0 / f64::from(m);
    for i in 0..m {
        for j in 0..m - i {
            let (u, v) = ((f64::from(i) + 1.0 / 3.0) * inv, (f64::from(j) + 1.0 / 3.0) * inv);
            f([u, v, 1.0 - u - v]);
        }
    }
    for i in 0..m {
        for j in 0..(m - i).saturating_sub(1) {
            let (u, v) = ((f64::from(i) + 2.0 / 3.0) * inv, (f64::from(j) + 2.0 / 3.0) * inv);
            f([u, v, 1.0 - u - v]);
        }
    }
}

/// As [`for_each_sample`], for only the samples of triangle `v` that can lie within `radius`
/// of `centre` (a box in barycentric coordinates around the centre's projection, `radius`
/// times each coordinate's gradient wide), plus possibly a few more. Falls back to every
/// sample when the triangle is degenerate or a value is not finite.
pub fn for_each_sample_near(m: u32, v: &[[f64; 3]; 3], centre: [f64; 3], radius: f64, mut f: impl FnMut([f64; 3])) {
    // p = u v0 + w v1 + (1 − u − w) v2: solve the normal equations for (u, w) of the centre's
    // projection; the inverse Gram matrix's diagonal is |∇u|², |∇w|² in the plane.
    let (e0, e1, d) = (sub(v[0], v[2]), sub(v[1], v[2]), sub(centre, v[2]));
    let (g00, g01, g11) = (dot(e0, e0), dot(e0, e1), dot(e1, e1));
    let det = g00 * g11 - g01 * g01;
    let (b0, b1) = (dot(e0, d), dot(e1, d));
    let (u, w) = ((g11 * b0 - g01 * b1) / det, (g00 * b1 - g01 * b0) / det);
    let (du, dw) = (radius * (g11 / det).sqrt(), radius * (g00 / det).sqrt());
    let mf = f64::from(m);
    // The indices i with (i + offset) / m in [lo, hi], within 0..m.
    let range = |lo: f64, hi: f64, offset: f64| {
        let first = (mf * lo - offset).ceil().max(0.0);
        let last = (mf * hi - offset).floor().min(mf - 1.0);
        (first <= last).then_some(first as u32..=last as u32)
    };
    if !(det > 1e-12 * g00 * g11 && [u, w, du, dw].iter().all(|x| x.is_finite())) {
        for_each_sample(m, f);
        return;
    }
    let inv = 1.0 / mf;
    // Upward sub-triangles (centroid offset 1/3) have j < m − i, downward ones (2/3) j < m − i − 1.
    for (offset, below_edge) in [(1.0 / 3.0, 1), (2.0 / 3.0, 2)] {
        let (Some(is), Some(js)) = (range(u - du, u + du, offset), range(w - dw, w + dw, offset)) else { continue };
        for i in is {
            let Some(j_last) = (m - i).checked_sub(below_edge) else { continue };
            for j in *js.start()..=(*js.end()).min(j_last) {
                let (a, b) = ((f64::from(i) + offset) * inv, (f64::from(j) + offset) * inv);
                f([a, b, 1.0 - a - b]);
            }
        }
    }
}

/// Squared distance from `p` to the triangle `(a, b, c)` (its closest point, by the Voronoi
/// regions of its vertices, edges and face: Ericson, *Real-Time Collision Detection*, 5.1.5).
pub fn distance2_to_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return dot(ap, ap);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return dot(bp, bp);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return dist2(p, add_scaled(a, ab, v));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return dot(cp, cp);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return dist2(p, add_scaled(a, ac, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return dist2(p, add_scaled(b, sub(c, b), w));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    dist2(p, add_scaled(add_scaled(a, ab, v), ac, w))
}

#[inline]
pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn add_scaled(a: [f64; 3], d: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + s * d[0], a[1] + s * d[1], a[2] + s * d[2]]
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}

#[inline]
pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn longest_edge(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    norm(sub(b, a)).max(norm(sub(c, b))).max(norm(sub(a, c)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_sub_triangle_centroids_covering_the_triangle_works() {
        for m in 1..=6 {
            let mut samples = Vec::new();
            for_each_sample(m, |w| samples.push(w));
            assert_eq!(samples.len() as u32, m * m, "m = {m}");
            // Inside the triangle, none on an edge, and their mean is the centroid (they
            // tile the triangle in equal areas).
            let mut mean = [0.0; 3];
            for w in &samples {
                assert!(w.iter().all(|&x| x > 0.0 && x < 1.0), "{w:?}");
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                for k in 0..3 {
                    mean[k] += w[k] / samples.len() as f64;
                }
            }
            assert!(mean.iter().all(|&x| (x - 1.0 / 3.0).abs() < 1e-12), "m = {m}: {mean:?}");
            // Distinct points.
            for a in 0..samples.len() {
                for b in a + 1..samples.len() {
                    let d: f64 = (0..3).map(|k| (samples[a][k] - samples[b][k]).abs()).sum();
                    assert!(d > 1e-9, "m = {m}: samples {a} and {b} coincide");
                }
            }
        }
    }

    #[test]
    fn samples_near_a_sphere_are_all_found_works() {
        // Every sample within the radius (by visiting them all) is visited by the windowed
        // sampler, exactly once; and it visits far fewer when the sphere is small.
        let v = [[0.0, 0.0, 0.0], [0.04, 0.003, 0.0], [0.01, -0.002, 0.035]];
        let mut state = 99u64;
        let mut rand = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let point = |w: [f64; 3]| [0, 1, 2].map(|k| w[0] * v[0][k] + w[1] * v[1][k] + w[2] * v[2][k]);
        let (mut visited, mut total) = (0usize, 0usize);
        for case in 0..400 {
            let m = [1, 2, 7, 16, 64][case % 5];
            let radius = 0.001 + 0.011 * rand();
            let centre = [0.06 * rand() - 0.01, 0.01 * rand() - 0.005, 0.05 * rand() - 0.01];
            let inside = |w: [f64; 3]| dist2(point(w), centre) < radius * radius;
            let key = |w: [f64; 3]| ((w[0] * 3e3).round() as i64, (w[1] * 3e3).round() as i64);
            let mut all = Vec::new();
            for_each_sample(m, |w| all.push(key(w)));
            let mut wanted = Vec::new();
            for_each_sample(m, |w| {
                if inside(w) {
                    wanted.push(key(w));
                }
            });
            let mut near = Vec::new();
            for_each_sample_near(m, &v, centre, radius, |w| near.push(key(w)));
            let mut unique = near.clone();
            unique.sort_unstable();
            unique.dedup();
            assert_eq!(unique.len(), near.len(), "m = {m}: a sample visited twice");
            assert!(near.iter().all(|k| all.contains(k)), "m = {m}: a point that is not a sample");
            assert!(wanted.iter().all(|k| near.contains(k)), "m = {m}, r = {radius}, {centre:?}: a sample missed");
            visited += near.len();
            total += all.len();
        }
        assert!(visited * 4 < total, "windowing visits {visited} of {total} samples");
    }

    #[test]
    fn distance_to_triangle_matches_brute_force_works() {
        // Against the minimum over a fine barycentric sampling of the triangle, for points in
        // every Voronoi region (vertices, edges, face, above and below).
        let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.1], [0.3, 1.5, -0.2]);
        let mut state = 12345u64;
        let mut rand = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 5.0 - 2.0
        };
        for _ in 0..300 {
            let p = [rand(), rand(), rand()];
            let mut best = f64::INFINITY;
            let n = 200;
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (f64::from(i) / f64::from(n), f64::from(j) / f64::from(n));
                    let q = [0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]));
                    best = best.min(dist2(p, q));
                }
            }
            let exact = distance2_to_triangle(p, a, b, c);
            assert!(exact <= best + 1e-12, "{p:?}: {exact} above the sampled {best}");
            assert!(best.sqrt() - exact.sqrt() < 0.02, "{p:?}: {exact} vs sampled {best}");
        }
    }

    #[test]
    fn shell_stiffness_per_node_is_bounded_by_the_tool_stiffness_works() {
        let scene = crate::scene::Scene::builtin_default();
        let model = scene.build_model().unwrap();
        let (radius, stiffness) = (0.012, 300.0);
        let shell = SkinShell::of_model(&model, radius);
        assert!(!shell.triangles.is_empty());
        // Whole neighbourhood in contact, normals aligned: Σ_s w_i k_s per node.
        let mut per_node = vec![0.0; model.nodes.len()];
        for t in &shell.triangles {
            for_each_sample(t.subdivision, |w| {
                for k in 0..3 {
                    per_node[t.nodes[k] as usize] += w[k] * t.sample_weight * stiffness;
                }
            });
            // Samples at most half a radius apart along the longest edge.
            let p = t.nodes.map(|i| model.nodes.position[i as usize]);
            assert!(longest_edge(p[0], p[1], p[2]) / f64::from(t.subdivision) <= 0.5 * radius + 1e-12);
        }
        let max = per_node.iter().copied().fold(0.0, f64::max);
        assert!(max <= stiffness * (1.0 + 1e-9) && max > 0.5 * stiffness, "{max}");
    }
}
