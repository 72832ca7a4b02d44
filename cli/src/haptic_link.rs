//! The core's side of the haptic loop: the newest `ToolCommand` from the haptics process
//! moves the scene's sphere tool before each step; after the step the contact force and its
//! local stiffness go out on `feedback` (every tick, also when there is no contact, so that
//! the haptics process can tell a quiet core from a tool in free space).
//!
//! The tool itself (press, grasp while button 0 is held, release) is the physics library's
//! [`HandTool`]; this module maps commands onto it and its feedback onto the wire.
//!
//! Bad commands (non-finite pose, radius or blade length, positions beyond 1 km, a tool kind
//! other than sphere or scalpel) are counted and ignored: the tool stays where the last good
//! command put it. A scalpel command parks the sphere and moves the scene's scalpel
//! (`[scalpel]`, [`Scalpel`]): its tip presses the skin, and once through it the edge cuts;
//! without a `[scalpel]` it cuts nothing. Commands older than the scene's
//! `timeout_ms` park the tool (out of the loop, zero force) until the haptics process is back.
//! Nothing here allocates after [`HapticLink::attach`].

use lamina_bridge::wire::{ContactFeedback, ToolCommand, ToolKind};
use lamina_bridge::{Bridge, FeedbackPublisher, ToolSubscriber, now_ns};
use lamina_core::hand_tool::HandTool;
use lamina_core::incision::{Blade, Scalpel};
use lamina_core::real::Real;
use lamina_core::scene::{ToolSettings, ToolSource};
use lamina_core::solver::Simulation;

/// Largest plausible tool coordinate, m; anything beyond is a corrupt command.
const MAX_COORDINATE_M: f64 = 1e3;

/// Counts of what the link did, for the run's report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HapticLinkCounts {
    /// Tool commands applied.
    pub commands: u64,
    /// Tool commands refused (non-finite or implausible), unknown kinds included.
    pub bad_commands: u64,
    /// Of `bad_commands`: commands of a tool kind that is neither sphere nor scalpel.
    pub unknown_kinds: u64,
    /// Scalpel commands applied (the sphere stays parked while they come).
    pub scalpel_commands: u64,
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

/// Ports and state of the core's haptic link.
pub struct HapticLink {
    tool: ToolSubscriber,
    feedback: FeedbackPublisher,
    timeout_ns: u64,
    last_command_ns: Option<u64>,
    /// The tool, from [`HapticLink::attach`].
    hand: Option<HandTool>,
    /// The scene's scalpel, from [`HapticLink::attach_scalpel`], and the tick, s.
    scalpel: Option<(Scalpel, f64)>,
    /// Whether the last command was the scalpel's.
    cutting: bool,
    /// What the link did so far.
    pub counts: HapticLinkCounts,
}

/// Whether a command can move the tool.
fn command_is_sane(c: &ToolCommand) -> bool {
    c.position.iter().all(|p| p.is_finite() && p.abs() < MAX_COORDINATE_M)
        && c.tool_radius_m.is_finite()
        && (0.0..1.0).contains(&c.tool_radius_m)
        && c.blade_length_m.is_finite()
        && (0.0..1.0).contains(&c.blade_length_m)
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
            timeout_ns: (timeout_s * 1e9) as u64,
            last_command_ns: None,
            hand: None,
            scalpel: None,
            cutting: false,
            counts: HapticLinkCounts::default(),
        }))
    }

    /// Before the loop: the tool the simulation was built with ([`HandTool::simulation`]).
    pub fn attach(&mut self, hand: HandTool) {
        self.hand = Some(hand);
    }

    /// Before the loop: the scene's scalpel (`[scalpel]`), which scalpel commands drive, for
    /// ticks of `dt` s. Without one, scalpel commands keep the sphere parked and cut nothing.
    pub fn attach_scalpel(&mut self, scalpel: Scalpel, dt: f64) {
        self.scalpel = Some((scalpel, dt));
    }

    /// The scalpel's totals (springs cut per layer, punctures, peak forces), when attached.
    pub fn scalpel_totals(&self) -> Option<lamina_core::incision::ScalpelTotals> {
        self.scalpel.as_ref().map(|(s, _)| s.totals())
    }

    /// Applies the newest tool command (or parks a tool whose commands stopped).
    pub fn before_step<T: Real>(&mut self, sim: &mut Simulation<T>) {
        let now = now_ns();
        let Some(hand) = self.hand.as_mut() else { return };
        match self.tool.latest() {
            Ok(Some(sample)) => {
                let c = *sample.message();
                match c.kind() {
                    _ if !command_is_sane(&c) => self.counts.bad_commands += 1,
                    Err(_) => {
                        self.counts.unknown_kinds += 1;
                        self.counts.bad_commands += 1;
                    }
                    Ok(ToolKind::Scalpel) => {
                        // The sphere is out of the loop while the scalpel is in the hand; the
                        // scalpel's tip presses, and cuts once through the skin.
                        if !self.cutting {
                            hand.park(sim);
                        }
                        if let Some((scalpel, dt)) = self.scalpel.as_mut() {
                            let length =
                                if c.blade_length_m > 0.0 { c.blade_length_m } else { scalpel.settings().blade_length };
                            scalpel.move_to(sim, Blade::from_pose(c.position, c.orientation, length), *dt);
                        }
                        self.cutting = true;
                        self.last_command_ns = Some(now);
                        self.counts.scalpel_commands += 1;
                    }
                    Ok(ToolKind::Sphere) => {
                        if self.cutting {
                            if let Some((scalpel, _)) = self.scalpel.as_mut() {
                                scalpel.lift(sim);
                            }
                            self.cutting = false;
                        }
                        // Button 0 grasps at the commanded centre; letting it go releases, and
                        // the sphere presses again.
                        let grasping = c.buttons & 1 != 0;
                        if !grasping {
                            hand.release(sim);
                        }
                        let raised = hand.move_to(sim, c.position, Some(c.tool_radius_m));
                        if grasping && !hand.is_grasping() && hand.grasp(sim) > 0 {
                            self.counts.grasps += 1;
                        }
                        self.counts.radius_raised += u64::from(raised);
                        self.last_command_ns = Some(now);
                        self.counts.commands += 1;
                    }
                }
            }
            Ok(None) => {}
            Err(_) => self.counts.failures += 1,
        }
        if let Some(last) = self.last_command_ns
            && now.saturating_sub(last) > self.timeout_ns
        {
            hand.park(sim);
            if let Some((scalpel, _)) = self.scalpel.as_mut() {
                scalpel.lift(sim);
            }
            self.cutting = false;
            self.last_command_ns = None;
            self.counts.parked += 1;
        }
    }

    /// Publishes the contact feedback of the step just taken.
    pub fn after_step<T: Real>(&mut self, sim: &Simulation<T>, tick: u64) {
        let mut msg = ContactFeedback { sequence: self.counts.feedback, tick, ..ContactFeedback::default() };
        let scalpel = self.scalpel.as_ref().filter(|_| self.cutting).map(|(s, _)| s);
        if let Some(scalpel) = scalpel {
            let fb = scalpel.feedback(sim);
            msg.x_ref = fb.centre;
            msg.in_contact = u32::from(fb.in_contact);
            msg.force = fb.force;
            msg.stiffness = fb.stiffness;
        } else if let Some(hand) = &self.hand {
            let fb = hand.feedback(sim);
            msg.x_ref = hand.centre();
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
