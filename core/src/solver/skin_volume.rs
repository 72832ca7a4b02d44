//! The skin layer's volume: a restoring force on each of its tetrahedra, so that the thin
//! skin cannot turn inside out.
//!
//! A mass-spring layer resists changes of length only. The paper's skin layer is 2 mm thick
//! on cells of centimetres, so its springs lie almost along the surface: a tool pressing the
//! skin, or gravity, can push an outer-skin triangle past its bottom node. The mirrored
//! tetrahedron has the same spring lengths, so it is an equilibrium too, and the skin stays
//! inverted after the press (the fat beneath shows through it). The volume energy of Teschner,
//! Heidelberger, Müller and Gross ("A versatile and robust model for geometrically complex
//! deformable solids", CGI 2004) removes that second equilibrium: per tetrahedron
//!
//! `E = ½ k (V − V₀)² / |V₀|`, with `V = (x₁ − x₀) · ((x₂ − x₀) × (x₃ − x₀)) / 6` signed,
//!
//! and node `i` feels `F_i = −k (V − V₀) / |V₀| · ∂V/∂x_i`. An inverted tetrahedron has
//! `V ≈ −V₀` and is pushed back with the force of doubling its volume. `k` (Pa) is the
//! scene's `skin_volume`. The forces of one tetrahedron sum to zero and have no moment
//! (`V` is invariant under translation and rotation), so momentum is conserved.
//!
//! The tetrahedra are found in the model itself: each triangle `(a, b, c)` of the outer skin
//! surface and the node, off that surface, spring-connected to all three corners and nearest
//! the triangle's centroid (the generator's skin-bottom mass of that triangle).

use super::skin_contact::{cross, dot, outer_skin, sub};
use super::vec3s::Vec3s;
use crate::model::{Model, NodeKind};
use crate::real::Real;

/// The skin's tetrahedra with their rest volumes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinVolume {
    /// Nodes of each tetrahedron: the skin triangle's three corners, then its bottom node.
    pub tets: Vec<[u32; 4]>,
    /// Signed rest volume of each tetrahedron, m³ (never zero).
    pub rest_volume: Vec<f64>,
    /// `1 / (36 |V₀|)` of each tetrahedron, 1/m³ (the kernel works with `6V` and `6∇V`, and
    /// multiplies, never divides).
    inv_36_abs_rest: Vec<f64>,
    /// Every node of some tetrahedron, once each, ascending.
    pub nodes: Vec<u32>,
}

impl SkinVolume {
    /// The tetrahedra of `model`'s outer skin
    /// (the surface named `skin_outer`); empty when the model has no such
    /// surface. Triangles with no bottom node, or whose tetrahedron is flat (volume under 10⁻⁶
    /// of its longest edge cubed), get none.
    pub fn of_model(model: &Model) -> Self {
        let n = model.nodes.len();
        let Some((skin, on_skin)) = outer_skin(model) else {
            return Self::default();
        };
        let p = &model.nodes.position;
        // Neighbours of the skin's nodes through springs.
        let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
        let s = &model.springs;
        for (&a, &b) in s.a.iter().zip(&s.b) {
            if (a as usize) < n && (b as usize) < n {
                if on_skin[a as usize] {
                    neighbours[a as usize].push(b);
                }
                if on_skin[b as usize] {
                    neighbours[b as usize].push(a);
                }
            }
        }
        let mut out = Self::default();
        for t in skin.triangles.iter().filter(|t| t.iter().all(|&i| (i as usize) < n)) {
            let [a, b, c] = t.map(|i| i as usize);
            let centroid = [0, 1, 2].map(|k| (p[a][k] + p[b][k] + p[c][k]) / 3.0);
            let bottom = neighbours[a]
                .iter()
                .copied()
                .filter(|&d| !on_skin[d as usize] && neighbours[b].contains(&d) && neighbours[c].contains(&d))
                .min_by(|&d, &e| {
                    let (dd, de) = (sub(p[d as usize], centroid), sub(p[e as usize], centroid));
                    dot(dd, dd).total_cmp(&dot(de, de))
                });
            let Some(d) = bottom else { continue };
            let tet = [t[0], t[1], t[2], d];
            let x = tet.map(|i| p[i as usize]);
            let v0 = signed_volume(x);
            let edge = (0..4)
                .flat_map(|i| (i + 1..4).map(move |j| (i, j)))
                .map(|(i, j)| dot(sub(x[i], x[j]), sub(x[i], x[j])).sqrt())
                .fold(0.0, f64::max);
            if v0.abs() > 1e-6 * edge.powi(3) && v0.is_finite() {
                out.tets.push(tet);
                out.rest_volume.push(v0);
            }
        }
        out.inv_36_abs_rest = out.rest_volume.iter().map(|v| 1.0 / (36.0 * v.abs())).collect();
        out.nodes = out.tets.iter().flatten().copied().collect();
        out.nodes.sort_unstable();
        out.nodes.dedup();
        out
    }

