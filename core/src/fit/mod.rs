//! Material fitting (the paper's "Analysis of macroscopic behavior", DESIGN.md §5): the
//! springs of each layer are chosen so that the layer's macroscopic stress-strain curve
//! matches measured tissue.
//!
//! 1. [`targets`]: a tissue's measured values with their sources (`config/materials/`).
//! 2. [`tensile`]: the virtual tensile test, a slab of the layer's lattice held at one end
//!    and pulled by increasing loads, each solved to static equilibrium (Newton, residual
//!    stop).
//! 3. [`regression`]: the paper's bilinear regression (every point tried as turning point).
//! 4. [`anneal`](mod@anneal): simulated annealing with a documented schedule and seed.
//! 5. [`layer_fit`]: the objective ψ and one layer's fit, every evaluation's curve kept.
//! 6. [`curve_error`](mod@curve_error): the fitted layer against the tissue's own curve, point by point.
//! 7. [`scene_fit`]: a scene's three layers, on the geometry of the limb it generates.
//! 8. [`indentation_targets`]: the in-vivo indentation band the living limb is checked against.
//! 9. [`indentation_fit`]: fat's and muscle's compression fitted to it by a virtual indentation.

pub mod anneal;
pub mod curve_error;
pub mod indentation_fit;
pub mod indentation_targets;
pub mod layer_fit;
pub mod regression;
pub mod scene_fit;
pub mod targets;
pub mod tensile;

pub use anneal::{AnnealResult, AnnealSettings, AnnealStep, AnnealStop, anneal};
pub use curve_error::{CurveError, curve_error};
pub use indentation_fit::{
    FAT_COMPRESSION_RATIO_RANGE, FIT_SITES, INDENTATION_WEIGHTS, IndentationFit, IndentationFitError,
    MUSCLE_COMPRESSION_RATIO_RANGE, STIFFENING_MARGIN, fit_indentation, indentation_psi, press_candidate,
    with_compression_ratios,
};
pub use indentation_targets::{
    BandCheck, IndentationBand, IndentationTargets, MeasuredIndentation, SHIPPED_INDENTATION_TARGETS,
    hertz_sphere_force,
};
pub use layer_fit::{
    Achieved, FitObjective, FitSettings, LayerFit, LayerFitError, LayerGeometry, fit_layer, macroscopic, material_of,
    psi, strain_psi,
};
pub use regression::{BilinearFit, LineFit, bilinear_regression, line_fit};
pub use scene_fit::{
    SceneGeometryError, anatomy_geometry, cylinder_geometry, fit_layers, scene_geometry, scene_springs,
};
pub use targets::{TargetCurve, TargetLaw, TargetsLoadError, TissueTargets};
pub use tensile::{Specimen, TensileCurve, TensileTestError, tensile_test};
