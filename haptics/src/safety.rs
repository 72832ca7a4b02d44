//! What the haptics process tells the operator about safety, and how often it happened.

/// One safety event. Events are sent from the device loop to a logger thread over a bounded
/// channel (never blocking the loop; a full channel drops the event, the counters still count).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyEvent {
    /// `CLOCK_MONOTONIC` when it happened, ns.
    pub time_ns: u64,
    /// Device-loop tick.
    pub tick: u64,
    /// What happened.
    pub kind: SafetyEventKind,
}

/// The kinds of [`SafetyEvent`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SafetyEventKind {
    /// A feedback message from the core held NaN or infinity; it was discarded and the force
    /// set to zero until a good one arrives.
    NonFiniteFeedback,
    /// The device reported a non-finite pose; zero force, no tool command sent.
    NonFiniteDevicePose,
    /// The rendered force was not finite (should not happen after the checks above); zero sent.
    NonFiniteForce,
    /// The force was clamped to the device's limit (logged at the start of each episode).
    ForceClamped {
        /// Norm of the force before clamping, N.
        requested_n: f64,
        /// The device's limit, N.
        limit_n: f64,
    },
    /// No feedback for longer than the quiet limit: force faded to zero.
    CoreQuiet {
        /// Age of the newest feedback, ns.
        age_ns: u64,
    },
    /// Feedback is flowing again after a quiet period (force ramps back in).
    CoreBack,
    /// The device reported a pose beyond its workspace: a sensor or plugin fault. The force
    /// fades to zero and no tool command is sent until the pose is back inside.
    OutsideWorkspace {
        /// Distance of the pose from the workspace centre, m.
        distance_m: f64,
        /// The workspace radius in force, m.
        radius_m: f64,
    },
    /// The pose is back inside the workspace (force ramps back in).
    WorkspaceBack,
    /// A device call took longer than the limit: a fault. The force restarts from zero and
    /// ramps back in.
    DeviceCallStalled {
        /// Which call.
        call: crate::watchdog::DeviceCall,
        /// How long it took, ns.
        duration_ns: u64,
        /// The limit, ns.
        limit_ns: u64,
    },
}

impl SafetyEventKind {
    /// Whether it is a device fault (a pose beyond the workspace, a call that stalled): said
    /// on stderr even when other events are not.
    pub fn is_fault(&self) -> bool {
        matches!(self, Self::OutsideWorkspace { .. } | Self::DeviceCallStalled { .. })
    }
}

impl core::fmt::Display for SafetyEventKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NonFiniteFeedback => write!(f, "non-finite contact feedback from the core: discarded, zero force"),
            Self::NonFiniteDevicePose => write!(f, "non-finite device pose: zero force, no tool command"),
            Self::NonFiniteForce => write!(f, "non-finite force computed: zero force sent"),
            Self::ForceClamped { requested_n, limit_n } => {
                write!(f, "force {requested_n:.2} N clamped to the device limit {limit_n:.2} N")
            }
            Self::CoreQuiet { age_ns } => {
                write!(f, "core quiet for {:.2} ms: force faded to zero", *age_ns as f64 / 1e6)
            }
            Self::CoreBack => write!(f, "core feedback back: force ramps in"),
            Self::OutsideWorkspace { distance_m, radius_m } => write!(
                f,
                "device pose {distance_m:.3e} m from the workspace centre, beyond its {radius_m} m radius: fault, force fades to zero, no tool command"
            ),
            Self::WorkspaceBack => write!(f, "device pose back inside the workspace: force ramps in"),
            Self::DeviceCallStalled { call, duration_ns, limit_ns } => write!(
                f,
                "device call {call} took {:.2} ms (limit {:.0} ms): fault, force restarts from zero",
                *duration_ns as f64 / 1e6,
                *limit_ns as f64 / 1e6
            ),
        }
    }
}

/// How often each safety measure acted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct SafetyCounts {
    /// Feedback messages accepted.
    pub feedback_accepted: u64,
    /// Feedback messages discarded as non-finite.
    pub feedback_non_finite: u64,
    /// Device samples with a non-finite pose.
    pub device_pose_non_finite: u64,
    /// Forces found non-finite and replaced by zero.
    pub force_non_finite: u64,
    /// Ticks whose force was clamped to the device limit.
    pub force_clamped_ticks: u64,
    /// Feedback messages whose stiffness was limited to the device's stable stiffness.
    pub stiffness_limited: u64,
    /// Ticks rendered at zero force because the core was quiet (or never spoke).
    pub quiet_ticks: u64,
    /// Quiet episodes (transitions from live to quiet).
    pub quiet_episodes: u64,
    /// Ticks whose device pose lay beyond the workspace radius.
    pub workspace_fault_ticks: u64,
    /// Workspace faults (transitions from inside to outside).
    pub workspace_faults: u64,
    /// Device calls (read or write) that took longer than the limit.
    pub device_call_stalls: u64,
    /// Events the logger channel could not take (counted here, not lost from the counters).
    pub events_dropped: u64,
}