    /// Keeps only the tetrahedra with a corner for which `free` is true: one whose corners
    /// are all held moves nothing (multirate stepping holds most of the model in each half).
    pub fn retain_touching(&mut self, free: impl Fn(u32) -> bool) {
        let keep: Vec<bool> = self.tets.iter().map(|t| t.iter().any(|&i| free(i))).collect();
        let mut k = keep.iter();
        self.tets.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        self.rest_volume.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        self.inv_36_abs_rest.retain(|_| *k.next().unwrap_or(&false));
        self.nodes = self.tets.iter().flatten().copied().collect();
        self.nodes.sort_unstable();
        self.nodes.dedup();
    }

    /// Takes the volume term off every tetrahedron with both `a` and `b` among its corners
    /// (a cut through their edge); returns how many lost it now. Allocates nothing.
    pub fn remove_tets_with_edge(&mut self, a: u32, b: u32) -> usize {
        let mut removed = 0;
        for (tet, inv) in self.tets.iter().zip(self.inv_36_abs_rest.iter_mut()) {
            if *inv != 0.0 && tet.contains(&a) && tet.contains(&b) {
                *inv = 0.0;
                removed += 1;
            }
        }
        removed
    }

    /// Whether tetrahedron `t` still has its volume term (false once cut through).
    pub fn is_intact(&self, t: usize) -> bool {
        self.inv_36_abs_rest.get(t).is_some_and(|&inv| inv != 0.0)
    }

    /// Adds the volume forces at positions `x` (m) for stiffness `k` (Pa) into `f` (N). Nodes
    /// of [`SkinVolume::nodes`] must have been zeroed or hold other forces of this evaluation.
    pub fn add_forces<T: Real>(&self, k: f64, x: &Vec3s<T>, f: &mut Vec3s<T>) {
        let [xs, ys, zs] = x.slices();
        let [fx, fy, fz] = f.slices_mut();
        let rest = self.rest_volume.iter().zip(&self.inv_36_abs_rest);
        for (tet, (&v0, &inv)) in self.tets.iter().zip(rest) {
            // Written out: LLVM leaves `array::map` closures out of line here (4x slower).
            let i = [tet[0] as usize, tet[1] as usize, tet[2] as usize, tet[3] as usize];
            let at = |n: usize| [xs[n].to_f64(), ys[n].to_f64(), zs[n].to_f64()];
            // Six times the volume and its gradient: F_i = −k (V − V₀)/|V₀| ∂V/∂x_i.
            let (v6, grad6) = six_volume_and_gradient([at(i[0]), at(i[1]), at(i[2]), at(i[3])]);
            let scale = -k * (v6 - 6.0 * v0) * inv;
            for (&n, g) in i.iter().zip(grad6) {
                fx[n] += T::from_f64(scale * g[0]);
                fy[n] += T::from_f64(scale * g[1]);
                fz[n] += T::from_f64(scale * g[2]);
            }
        }
    }

