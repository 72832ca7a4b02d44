//! Fitting a scene's springs: the skin, fat and muscle layers of the limb a scene generates,
//! each fitted on a slab of its own spacing and thickness, the three in parallel.

use super::anneal::AnnealStep;
use super::layer_fit::{FitSettings, LayerFit, LayerFitError, LayerGeometry, fit_layer};
use super::targets::TissueTargets;
use crate::generator::vec3::{add, cross, dot, norm, scale, sub};
use crate::generator::{AnatomySpec, CylinderLimb, GridSize};
use crate::model::Model;
use crate::scene::{ModelSource, Scene, SceneLoadError, SceneSprings};

/// Why a scene's layer geometry could not be found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SceneGeometryError {
    /// The scene's model could not be built.
    #[error(transparent)]
    Scene(#[from] SceneLoadError),
    /// The generated limb has no usable layer geometry.
    #[error("{scene}: the generated limb has no usable layer geometry")]
    NoGeometry {
        /// The scene's file, or `the built-in default scene`.
        scene: String,
    },
    /// The scene's model is not a generated limb.
    #[error("{scene}: only a generated limb (cylinder_limb or anatomy) has springs to fit")]
    NotALimb {
        /// The scene's file, or `the built-in default scene`.
        scene: String,
    },
}

/// The skin, fat and muscle layers' geometry in a cylindrical limb: spacing = the geometric
/// mean of a cell's sides on the skin (circumference / W by length / H), thickness = the
/// layer's radial extent.
pub fn cylinder_geometry(limb: &CylinderLimb) -> [LayerGeometry; 3] {
    let around = std::f64::consts::TAU * limb.outer_skin_radius / limb.grid.columns as f64;
    let along = limb.length / limb.grid.rows as f64;
    let spacing_m = (around * along).sqrt();
    [
        LayerGeometry { spacing_m, thickness_m: limb.outer_skin_radius - limb.skin_fat_radius },
        LayerGeometry { spacing_m, thickness_m: limb.skin_fat_radius - limb.fat_muscle_radius },
        LayerGeometry { spacing_m, thickness_m: limb.fat_muscle_radius - limb.bone_radius },
    ]
}

/// The layers' geometry in a limb generated from surfaces (`model`, generated from `spec`):
/// spacing = the square root of the outer skin's mean cell area; skin thickness = the
/// spec's, or with a segmented skin/fat surface the mean distance from the outer skin's
/// inner-ring grid points to the model's skin/fat surface; fat and muscle thickness = the mean distance between
/// a ray's nodes on the boundaries above and below the layer. `None` when `model` is not the generator's output
/// for `spec`'s grid.
pub fn anatomy_geometry(model: &Model, spec: &AnatomySpec) -> Option<[LayerGeometry; 3]> {
    let grid: GridSize = spec.grid;
    let p = &model.nodes.position;
    if p.len() != grid.masses() {
        return None;
    }
    let (gw, gh, nodes) = model.surfaces.first()?.grid.as_ref()?;
    let (gw, gh) = (*gw as usize, *gh as usize);
    let at = |c: usize, r: usize| p[nodes[r * gw + c] as usize];
    let mut area = 0.0;
    let mut cells = 0usize;
    for r in 0..gh.saturating_sub(1) {
        for c in 0..gw.saturating_sub(1) {
            let (p00, p10, p01, p11) = (at(c, r), at(c + 1, r), at(c, r + 1), at(c + 1, r + 1));
            area += 0.5 * norm(cross(sub(p10, p00), sub(p01, p00))) + 0.5 * norm(cross(sub(p10, p11), sub(p01, p11)));
            cells += 1;
        }
    }
    let spacing_m = (area / cells.max(1) as f64).sqrt();
    let mean_gap = |upper: u32| {
        let n = grid.triangles();
        let sum: f64 = (0..n as u32)
            .map(|t| norm(sub(p[grid.triangle_node(upper, t) as usize], p[grid.triangle_node(upper + 1, t) as usize])))
            .sum();
        sum / n as f64
    };
    let skin_thickness = match spec.skin_fat {
        None => spec.skin_thickness,
        Some(_) => {
            // Each inner ring's outer grid points' distance to the skin/fat surface the model
            // carries (its triangles over the level-1 nodes), averaged; the end rings lie
            // beyond that surface's ends (its nodes sit at the triangles' centroids).
            let level1 = &model.surfaces.get(1)?.triangles;
            let rings: Vec<u32> = if grid.rows >= 2 { (1..grid.rows).collect() } else { (0..=grid.rows).collect() };
            let points: Vec<usize> = rings
                .iter()
                .flat_map(|&j| (0..grid.columns as i64).map(move |i| grid.surface_node(grid.vertex(i, j)) as usize))
                .collect();
            let outer = points.len();
            let sum: f64 = points
                .iter()
                .map(|&v| {
                    let q = p[v];
                    level1
                        .iter()
                        .map(|t| distance_to_triangle(q, p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]))
                        .fold(f64::INFINITY, f64::min)
                })
                .sum();
            sum / outer as f64
        }
    };
    let geometry = [
        LayerGeometry { spacing_m, thickness_m: skin_thickness },
        LayerGeometry { spacing_m, thickness_m: mean_gap(1) },
        LayerGeometry { spacing_m, thickness_m: mean_gap(2) },
    ];
    geometry.iter().all(|g| g.spacing_m.is_finite() && g.spacing_m > 0.0 && g.thickness_m > 0.0).then_some(geometry)
}

