//! Indentation: a generated limb pressed by the scene's sphere, 1-10 mm deep at a few sites,
//! force against depth, beside published in-vivo indentation of limb soft tissue brought to
//! the same indenter by Hertz contact.
//!
//! Each site is an outer-skin grid point at mid-length; the sphere touches it from outside
//! along the line to the nearest bone node and is lowered in steps of 1 mm at 10 mm/s, each
//! step held 0.2 s, the force read at the end of each hold (quasi-static: the limb's slowest
//! motion under the viscous damping of the scenes decays within it). The press runs
//! single-rate (every node every tick) whatever the scene's multirate settings, so each site
//! sees the whole limb. Depths beyond half the soft tissue under a site are refused: Hertz
//! contact, which brings the force to a modulus, holds only while the depth is small against
//! the tissue's thickness.

use crate::generator::vec3::{add, dot, norm, normalize, scale, sub};
use crate::hand_tool::HandTool;
use crate::model::{Model, NodeKind};
use crate::scene::{Scene, SceneLoadError, ToolSettings, ToolSource};
use crate::solver::SimulationBuildError;

/// Why an indentation could not be measured.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IndentationError {
    /// The scene's model could not be built.
    #[error(transparent)]
    Scene(#[from] SceneLoadError),
    /// The model has no outer-skin grid to pick sites on.
    #[error("the model has no outer-skin grid (not a generated limb)")]
    NoSkinGrid,
    /// The model has no fixed nodes to press toward.
    #[error("the model has no fixed (bone) nodes to press toward")]
    NoBone,
    /// A site's skin node coincides with its nearest bone node.
    #[error("a skin node sits on the bone")]
    SkinOnBone,
    /// The simulation with the tool could not be built.
    #[error(transparent)]
    Simulation(#[from] SimulationBuildError),
    /// The depth asked for is beyond half the soft tissue's thickness at a site.
    #[error("{site}: a {depth_mm} mm press is beyond half the {thickness_mm:.1} mm of soft tissue over the bone there")]
    TooDeep {
        /// The site.
        site: String,
        /// Depth asked for, mm.
        depth_mm: u32,
        /// Skin-to-bone distance at the site, mm.
        thickness_mm: f64,
    },
    /// The force on the sphere became NaN or infinite.
    #[error("{site}: non-finite force at {depth_mm} mm")]
    NonFiniteForce {
        /// The site, e.g. `node 12 at (1.0, 2.0, 3.0) mm`.
        site: String,
        /// Depth reached, mm.
        depth_mm: u32,
    },
}

/// A published indentation modulus of limb soft tissue.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PublishedModulus {
    /// What and where, with the source.
    pub label: &'static str,
    /// Effective Young's modulus, Pa.
    pub modulus_pa: f64,
}

/// In-vivo indentation moduli of limb soft tissue.
pub const PUBLISHED_MODULI: [PublishedModulus; 4] = [
    PublishedModulus { label: "Zheng & Mak 1999, lower limb, initial modulus, lowest", modulus_pa: 0.22e3 },
    PublishedModulus { label: "Isogai et al. 2022, gluteal subcutaneous tissue at 1 N", modulus_pa: 26e3 },
    PublishedModulus { label: "Zheng & Mak 1999, lower limb, initial modulus, highest", modulus_pa: 58.4e3 },
    PublishedModulus { label: "Isogai et al. 2022, gluteal muscle at 5 N", modulus_pa: 62e3 },
];

/// Poisson's ratio used to bring a modulus to a contact force: soft tissue is nearly
/// incompressible.
pub const TISSUE_POISSON: f64 = 0.49;

/// Hertz contact of a rigid sphere of `radius_m` pressed `depth_m` into a half-space of
/// Young's modulus `modulus_pa`: F = 4/3 · E/(1 − ν²) · √R · d^{3/2}, N.
///
/// ```
/// use lamina_core::study::hertz_force;
/// // 26 kPa tissue, 12 mm sphere, 8 mm deep: about 3.6 N.
/// let f = hertz_force(26e3, 0.012, 0.008);
/// assert!((f - 3.58).abs() < 0.01);
/// ```
pub fn hertz_force(modulus_pa: f64, radius_m: f64, depth_m: f64) -> f64 {
    4.0 / 3.0 * modulus_pa / (1.0 - TISSUE_POISSON * TISSUE_POISSON) * radius_m.sqrt() * depth_m.max(0.0).powf(1.5)
}

/// The modulus whose Hertz force at `depth_m` under a sphere of `radius_m` is `force_n`, Pa.
pub fn effective_modulus(force_n: f64, radius_m: f64, depth_m: f64) -> f64 {
    force_n / hertz_force(1.0, radius_m, depth_m)
}

