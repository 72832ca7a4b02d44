//! The core's side of the haptic loop: the newest `ToolCommand` from the haptics process
//! moves the scene's sphere tool before each step; after the step the contact force and its
//! local stiffness go out on `feedback` (every tick, also when there is no contact, so that
//! the haptics process can tell a quiet core from a tool in free space).
//!
//! # Push and pull
//! - Without buttons the tool is a rigid sphere pushing nodes out (penalty contact).
//! - While button 0 is held the tool **grasps**: the free nodes within 1.25 radii of its
//!   centre when the button went down (at most [`MAX_GRASPED`]) hang on springs of the tool's
//!   stiffness at their offsets from the centre, so moving the tool pulls the tissue (the
//!   paper's Fig. 12). The feedback is the springs' reaction and stiffness. Releasing the
//!   button (or the tool being parked) lets go.
//!
//! Bad commands (non-finite pose or radius, positions beyond 1 km) are counted and ignored:
//! the tool stays where the last good command put it. Commands older than the scene's
//! `timeout_ms` park the tool (out of the loop, zero force) until the haptics process is back.
//! Nothing here allocates after [`HapticLink::prepare`].

use lamina_bridge::wire::{ContactFeedback, ToolCommand};
use lamina_bridge::{Bridge, FeedbackPublisher, ToolSubscriber, now_ns};
use lamina_core::real::Real;
use lamina_core::scene::{Scene, ToolSettings, ToolSource};
use lamina_core::solver::{DragHandle, Effects, Simulation, SphereTool};

/// Largest plausible tool coordinate, m; anything beyond is a corrupt command.
const MAX_COORDINATE_M: f64 = 1e3;

/// Most nodes one grasp holds.
pub const MAX_GRASPED: usize = 32;

/// Grasp reach, in tool radii.
const GRASP_REACH: f64 = 1.25;

/// Damping of a grasp spring, N·s/m.
const GRASP_DAMPING: f64 = 0.01;

/// Counts of what the link did, for the run's report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HapticLinkCounts {
    /// Tool commands applied.
    pub commands: u64,
    /// Tool commands refused (non-finite or implausible).
    pub bad_commands: u64,
    /// Commands whose radius was below the scene's `min_radius` and was raised to it.
    pub radius_raised: u64,
    /// Times the tool was parked because commands stopped.
    pub parked: u64,
    /// Grasps made (button 0 pressed with nodes in reach).
    pub grasps: u64,
    /// Feedback messages published.
    pub feedback: u64,
    /// Feedback replaced by "no contact" because the contact force was not finite.
    pub bad_feedback: u64,
    /// Failed publishes or receives.
    pub failures: u64,
}

/// Nodes held by the tool.
struct Grasp {
    /// Index of the first grasp handle in `effects.handles` (the scene's own come first).
    first_handle: usize,
    count: usize,
    offsets: [[f64; 3]; MAX_GRASPED],
}

/// Ports and state of the core's haptic link.
pub struct HapticLink {
    tool: ToolSubscriber,
    feedback: FeedbackPublisher,
    settings: ToolSettings,
    timeout_ns: u64,
    last_command_ns: Option<u64>,
    centre: [f64; 3],
    radius: f64,
    buttons: u32,
    grasp: Option<Grasp>,
    /// What the link did so far.
    pub counts: HapticLinkCounts,
}

/// Whether a command can move the tool.
fn command_is_sane(c: &ToolCommand) -> bool {
    c.position.iter().all(|p| p.is_finite() && p.abs() < MAX_COORDINATE_M)
        && c.tool_radius_m.is_finite()
        && (0.0..1.0).contains(&c.tool_radius_m)
}

/// The effects to build the simulation with: a haptics-driven tool is included (far away)
/// so that the critical step accounts for its stiffness; the caller parks it right after.
pub fn effects_for_build(scene: &Scene) -> Effects {
    let mut effects = scene.effects.clone();
    if let Some(t) = &scene.tool
        && effects.tool.is_none()
    {
        effects.tool = Some(SphereTool {
            // The skin's point shell is sampled for the radius the tool is built with.
            radius: t.shell_radius(),
            stiffness: t.stiffness,
            start: [MAX_COORDINATE_M; 3],
            velocity: [0.0; 3],
        });
    }
    effects
}

impl HapticLink {
    /// Opens the `tool` subscriber and `feedback` publisher; `None` when the scene's tool is
    /// not driven by haptics.
    pub fn open(bridge: &Bridge, settings: Option<&ToolSettings>) -> Result<Option<Self>, String> {
        let Some(settings) = settings.copied() else { return Ok(None) };
        let ToolSource::Haptics { timeout_s, .. } = settings.source else { return Ok(None) };
        let tool = ToolSubscriber::create(bridge).map_err(|e| format!("tool service: {e}"))?;
        let feedback = FeedbackPublisher::create(bridge).map_err(|e| format!("feedback service: {e}"))?;
        Ok(Some(Self {
            tool,
            feedback,
            settings,
            timeout_ns: (timeout_s * 1e9) as u64,
            last_command_ns: None,
            centre: [0.0; 3],
            radius: settings.radius,
            buttons: 0,
            grasp: None,
            counts: HapticLinkCounts::default(),
        }))
    }

