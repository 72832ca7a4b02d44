//! The core's side of the haptic loop: the newest `ToolCommand` from the haptics process
//! moves the scene's sphere tool before each step; after the step the contact force and its
//! local stiffness go out on `feedback` (every tick, also when there is no contact, so that
//! the haptics process can tell a quiet core from a tool in free space).
//!
//! Bad commands (non-finite pose or radius, positions beyond 1 km) are counted and ignored:
//! the tool stays where the last good command put it. Commands older than the scene's
//! `timeout_ms` park the tool (out of the loop, zero force) until the haptics process is back.

use lamina_bridge::wire::{ContactFeedback, ToolCommand};
use lamina_bridge::{Bridge, FeedbackPublisher, ToolSubscriber, now_ns};
use lamina_core::real::Real;
use lamina_core::scene::{ToolSettings, ToolSource};
use lamina_core::solver::{Simulation, SphereTool};

/// Largest plausible tool coordinate, m; anything beyond is a corrupt command.
const MAX_COORDINATE_M: f64 = 1e3;

/// Counts of what the link did, for the run's report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HapticLinkCounts {
    /// Tool commands applied.
    pub commands: u64,
    /// Tool commands refused (non-finite or implausible).
    pub bad_commands: u64,
    /// Times the tool was parked because commands stopped.
    pub parked: u64,
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
    settings: ToolSettings,
    timeout_ns: u64,
    last_command_ns: Option<u64>,
    /// What the link did so far.
    pub counts: HapticLinkCounts,
}

/// Whether a command can move the tool.
fn command_is_sane(c: &ToolCommand) -> bool {
    c.position.iter().all(|p| p.is_finite() && p.abs() < MAX_COORDINATE_M)
        && c.tool_radius_m.is_finite()
        && (0.0..1.0).contains(&c.tool_radius_m)
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
            counts: HapticLinkCounts::default(),
        }))
    }

    /// Applies the newest tool command (or parks a tool whose commands stopped).
    pub fn before_step<T: Real>(&mut self, sim: &mut Simulation<T>) {
        let now = now_ns();
        match self.tool.latest() {
            Ok(Some(sample)) => {
                let c = *sample.message();
                if command_is_sane(&c) {
                    let radius = if c.tool_radius_m > 0.0 { c.tool_radius_m } else { self.settings.radius };
                    sim.effects_mut().tool = Some(SphereTool {
                        radius,
                        stiffness: self.settings.stiffness,
                        start: c.position,
                        velocity: [0.0; 3],
                    });
                    self.last_command_ns = Some(now);
                    self.counts.commands += 1;
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
            sim.effects_mut().tool = None;
            self.last_command_ns = None;
            self.counts.parked += 1;
        }
    }

    /// Publishes the contact feedback of the step just taken.
    pub fn after_step<T: Real>(&mut self, sim: &Simulation<T>, tick: u64) {
        let mut msg = ContactFeedback { sequence: self.counts.feedback, tick, ..ContactFeedback::default() };
        if let Some(tool) = sim.effects().tool {
            let fb = sim.tool_feedback();
            msg.x_ref = tool.start;
            let finite = fb.force.iter().chain(fb.stiffness.iter().flatten()).all(|v| v.is_finite());
            if finite {
                msg.in_contact = u32::from(fb.in_contact);
                msg.force = fb.force;
                msg.stiffness = fb.stiffness;
            } else {
                self.counts.bad_feedback += 1;
            }
        }
        msg.publish_time_ns = now_ns();
        match self.feedback.publish_polled(&msg) {
            Ok(_) => self.counts.feedback += 1,
            Err(_) => self.counts.failures += 1,
        }
    }
}