/// One site's force against depth.
#[derive(Clone, Debug, PartialEq)]
pub struct IndentationCurve {
    /// Where: the node pressed and its position, m.
    pub site: String,
    /// Depths, m.
    pub depth_m: Vec<f64>,
    /// Force pushing the sphere back along the press, N.
    pub force_n: Vec<f64>,
}

/// Presses `scene`'s limb at `sites` outer-skin grid columns (mid-length) to `max_depth_mm`
/// (whole millimetres) with the scene's tool (or a 12 mm, 300 N/m sphere when it has none).
///
/// # Errors
/// A scene that does not build, has no outer-skin grid, or a non-finite force.
pub fn indentation(
    scene: &Scene,
    sites: usize,
    max_depth_mm: u32,
) -> Result<(f64, Vec<IndentationCurve>), IndentationError> {
    let model = scene.build_model()?;
    indentation_of_model(scene, &model, sites, max_depth_mm)
}

/// [`indentation`] on a model already built (the scene's own, or a candidate of a fit),
/// with the scene's solver, effects and tool.
///
/// # Errors
/// As [`indentation`].
pub fn indentation_of_model(
    scene: &Scene,
    model: &Model,
    sites: usize,
    max_depth_mm: u32,
) -> Result<(f64, Vec<IndentationCurve>), IndentationError> {
    let settings = scene.tool.unwrap_or(ToolSettings {
        radius: 0.012,
        stiffness: 300.0,
        stiffness_per_area: None,
        source: ToolSource::Haptics {
            device_origin: [0.0; 3],
            timeout_s: 0.1,
            min_radius: 0.012,
            device_scale: 1.0,
            force_scale: 1.0,
        },
    });
    let radius = settings.radius;
    let (columns, rows, grid) =
        model.surfaces.first().and_then(|s| s.grid.as_ref()).ok_or(IndentationError::NoSkinGrid)?;
    let (columns, rows) = ((*columns as usize).saturating_sub(1).max(1), *rows as usize);
    let mut curves = Vec::new();
    for k in 0..sites.max(1) {
        let column = k * columns / sites.max(1);
        let node = grid[(rows / 2) * (columns + 1) + column] as usize;
        let curve = press_site(scene, model, settings, node, max_depth_mm)?;
        curves.push(curve);
    }
    Ok((radius, curves))
}

fn press_site(
    scene: &Scene,
    model: &Model,
    settings: ToolSettings,
    node: usize,
    max_depth_mm: u32,
) -> Result<IndentationCurve, IndentationError> {
    let skin = model.nodes.position[node];
    let bone = (0..model.nodes.len())
        .filter(|&i| model.nodes.kind[i] == NodeKind::Fixed)
        .map(|i| model.nodes.position[i])
        .min_by(|a, b| norm(sub(*a, skin)).total_cmp(&norm(sub(*b, skin))))
        .ok_or(IndentationError::NoBone)?;
    let inward = normalize(sub(bone, skin)).ok_or(IndentationError::SkinOnBone)?;
    let site = format!("node {node} at ({:.1}, {:.1}, {:.1}) mm", skin[0] * 1e3, skin[1] * 1e3, skin[2] * 1e3);
    let thickness = norm(sub(bone, skin));
    if f64::from(max_depth_mm) * 1e-3 > 0.5 * thickness {
        return Err(IndentationError::TooDeep { site, depth_mm: max_depth_mm, thickness_mm: thickness * 1e3 });
    }
    let mut effects = scene.effects.clone();
    effects.handles.clear(); // only the tool loads the limb
    let mut solver = scene.solver.clone();
    solver.multirate = None; // every site sees the whole limb
    let (mut sim, mut tool) = HandTool::simulation::<f64>(model, solver, effects, settings)?;
    let dt = 1.0 / f64::from(scene.rate_hz);
    let touching = sub(skin, scale(inward, settings.radius));
    let (ramp_steps, hold_steps) = ((0.1 / dt).round() as usize, (0.2 / dt).round() as usize);
    let mut curve = IndentationCurve { site, depth_m: Vec::new(), force_n: Vec::new() };
    for mm in 1..=max_depth_mm {
        let from = f64::from(mm - 1) * 1e-3;
        for s in 1..=ramp_steps + hold_steps {
            let depth = from + 1e-3 * (s.min(ramp_steps) as f64 / ramp_steps as f64);
            tool.move_to(&mut sim, add(touching, scale(inward, depth)), None);
            sim.step();
        }
        let f = tool.feedback(&sim);
        let push = -dot(f.force, inward);
        if !push.is_finite() {
            return Err(IndentationError::NonFiniteForce { site: curve.site, depth_mm: mm });
        }
        curve.depth_m.push(f64::from(mm) * 1e-3);
        curve.force_n.push(push);
    }
    Ok(curve)
}