    /// `√(k/|V₀|) ∇V` of tetrahedron `t` at positions `x` (m) for stiffness `k` (Pa), per
    /// corner, in `T`: the term's Gauss-Newton stiffness `k/|V₀| ∇V ∇Vᵀ` (positive
    /// semi-definite; the implicit solvers' tangent) is its outer product. Computed in f64.
    pub(crate) fn weighted_gradient<T: Real>(&self, t: usize, k: f64, x: &Vec3s<T>) -> [[T; 3]; 4] {
        let [xs, ys, zs] = x.slices();
        let tet = &self.tets[t];
        // Written out as in `add_forces`: `array::map` closures stay out of line here.
        let at = |n: u32| [xs[n as usize].to_f64(), ys[n as usize].to_f64(), zs[n as usize].to_f64()];
        let (_, g6) = six_volume_and_gradient([at(tet[0]), at(tet[1]), at(tet[2]), at(tet[3])]);
        // ∇V = ∇(6V)/6, so √(k/|V₀|) ∇V = √(k/(36|V₀|)) ∇(6V).
        let w = (k * self.inv_36_abs_rest[t]).sqrt();
        let scaled = |g: [f64; 3]| [T::from_f64(w * g[0]), T::from_f64(w * g[1]), T::from_f64(w * g[2])];
        [scaled(g6[0]), scaled(g6[1]), scaled(g6[2]), scaled(g6[3])]
    }

    /// `y += scale Σ_t g_t (g_t · p)`, `g_t` tetrahedron `t`'s [`weighted_gradient`]s in
    /// `grads` (one entry per tetrahedron): the product of `p` with the term's Gauss-Newton
    /// stiffness, times `scale`.
    ///
    /// [`weighted_gradient`]: SkinVolume::weighted_gradient
    pub(crate) fn add_stiffness_product<T: Real>(
        &self,
        grads: &[[[T; 3]; 4]],
        scale: T,
        p: &Vec3s<T>,
        y: &mut Vec3s<T>,
    ) {
        let [px, py, pz] = p.slices();
        let [yx, yy, yz] = y.slices_mut();
        for (tet, g) in self.tets.iter().zip(grads) {
            let mut gp = T::ZERO;
            for (&i, gi) in tet.iter().zip(g) {
                let i = i as usize;
                gp += gi[0] * px[i] + gi[1] * py[i] + gi[2] * pz[i];
            }
            let s = scale * gp;
            for (&i, gi) in tet.iter().zip(g) {
                let i = i as usize;
                yx[i] += s * gi[0];
                yy[i] += s * gi[1];
                yz[i] += s * gi[2];
            }
        }
    }

    /// `|∇V|²` of tetrahedron `tet` at the model's rest positions, m⁴.
    pub fn rest_gradient_norm2(&self, model: &Model, tet: &[u32; 4]) -> f64 {
        let (_, grad) = volume_and_gradient(tet.map(|i| model.nodes.position[i as usize]));
        grad.iter().map(|g| dot(*g, *g)).sum()
    }

    /// Energy of the volume term at positions `x` (m) for stiffness `k` (Pa), J.
    pub fn energy<T: Real>(&self, k: f64, x: &Vec3s<T>) -> f64 {
        self.tets
            .iter()
            .zip(&self.rest_volume)
            .zip(&self.inv_36_abs_rest)
            .filter(|(_, inv)| **inv != 0.0)
            .map(|((tet, &v0), _)| {
                let v = signed_volume(tet.map(|i| x.get_f64(i as usize)));
                0.5 * k * (v - v0) * (v - v0) / v0.abs()
            })
            .sum()
    }

    /// Each tetrahedron's volume over its rest volume at positions `x`: 1 at rest, negative
    /// when inverted.
    pub fn volume_ratios<'a, T: Real>(&'a self, x: &'a Vec3s<T>) -> impl Iterator<Item = f64> + 'a {
        self.tets.iter().zip(&self.rest_volume).map(|(tet, &v0)| signed_volume(tet.map(|i| x.get_f64(i as usize))) / v0)
    }

