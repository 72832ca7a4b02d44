//! Why a [`Simulation`](super::Simulation) could not be built: the model, an effect, the
//! parameters, the precision, the memory or the stability checks refused it.

use super::sparse_cholesky::FactorBuildError;
use crate::model::ModelValidateError;

/// Why a simulation could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimulationBuildError {
    /// The model is inconsistent.
    #[error("invalid model: {0}")]
    Model(ModelValidateError),
    /// An effect names a node that does not exist.
    #[error("{effect}: node {node} does not exist")]
    NodeOutOfRange {
        /// Which effect.
        effect: &'static str,
        /// The node index named.
        node: u32,
    },
    /// An effect parameter is NaN, infinite or negative where it must not be.
    #[error("{effect}: a value is NaN, infinite or out of range")]
    BadEffectValue {
        /// Which effect.
        effect: &'static str,
    },
    /// `bone_motion` is on but moves nothing: `bone` is off, or the model has no kinematic
    /// node.
    #[error(
        "bone_motion moves the model's kinematic nodes with bone on, and there are none: set bone = true, and mark the moving bone's nodes kinematic (a generated model's scene does so when it asks for bone_motion; a model file gives them kind=\"kinematic\")"
    )]
    NothingToMove,
    /// The step is not finite and positive, or sub-steps are zero.
    #[error("time step must be finite and positive, sub-steps at least 1")]
    BadStep,
    /// A count is above its cap ([`MAX_SUBSTEPS`](super::MAX_SUBSTEPS),
    /// [`MAX_CG_ITERATIONS`](super::MAX_CG_ITERATIONS), ...).
    #[error("{parameter} = {value} is above its cap of {cap}")]
    AboveCap {
        /// The parameter, as named in scene files.
        parameter: &'static str,
        /// Its value.
        value: u64,
        /// The cap.
        cap: u64,
    },
    /// A solver setting is outside its range.
    #[error("{parameter} = {value:e} must be {expected}")]
    BadParameter {
        /// The parameter, as named in scene files.
        parameter: &'static str,
        /// Its value.
        value: f64,
        /// The range it must be in.
        expected: &'static str,
    },
    /// A node lies beyond [`max_coordinate`](super::max_coordinate) of the precision: its
    /// squared distances would not be finite.
    #[error("node {node} at ({:e}, {:e}, {:e}) m is beyond ±{limit_m:.1e} m, the largest coordinate whose squared distances stay finite in {precision}", .position[0], .position[1], .position[2])]
    PositionOutOfRange {
        /// The node.
        node: u32,
        /// Its position, m.
        position: [f64; 3],
        /// The largest coordinate magnitude of the precision, m.
        limit_m: f64,
        /// `f32` or `f64`.
        precision: &'static str,
    },
    /// A mass or stiffness rounds to zero or overflows in the precision.
    #[error("{item} rounds to zero or overflows in {precision}")]
    NotRepresentable {
        /// What and its value, e.g. `node 3: mass 1e-300 kg`.
        item: String,
        /// `f32` or `f64`.
        precision: &'static str,
    },
    /// Running the model would need more memory than is available.
    #[error("{0}")]
    Memory(crate::model::ModelSizeError),
    /// The stiffest mode's frequency or damping rate is not finite (or the explicit
    /// critical step not positive): no step can follow the model.
    #[error(
        "the model's stiffest mode is not finite (omega_max {omega_max:e} rad/s, damping rate {gamma_max:e} 1/s); stiffest spring for its mass: {stiffest}"
    )]
    NonFiniteStability {
        /// Highest angular frequency estimated, rad/s.
        omega_max: f64,
        /// Highest damping rate estimated, 1/s.
        gamma_max: f64,
        /// The spring with the largest stiffness over its lighter node's mass.
        stiffest: String,
    },
    /// Multirate stepping cannot be set up as asked (what is wrong is in the message).
    #[error("multirate stepping: {0}")]
    Multirate(String),
    /// The implicit solvers' prefactored matrix could not be factored.
    #[error("prefactored matrix: {0}")]
    Factor(FactorBuildError),
}

impl From<ModelValidateError> for SimulationBuildError {
    fn from(e: ModelValidateError) -> Self {
        Self::Model(e)
    }
}
