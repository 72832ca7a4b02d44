//! Force rendering at the device rate from the core's latest contact model.

use super::mapping::DeviceMapping;
use super::safety::{SafetyCounts, SafetyEventKind};
use crate::device::{DeviceInfo, norm3};
use lamina_bridge::wire::ContactFeedback;

/// How the renderer keeps the device stable and the operator safe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderLimits {
    /// Largest force norm sent to the device, N. Default: the device's `max_force_n`.
    pub max_force_n: f64,
    /// Largest local stiffness rendered (Frobenius norm, an upper bound of the spectral
    /// norm), N/m. Default: the device's `max_stiffness_n_per_m`.
    pub max_stiffness_n_per_m: f64,
    /// Viscous coupling damping applied while in contact, N·s/m. Default:
    /// `min(max_damping, max_stiffness · period)`, twice the passivity bound `K·T/2` of a
    /// sampled virtual wall (Colgate and Schenkel 1997).
    pub damping_n_s_per_m: f64,
    /// Feedback younger than this renders at full strength, ns. Default 3 ms: a core tick
    /// up to two periods late (at 1 kHz) goes unnoticed by the hand.
    pub quiet_after_ns: u64,
    /// After `quiet_after_ns` the force fades linearly to zero over this, ns. Default 1.5 ms,
    /// so a quiet core gives zero force 4.5 ms after its last message (the requirement is 5 ms;
    /// the margin covers one device-loop period).
    pub fade_ns: u64,
    /// When feedback starts (or resumes), the force ramps in over this, ns. Default 20 ms.
    pub onset_ns: u64,
    /// A handle farther than this from the workspace centre is a fault, m. Default: the
    /// device's `workspace_radius_m`.
    pub workspace_radius_m: f64,
}

impl RenderLimits {
    /// The defaults for `device` with a device loop of `period_ns`.
    pub fn for_device(info: &DeviceInfo, period_ns: u64) -> Self {
        let k = info.max_stiffness_n_per_m;
        Self {
            max_force_n: info.max_force_n,
            max_stiffness_n_per_m: k,
            damping_n_s_per_m: info.max_damping_n_s_per_m.min(k * period_ns as f64 * 1e-9),
            quiet_after_ns: 3_000_000,
            fade_ns: 1_500_000,
            onset_ns: 20_000_000,
            workspace_radius_m: info.workspace_radius_m,
        }
    }

    /// Time after the last feedback at which the force is zero, ns.
    pub fn zero_after_ns(&self) -> u64 {
        self.quiet_after_ns + self.fade_ns
    }
}

/// The force for one device tick, with what shaped it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RenderedForce {
    /// Force to command, N, device frame; always finite and within the limit.
    pub force_n: [f64; 3],
    /// Staleness and onset gain applied, 0..=1.
    pub gain: f64,
    /// Whether the local model says the tool touches the tissue.
    pub in_contact: bool,
    /// Whether the force was clamped to the device limit.
    pub clamped: bool,
}

/// The core's contact model in device coordinates: `F(x) = f0 + K (x − x_ref)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct LocalModel {
    f0: [f64; 3],
    k: [[f64; 3]; 3],
    x_ref: [f64; 3],
    in_contact: bool,
}

/// Renders force between core ticks (virtual coupling through the core's local contact model).
///
/// # How it works
/// 1. [`accept_feedback`](Self::accept_feedback) takes each new `feedback` message: checks it
///    is finite (else discards it and reports [`SafetyEventKind::NonFiniteFeedback`]), maps it
///    into the device frame and limits its stiffness to the device's stable stiffness.
/// 2. [`render`](Self::render) evaluates the model at the handle's position, keeps it
///    unilateral (a contact pushes, never pulls: a force turned against the contact normal is
///    zero), adds coupling damping in contact, scales by the staleness gain (full up to
///    `quiet_after_ns`, zero from `quiet_after_ns + fade_ns`, 4.5 ms by default) and the onset
///    ramp, and clamps
///    the norm to the device limit. Whatever comes out is finite.
///
/// It allocates nothing and does no I/O: it runs inside the device loop.
///
/// # Examples
///
/// ```
/// use lamina_haptics::device::DeviceInfo;
/// use lamina_haptics::{DeviceMapping, ForceRenderer, RenderLimits};
/// use lamina_bridge::wire::ContactFeedback;
///
/// let info = DeviceInfo {
///     name: "example".into(),
///     max_force_n: 5.0,
///     max_stiffness_n_per_m: 2000.0,
///     max_damping_n_s_per_m: 10.0,
///     workspace_radius_m: 0.08,
/// };
/// let limits = RenderLimits { onset_ns: 0, ..RenderLimits::for_device(&info, 250_000) };
/// let mut r = ForceRenderer::new(limits, DeviceMapping::y_up_model([0.0; 3]));
/// let mut fb = ContactFeedback { in_contact: 1, ..Default::default() };
/// fb.force = [0.0, 1.5, 0.0]; // the tissue pushes the tool up (model y)
/// r.accept_feedback(&fb, 0).unwrap();
/// let out = r.render([0.0; 3], 1_000_000); // 1 ms later
/// assert_eq!(out.force_n, [0.0, 0.0, 1.5]); // up is the device's z
/// assert_eq!(r.render([0.0; 3], 5_000_000).force_n, [0.0; 3]); // 5 ms: the core is quiet
/// ```
#[derive(Debug, Clone)]
pub struct ForceRenderer {
    limits: RenderLimits,
    mapping: DeviceMapping,
    model: LocalModel,
    last_feedback_ns: Option<u64>,
    live_since_ns: Option<u64>,
    was_quiet: bool,
    was_clamped: bool,
    previous: Option<([f64; 3], u64)>,
    velocity: [f64; 3],
    /// Force of the previous tick, N (what a fault fades from).
    last_force: [f64; 3],
    /// Since when the pose is outside the workspace, and the force it fades from.
    outside: Option<(u64, [f64; 3])>,
    /// How often each safety measure acted.
    pub counts: SafetyCounts,
}