    /// An upper bound on the largest eigenvalue of `M⁻¹K` the term adds at rest, 1/s², for
    /// stiffness `k` (Pa): Gershgorin's row sums of the stiffness `k/|V₀| ∇V ∇Vᵀ`, over free
    /// nodes (every node when `held` is false). Added to the springs' `ω²` it keeps the
    /// explicit step stable.
    pub fn omega2_bound(&self, model: &Model, k: f64, held: bool) -> f64 {
        let n = model.nodes.len();
        let mut row = vec![0.0_f64; n];
        for (tet, &v0) in self.tets.iter().zip(&self.rest_volume) {
            let (_, grad) = volume_and_gradient(tet.map(|i| model.nodes.position[i as usize]));
            let norms = grad.map(|g| dot(g, g).sqrt());
            let sum: f64 = norms.iter().sum();
            for (&i, gi) in tet.iter().zip(norms) {
                row[i as usize] += k / v0.abs() * gi * sum;
            }
        }
        (0..n)
            .filter(|&i| !held || model.nodes.kind[i] == NodeKind::Free)
            .map(|i| row[i] / model.nodes.mass[i])
            .fold(0.0, f64::max)
    }
}

/// Signed volume of the tetrahedron `x`, m³.
fn signed_volume(x: [[f64; 3]; 4]) -> f64 {
    dot(sub(x[1], x[0]), cross(sub(x[2], x[0]), sub(x[3], x[0]))) / 6.0
}

/// Six times the signed volume, and its gradient with respect to each corner.
#[inline(always)]
fn six_volume_and_gradient(x: [[f64; 3]; 4]) -> (f64, [[f64; 3]; 4]) {
    let (e1, e2, e3) = (sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0]));
    let (g1, g2, g3) = (cross(e2, e3), cross(e3, e1), cross(e1, e2));
    let g0 = [-(g1[0] + g2[0] + g3[0]), -(g1[1] + g2[1] + g3[1]), -(g1[2] + g2[2] + g3[2])];
    (dot(e1, g1), [g0, g1, g2, g3])
}

