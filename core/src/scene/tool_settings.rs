//! The scene's haptic tool: a sphere pushed into the tissue, driven by a script or by the
//! haptics process over the `tool` service.

/// Where the tool's position comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToolSource {
    /// Moves as `start + velocity · t` (offline studies, tests).
    Scripted {
        /// Centre at t = 0, m (model frame).
        start: [f64; 3],
        /// Centre velocity, m/s.
        velocity: [f64; 3],
    },
    /// Follows the newest `ToolCommand` from the haptics process; parked (out of the loop)
    /// until the first command and again when commands stop for `timeout_s`.
    Haptics {
        /// Model position of the device's workspace centre, m. The haptics process maps its
        /// device frame onto the model frame about this point (`lamina demo` passes it on).
        device_origin: [f64; 3],
        /// Commands older than this park the tool, s. Default 0.1.
        timeout_s: f64,
        /// Smallest radius a command may give the sphere, m. The skin's point shell is
        /// sampled for it (samples at most half of it apart), so a smaller sphere could pass
        /// between the samples: a command below it is raised to it (and counted). Default: the
        /// scene's `radius`. Samples, and their cost, grow as `(radius / min_radius)²`.
        min_radius: f64,
        /// Model metres per device metre: the device's workspace scaled onto the model.
        /// Default 1.
        device_scale: f64,
        /// Device newtons per model newton. Default 1.
        force_scale: f64,
    },
}

/// Rotation from the haptic device's axes (x toward the operator, y right, z up) to a y-up
/// model's (row-major, `model_i = Σ_j R[i][j] device_j`): device x → model z, device y → model
/// x, device z → model y.
pub const DEVICE_TO_Y_UP_MODEL: [[f64; 3]; 3] = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]];

/// The scene's `[effects.tool]` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolSettings {
    /// Sphere radius, m (a haptics command may carry its own, down to the source's
    /// `min_radius`).
    pub radius: f64,
    /// Penalty stiffness per node in contact, N/m: the scene's `stiffness`, or its
    /// `stiffness_per_area` times the model's largest skin node area.
    pub stiffness: f64,
    /// The stiffness per area the scene gave instead of `stiffness`, N/m per m² of skin in
    /// contact (Pa/m): the contact feels the same on any grid of the same skin
    /// ([`largest_skin_node_area`](crate::solver::largest_skin_node_area)). `None` when the
    /// scene gave `stiffness`.
    pub stiffness_per_area: Option<f64>,
    /// Script or haptics.
    pub source: ToolSource,
}

impl ToolSettings {
    /// The sphere this tool starts as in the loop: `Some` for a scripted tool, `None` (parked)
    /// for a haptics-driven one.
    pub fn initial_sphere(&self) -> Option<crate::solver::SphereTool> {
        match self.source {
            ToolSource::Scripted { start, velocity } => {
                Some(crate::solver::SphereTool { radius: self.radius, stiffness: self.stiffness, start, velocity })
            }
            ToolSource::Haptics { .. } => None,
        }
    }

    /// The radius the skin's point shell must be sampled for: the smallest the tool can take.
    pub fn shell_radius(&self) -> f64 {
        match self.source {
            ToolSource::Scripted { .. } => self.radius,
            ToolSource::Haptics { min_radius, .. } => min_radius,
        }
    }

    /// The radius of a sphere commanded with `commanded` m (0: the scene's), and whether it
    /// was raised to the smallest the skin's point shell supports.
    pub fn commanded_radius(&self, commanded: f64) -> (f64, bool) {
        let wanted = if commanded > 0.0 { commanded } else { self.radius };
        let smallest = self.shell_radius();
        if wanted < smallest { (smallest, true) } else { (wanted, false) }
    }
}