/// Low-pass cutoff of the handle velocity estimate used for damping, Hz.
const VELOCITY_CUTOFF_HZ: f64 = 100.0;

fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

impl ForceRenderer {
    /// A renderer with no contact model yet (it renders zero until the first feedback).
    pub fn new(limits: RenderLimits, mapping: DeviceMapping) -> Self {
        Self {
            limits,
            mapping,
            model: LocalModel::default(),
            last_feedback_ns: None,
            live_since_ns: None,
            was_quiet: true,
            was_clamped: false,
            previous: None,
            velocity: [0.0; 3],
            last_force: [0.0; 3],
            outside: None,
            counts: SafetyCounts::default(),
        }
    }

    /// The limits in force.
    pub fn limits(&self) -> &RenderLimits {
        &self.limits
    }

    /// The device-to-model mapping.
    pub fn mapping(&self) -> &DeviceMapping {
        &self.mapping
    }

    /// Takes a feedback message received at `now_ns`. A non-finite one is discarded (the
    /// previous model keeps ageing toward zero force) and reported.
    pub fn accept_feedback(&mut self, fb: &ContactFeedback, now_ns: u64) -> Result<(), SafetyEventKind> {
        let finite = finite3(&fb.force) && finite3(&fb.x_ref) && fb.stiffness.iter().all(finite3);
        if !finite {
            self.counts.feedback_non_finite += 1;
            return Err(SafetyEventKind::NonFiniteFeedback);
        }
        let in_contact = fb.is_in_contact();
        let mut k = self.mapping.stiffness_to_device(&fb.stiffness);
        let frobenius = k.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
        if frobenius > self.limits.max_stiffness_n_per_m {
            let s = self.limits.max_stiffness_n_per_m / frobenius;
            self.counts.stiffness_limited += 1;
            k.iter_mut().flatten().for_each(|v| *v *= s);
        }
        self.model = LocalModel {
            f0: self.mapping.force_to_device(fb.force),
            k,
            x_ref: self.mapping.to_device(fb.x_ref),
            in_contact,
        };
        self.last_feedback_ns = Some(now_ns);
        if self.live_since_ns.is_none() {
            self.live_since_ns = Some(now_ns);
        }
        self.counts.feedback_accepted += 1;
        Ok(())
    }

    /// The staleness gain at `now_ns`: 1 while feedback is fresh, fading to 0.
    fn staleness_gain(&self, now_ns: u64) -> (f64, u64) {
        let Some(last) = self.last_feedback_ns else { return (0.0, u64::MAX) };
        let age = now_ns.saturating_sub(last);
        let l = &self.limits;
        let gain = if age <= l.quiet_after_ns {
            1.0
        } else if age >= l.zero_after_ns() {
            0.0
        } else {
            1.0 - (age - l.quiet_after_ns) as f64 / l.fade_ns.max(1) as f64
        };
        (gain, age)
    }

    /// The force to command at handle position `x_dev` (m, device frame) at `now_ns`, and
    /// the safety event it raised, if any.
    pub fn render(&mut self, x_dev: [f64; 3], now_ns: u64) -> RenderedForce {
        self.render_with_event(x_dev, now_ns).0
    }

    /// A device call took longer than the limit at `now_ns`: counted, and the force restarts
    /// from zero, ramping in over `onset_ns` (the handle may have moved meanwhile).
    pub fn device_call_stalled(&mut self, now_ns: u64) {
        self.counts.device_call_stalls += 1;
        self.previous = None;
        if self.last_feedback_ns.is_some() {
            self.live_since_ns = Some(now_ns);
        }
    }

    /// As [`render`](Self::render), also returning the event to log (transitions only).
    pub fn render_with_event(&mut self, x_dev: [f64; 3], now_ns: u64) -> (RenderedForce, Option<SafetyEventKind>) {
        let (out, event) = self.render_checked(x_dev, now_ns);
        self.last_force = out.force_n;
        (out, event)
    }