/// Signed volume and its gradient with respect to each corner.
fn volume_and_gradient(x: [[f64; 3]; 4]) -> (f64, [[f64; 3]; 4]) {
    let (v6, g6) = six_volume_and_gradient(x);
    (v6 / 6.0, g6.map(|g| g.map(|c| c / 6.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_tet() -> (SkinVolume, Vec3s<f64>) {
        let x = [[0.0, 0.0, 0.0], [0.02, 0.0, 0.001], [0.004, 0.013, 0.0], [0.008, 0.004, -0.002]];
        let v0 = signed_volume(x);
        let sv = SkinVolume {
            tets: vec![[0, 1, 2, 3]],
            rest_volume: vec![v0],
            inv_36_abs_rest: vec![1.0 / (36.0 * v0.abs())],
            nodes: vec![0, 1, 2, 3],
        };
        (sv, Vec3s::from_f64(&x))
    }

    #[test]
    fn volume_forces_are_minus_the_energy_gradient_works() {
        let (sv, mut x) = one_tet();
        // Deform: squash the apex through the base (inverted) and shear a corner.
        x.set(3, [0.009, 0.005, 0.0015]);
        x.set(1, [0.021, 0.001, 0.0]);
        let k = 5e4;
        let mut f = Vec3s::zeros(4);
        sv.add_forces(k, &x, &mut f);
        let h = 1e-9;
        for i in 0..4 {
            for c in 0..3 {
                let mut xp = x.clone();
                let mut xm = x.clone();
                let mut p = x.get(i);
                p[c] += h;
                xp.set(i, p);
                p[c] -= 2.0 * h;
                xm.set(i, p);
                let fd = -(sv.energy(k, &xp) - sv.energy(k, &xm)) / (2.0 * h);
                let got = f.get(i)[c];
                assert!((got - fd).abs() <= 1e-6 * fd.abs().max(1e-3), "node {i} axis {c}: {got} vs {fd}");
            }
        }
        assert!(sv.volume_ratios(&x).next().unwrap() < 0.0, "the deformed tetrahedron is inverted");
    }

    #[test]
    fn weighted_gradient_is_the_root_stiffness_times_the_volume_gradient_works() {
        let (sv, mut x) = one_tet();
        x.set(2, [0.005, 0.012, 0.001]);
        let (k, h) = (5e4, 1e-9);
        let v0 = sv.rest_volume[0];
        let got = sv.weighted_gradient(0, k, &x);
        for i in 0..4 {
            for c in 0..3 {
                // Central difference of the signed volume, times √(k/|V₀|).
                let volume_at = |delta: f64| {
                    let mut p = x.clone();
                    let mut q = p.get(i);
                    q[c] += delta;
                    p.set(i, q);
                    signed_volume(sv.tets[0].map(|n| p.get_f64(n as usize)))
                };
                let want = (k / v0.abs()).sqrt() * (volume_at(h) - volume_at(-h)) / (2.0 * h);
                assert!(
                    (got[i][c] - want).abs() <= 1e-6 * want.abs().max(1e-3),
                    "corner {i} axis {c}: {} vs {want}",
                    got[i][c]
                );
            }
        }
    }

    #[test]
    fn volume_forces_conserve_momentum_and_vanish_at_rest_works() {
        let (sv, x0) = one_tet();
        let mut f = Vec3s::zeros(4);
        sv.add_forces(1e5, &x0, &mut f);
        assert!((0..4).all(|i| f.get(i) == [0.0; 3]), "no force at rest");
        let mut x = x0.clone();
        x.set(3, [0.007, 0.006, 0.0005]);
        let mut f = Vec3s::zeros(4);
        sv.add_forces(1e5, &x, &mut f);
        let (mut total, mut moment) = ([0.0; 3], [0.0; 3]);
        for i in 0..4 {
            let (fi, xi) = (f.get(i), x.get(i));
            let m = cross(xi, fi);
            for c in 0..3 {
                total[c] += fi[c];
                moment[c] += m[c];
            }
        }
        let scale = (0..4).map(|i| dot(f.get(i), f.get(i)).sqrt()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        assert!(total.iter().all(|c| c.abs() < 1e-12 * scale), "{total:?}");
        assert!(moment.iter().all(|c| c.abs() < 1e-12 * scale), "{moment:?}");
    }

    #[test]
    fn inverted_tetrahedron_is_pushed_back_works() {
        // The apex pushed through the base: its force points back to its rest side.
        let (sv, x0) = one_tet();
        let mut x = x0.clone();
        let apex = x0.get(3);
        x.set(3, [apex[0], apex[1], 0.002]);
        let mut f = Vec3s::zeros(4);
        sv.add_forces(1e4, &x, &mut f);
        assert!(f.get(3)[2] < 0.0, "{:?}", f.get(3));
    }

    #[test]
    fn default_limb_has_one_tetrahedron_per_skin_triangle_works() {
        let model = crate::scene::Scene::builtin_default().build_model().unwrap();
        let sv = SkinVolume::of_model(&model);
        let skin = model.surfaces.iter().find(|s| s.name == super::super::skin_contact::SKIN_SURFACE).unwrap();
        assert_eq!(sv.tets.len(), skin.triangles.len());
        for (tet, v0) in sv.tets.iter().zip(&sv.rest_volume) {
            // The bottom node lies in the skin layer, beneath its triangle, about one skin
            // thickness (2 mm) from it: |V₀| = area × height / 3.
            let x = tet.map(|i| model.nodes.position[i as usize]);
            let area =
                0.5 * dot(cross(sub(x[1], x[0]), sub(x[2], x[0])), cross(sub(x[1], x[0]), sub(x[2], x[0]))).sqrt();
            let height = 3.0 * v0.abs() / area;
            assert!((0.0015..0.0025).contains(&height), "{tet:?}: {height} m");
            assert_eq!(model.nodes.layer[tet[3] as usize], model.nodes.layer[tet[0] as usize]);
        }
    }
}