/// The layers' geometry of the limb `scene` generates; an error naming the scene when its
/// model is not a generated limb (a layered block, a lattice or a model file).
pub fn scene_geometry(scene: &Scene) -> Result<[LayerGeometry; 3], SceneGeometryError> {
    let name = || scene.path.as_ref().map_or_else(|| "the built-in default scene".into(), |p| p.display().to_string());
    match &scene.model {
        ModelSource::CylinderLimb { columns, rows, length, .. } => Ok(cylinder_geometry(&CylinderLimb {
            grid: GridSize::new(*columns, *rows),
            length: *length,
            ..CylinderLimb::default()
        })),
        ModelSource::Anatomy(spec) => {
            let model = scene.build_model()?;
            anatomy_geometry(&model, spec).ok_or_else(|| SceneGeometryError::NoGeometry { scene: name() })
        }
        _ => Err(SceneGeometryError::NotALimb { scene: name() }),
    }
}

/// Fits skin, fat and muscle (`targets` in that order) on `geometry`, one thread per layer;
/// `on_step(layer, step)` sees every evaluation.
pub fn fit_layers(
    targets: &[TissueTargets; 3],
    geometry: &[LayerGeometry; 3],
    settings: &FitSettings,
    on_step: &(dyn Fn(usize, &AnnealStep) + Sync),
) -> [Result<LayerFit, LayerFitError>; 3] {
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..3)
            .map(|i| s.spawn(move || fit_layer(&targets[i], geometry[i], settings, |step| on_step(i, step))))
            .collect();
        let mut results = handles.into_iter().map(|h| h.join().unwrap_or(Err(LayerFitError::NoCurve)));
        [(); 3].map(|_| results.next().unwrap_or(Err(LayerFitError::NoCurve)))
    })
}

/// The scene springs of three fitted layers (skin, fat, muscle).
pub fn scene_springs(fits: &[LayerFit; 3], seed: u64) -> SceneSprings {
    SceneSprings { fit_seed: seed, skin: fits[0].material, fat: fits[1].material, muscle: fits[2].material }
}

/// Distance from `q` to the triangle `a b c`, m (the closest point by Voronoi region, Ericson's
/// "Real-Time Collision Detection" 5.1.5).
fn distance_to_triangle(q: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let at = |o: [f64; 3], d: [f64; 3], s: f64| add(o, scale(d, s));
    let dist = |x: [f64; 3]| norm(sub(q, x));
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(q, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return dist(a);
    }
    let bp = sub(q, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return dist(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return dist(at(a, ab, d1 / (d1 - d3)));
    }
    let cp = sub(q, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return dist(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return dist(at(a, ac, d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return dist(at(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    dist(at(at(a, ab, v), ac, w))
}

#[cfg(test)]
mod tests {
    use super::distance_to_triangle;

    #[test]
    fn distance_to_triangle_closed_forms_works() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        // Above the face, beside an edge, beyond a corner.
        assert!((distance_to_triangle([0.2, 0.2, 0.5], a, b, c) - 0.5).abs() < 1e-15);
        assert!((distance_to_triangle([0.5, -2.0, 0.0], a, b, c) - 2.0).abs() < 1e-15);
        assert!((distance_to_triangle([2.0, 2.0, 0.0], a, b, c) - (2.0 * 1.5f64.powi(2)).sqrt()).abs() < 1e-12);
        assert!((distance_to_triangle([-3.0, -4.0, 0.0], a, b, c) - 5.0).abs() < 1e-15);
    }
}