    /// A pose beyond the workspace at `now_ns`: the previous force fades to zero over
    /// `fade_ns` from the first such tick.
    fn outside_workspace(&mut self, distance_m: f64, now_ns: u64) -> (RenderedForce, Option<SafetyEventKind>) {
        self.counts.workspace_fault_ticks += 1;
        self.previous = None;
        let mut event = None;
        let (since, from) = match self.outside {
            Some(fault) => fault,
            None => {
                self.counts.workspace_faults += 1;
                event =
                    Some(SafetyEventKind::OutsideWorkspace { distance_m, radius_m: self.limits.workspace_radius_m });
                let fault = (now_ns, self.last_force);
                self.outside = Some(fault);
                fault
            }
        };
        let left = 1.0 - now_ns.saturating_sub(since) as f64 / self.limits.fade_ns.max(1) as f64;
        let gain = left.clamp(0.0, 1.0);
        (RenderedForce { force_n: from.map(|c| c * gain), gain, ..RenderedForce::default() }, event)
    }

    fn render_checked(&mut self, x_dev: [f64; 3], now_ns: u64) -> (RenderedForce, Option<SafetyEventKind>) {
        let mut event = None;
        if !finite3(&x_dev) {
            self.counts.device_pose_non_finite += 1;
            self.previous = None;
            return (RenderedForce::default(), Some(SafetyEventKind::NonFiniteDevicePose));
        }
        let distance = norm3(x_dev);
        if distance.is_nan() || distance > self.limits.workspace_radius_m {
            return self.outside_workspace(distance, now_ns);
        }
        if self.outside.take().is_some() {
            event = Some(SafetyEventKind::WorkspaceBack);
            if self.last_feedback_ns.is_some() {
                self.live_since_ns = Some(now_ns);
            }
        }
        // Handle velocity, low-passed (for the coupling damping).
        if let Some((p, t)) = self.previous
            && now_ns > t
        {
            let dt = (now_ns - t) as f64 * 1e-9;
            let alpha = dt / (dt + 1.0 / (2.0 * core::f64::consts::PI * VELOCITY_CUTOFF_HZ));
            for c in 0..3 {
                self.velocity[c] += alpha * ((x_dev[c] - p[c]) / dt - self.velocity[c]);
            }
        }
        self.previous = Some((x_dev, now_ns));

        let (stale_gain, age) = self.staleness_gain(now_ns);
        if stale_gain == 0.0 {
            self.counts.quiet_ticks += 1;
            if !self.was_quiet {
                self.was_quiet = true;
                self.counts.quiet_episodes += 1;
                event = Some(SafetyEventKind::CoreQuiet { age_ns: age });
            }
            self.live_since_ns = None;
            return (RenderedForce::default(), event);
        }
        if self.was_quiet {
            self.was_quiet = false;
            if self.counts.quiet_episodes > 0 {
                event = Some(SafetyEventKind::CoreBack);
            }
        }
        let onset_gain = match self.live_since_ns {
            Some(since) if self.limits.onset_ns > 0 => {
                (now_ns.saturating_sub(since) as f64 / self.limits.onset_ns as f64).min(1.0)
            }
            _ => 1.0,
        };
        let gain = stale_gain * onset_gain;
        let m = &self.model;
        if !m.in_contact {
            self.was_clamped = false;
            return (RenderedForce { gain, ..RenderedForce::default() }, event);
        }
        let d = [0, 1, 2].map(|c| x_dev[c] - m.x_ref[c]);
        let mut f = [0, 1, 2].map(|i| m.f0[i] + m.k[i][0] * d[0] + m.k[i][1] * d[1] + m.k[i][2] * d[2]);
        // Unilateral: a contact pushes the tool out; pulled past the surface it lets go.
        let along = f[0] * m.f0[0] + f[1] * m.f0[1] + f[2] * m.f0[2];
        if along <= 0.0 {
            f = [0.0; 3];
        } else {
            for (fc, vc) in f.iter_mut().zip(self.velocity) {
                *fc -= self.limits.damping_n_s_per_m * vc;
            }
        }
        let mut f = f.map(|c| c * gain);
        if !finite3(&f) {
            self.counts.force_non_finite += 1;
            return (
                RenderedForce { gain, in_contact: true, ..RenderedForce::default() },
                Some(SafetyEventKind::NonFiniteForce),
            );
        }
        let n = norm3(f);
        let clamped = n > self.limits.max_force_n;
        if clamped {
            let s = self.limits.max_force_n / n;
            f = f.map(|c| c * s);
            self.counts.force_clamped_ticks += 1;
            if !self.was_clamped {
                event = Some(SafetyEventKind::ForceClamped { requested_n: n, limit_n: self.limits.max_force_n });
            }
        }
        self.was_clamped = clamped;
        (RenderedForce { force_n: f, gain, in_contact: true, clamped }, event)
    }
}