    /// Before the loop: reserves room for a grasp's handles.
    pub fn prepare<T: Real>(&mut self, sim: &mut Simulation<T>) {
        sim.effects_mut().handles.reserve(MAX_GRASPED);
    }

    /// Applies the newest tool command (or parks a tool whose commands stopped).
    pub fn before_step<T: Real>(&mut self, sim: &mut Simulation<T>) {
        let now = now_ns();
        match self.tool.latest() {
            Ok(Some(sample)) => {
                let c = *sample.message();
                if command_is_sane(&c) {
                    self.centre = c.position;
                    let (radius, raised) = self.settings.commanded_radius(c.tool_radius_m);
                    self.radius = radius;
                    self.counts.radius_raised += u64::from(raised);
                    self.buttons = c.buttons;
                    self.last_command_ns = Some(now);
                    self.counts.commands += 1;
                    self.apply(sim);
                } else {
                    self.counts.bad_commands += 1;
                }
            }
            Ok(None) => {}
            Err(_) => self.counts.failures += 1,
        }
        if let Some(last) = self.last_command_ns
            && now.saturating_sub(last) > self.timeout_ns
        {
            self.release(sim);
            sim.effects_mut().tool = None;
            self.last_command_ns = None;
            self.counts.parked += 1;
        }
    }

    /// Moves the sphere, or the grasp, to the commanded pose.
    fn apply<T: Real>(&mut self, sim: &mut Simulation<T>) {
        let grasping = self.buttons & 1 != 0;
        if grasping && self.grasp.is_none() {
            self.capture(sim);
        } else if !grasping {
            self.release(sim);
        }
        let centre = self.centre;
        match &self.grasp {
            Some(g) => {
                let handles = &mut sim.effects_mut().handles[g.first_handle..g.first_handle + g.count];
                for (h, off) in handles.iter_mut().zip(&g.offsets) {
                    h.target = [0, 1, 2].map(|c| centre[c] + off[c]);
                }
            }
            None => {
                sim.effects_mut().tool = Some(SphereTool {
                    radius: self.radius,
                    stiffness: self.settings.stiffness,
                    start: centre,
                    velocity: [0.0; 3],
                });
            }
        }
    }

    /// Grasps the free nodes within reach (nearest first is not needed: all in reach, in
    /// index order, up to [`MAX_GRASPED`]).
    fn capture<T: Real>(&mut self, sim: &mut Simulation<T>) {
        let reach2 = (GRASP_REACH * self.radius).powi(2);
        let mut g = Grasp { first_handle: sim.effects().handles.len(), count: 0, offsets: [[0.0; 3]; MAX_GRASPED] };
        let n = sim.state().x.len();
        for i in 0..n {
            if g.count == MAX_GRASPED {
                break;
            }
            let p = sim.state().x.get_f64(i);
            let d = [0, 1, 2].map(|c| p[c] - self.centre[c]);
            if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach2 && sim.node_is_free(i) {
                g.offsets[g.count] = d;
                g.count += 1;
                sim.effects_mut().handles.push(DragHandle {
                    node: i as u32,
                    target: p,
                    stiffness: self.settings.stiffness,
                    damping: GRASP_DAMPING,
                });
            }
        }
        if g.count > 0 {
            sim.effects_mut().tool = None;
            self.grasp = Some(g);
            self.counts.grasps += 1;
        }
    }

    /// Lets go of grasped nodes.
    fn release<T: Real>(&mut self, sim: &mut Simulation<T>) {
        if let Some(g) = self.grasp.take() {
            sim.effects_mut().handles.truncate(g.first_handle);
        }
    }

    /// Publishes the contact feedback of the step just taken.
    pub fn after_step<T: Real>(&mut self, sim: &Simulation<T>, tick: u64) {
        let mut msg = ContactFeedback { sequence: self.counts.feedback, tick, ..ContactFeedback::default() };
        msg.x_ref = self.centre;
        if let Some(g) = &self.grasp {
            // The grasp springs' reaction on the tool, and their stiffness with respect to it.
            let k = self.settings.stiffness;
            let handles = &sim.effects().handles[g.first_handle..g.first_handle + g.count];
            let mut force = [0.0; 3];
            for h in handles {
                let p = sim.state().x.get_f64(h.node as usize);
                for c in 0..3 {
                    force[c] -= k * (h.target[c] - p[c]);
                }
            }
            let kn = -k * g.count as f64;
            msg.in_contact = 1;
            msg.force = force;
            msg.stiffness = [[kn, 0.0, 0.0], [0.0, kn, 0.0], [0.0, 0.0, kn]];
        } else if sim.effects().tool.is_some() {
            let fb = sim.tool_feedback();
            msg.in_contact = u32::from(fb.in_contact);
            msg.force = fb.force;
            msg.stiffness = fb.stiffness;
        }
        let finite = msg.force.iter().chain(msg.stiffness.iter().flatten()).all(|v| v.is_finite());
        if !finite {
            self.counts.bad_feedback += 1;
            msg.in_contact = 0;
            msg.force = [0.0; 3];
            msg.stiffness = [[0.0; 3]; 3];
        }
        msg.publish_time_ns = now_ns();
        match self.feedback.publish_polled(&msg) {
            Ok(_) => self.counts.feedback += 1,
            Err(_) => self.counts.failures += 1,
        }
    }
}
