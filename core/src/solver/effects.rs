//! The physical effects a scene asks for. Each one left off is absent from the step loop.

/// Sinusoidal translation of the kinematic (bone-attached) nodes:
/// `x(t) = x_rest + amplitude · sin(2π f t)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoneMotion {
    /// Peak displacement, m.
    pub amplitude: [f64; 3],
    /// Frequency, Hz.
    pub frequency_hz: f64,
}

/// A constant force on one node, optionally ramped in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLoad {
    /// Node index.
    pub node: u32,
    /// Force, N.
    pub force: [f64; 3],
    /// Time to ramp linearly from zero to full force, s. 0 = sudden. Default 0.
    pub ramp_s: f64,
}

/// A node pulled toward a target point by a spring and dashpot (a mouse drag, a clamp).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragHandle {
    /// Node index.
    pub node: u32,
    /// Target position, m.
    pub target: [f64; 3],
    /// Spring stiffness, N/m.
    pub stiffness: f64,
    /// Dashpot, N·s/m.
    pub damping: f64,
}

/// A rigid sphere (a haptic tool's tip) pushing the tissue out by penalty springs. It meets
/// the outer skin's surface through a point shell (see `skin_contact.rs`: samples on every
/// skin triangle, a penalty pressure such that no skin node feels more than `stiffness`),
/// and any other node at distance `d < radius` from the centre feels
/// `stiffness · (radius − d)` along the outward direction. The centre moves as
/// `start + velocity · t` unless a caller sets it each frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereTool {
    /// Radius, m.
    pub radius: f64,
    /// Penalty stiffness per node, N/m (the most any skin node feels from the shell).
    pub stiffness: f64,
    /// Centre at t = 0, m.
    pub start: [f64; 3],
    /// Centre velocity, m/s.
    pub velocity: [f64; 3],
}

impl SphereTool {
    /// Centre at time `t`, m.
    pub fn centre(&self, t: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| self.start[c] + self.velocity[c] * t)
    }
}

/// What the tool feels: the contact's resultant and its local stiffness, for haptic rendering
/// (`F(x) ≈ force + stiffness · (x − centre)`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToolFeedback {
    /// Whether any contact point touches the tool.
    pub in_contact: bool,
    /// Contact points inside the tool: skin-shell samples and nodes off the skin.
    pub nodes: u32,
    /// Force on the tool, N (the reaction of the tissue).
    pub force: [f64; 3],
    /// Local stiffness of that force with respect to the tool's position, N/m (symmetric).
    pub stiffness: [[f64; 3]; 3],
    /// Tool centre the feedback was computed at, m.
    pub centre: [f64; 3],
}

/// When the guard declares a state bad.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuardSettings {
    /// Largest plausible node speed, m/s. Default 50.
    pub max_speed: f64,
    /// Largest plausible displacement from rest, m. Default 1.
    pub max_displacement: f64,
    /// Retries with twice the sub-steps before handing the frame to implicit Euler. Default 2;
    /// at most [`MAX_GUARD_RETRIES`](super::MAX_GUARD_RETRIES) (8).
    pub retries: u32,
}

impl Default for GuardSettings {
    fn default() -> Self {
        Self { max_speed: 50.0, max_displacement: 1.0, retries: 2 }
    }
}

/// The effects of a scene. `Default` is springs only: no gravity, no damping, no bone,
/// no loads, no guard.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Effects {
    /// Gravity, m/s². Typical `[0, -9.81, 0]`.
    pub gravity: Option<[f64; 3]>,
    /// Viscous (air/ether) damping coefficient α, 1/s: force `−α m v` on every node.
    pub viscous_damping: Option<f64>,
    /// Evaluate the dashpots along springs.
    pub spring_damping: bool,
    /// Hold fixed nodes and move kinematic ones. Off: every node is free.
    pub bone: bool,
    /// Motion of the kinematic nodes (needs `bone`).
    pub bone_motion: Option<BoneMotion>,
    /// Point loads.
    pub loads: Vec<PointLoad>,
    /// Drag handles.
    pub handles: Vec<DragHandle>,
    /// Detect non-finite or exploding state and roll back.
    pub guard: Option<GuardSettings>,
    /// A spherical tool in contact with the tissue.
    pub tool: Option<SphereTool>,
    /// Volume stiffness of the skin layer's tetrahedra, Pa (see `skin_volume.rs`: keeps the
    /// thin skin from turning inside out under a press). Typical 5·10⁴.
    pub skin_volume: Option<f64>,
}

impl Effects {
    /// Every effect on, with typical values: the configuration `lamina bench effects`
    /// compares against springs only.
    pub fn all_on() -> Self {
        Self {
            gravity: Some([0.0, -9.81, 0.0]),
            viscous_damping: Some(0.5),
            spring_damping: true,
            bone: true,
            bone_motion: Some(BoneMotion { amplitude: [0.0, 0.002, 0.0], frequency_hz: 1.0 }),
            loads: Vec::new(),
            handles: Vec::new(),
            guard: Some(GuardSettings::default()),
            tool: None,
            skin_volume: Some(5e4),
        }
    }

    /// Names of the stages these effects put in the loop, in loop order.
    pub fn stage_names(&self) -> Vec<&'static str> {
        let mut names = Vec::new();
        if !self.loads.is_empty() {
            names.push("loads");
        }
        if !self.handles.is_empty() {
            names.push("handles");
        }
        if self.tool.is_some() {
            names.push("tool");
        }
        if self.skin_volume.is_some() {
            names.push("skin volume");
        }
        names.push(if self.spring_damping { "springs+dashpots" } else { "springs" });
        if self.gravity.is_some() {
            names.push("gravity");
        }
        if self.viscous_damping.is_some() {
            names.push("viscous");
        }
        if self.bone {
            names.push("bone");
        }
        if self.guard.is_some() {
            names.push("guard");
        }
        names
    }
}
