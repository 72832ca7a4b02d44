//! What `lamina demo` measures of the tool's work, from the core's own messages: a thread of
//! the demo process subscribes to the core's node frames, its contact feedback and the tool
//! commands, and keeps
//! - the peak press under the tool: the largest downward displacement of a node whose
//!   horizontal distance from the tool's centre is less than the tool's radius (the skin
//!   under the sphere), from its position in the first frame received (the limb at rest,
//!   settled under gravity, before the tool arrives), before the first grasp (the skin's
//!   recoil and the grasp's pull-back after a grasp are not the press);
//! - the peak pull: the largest upward displacement of such a node while button 0 (grasp)
//!   is held;
//! - the peak force on the tool: the largest magnitude of the force the core reports on
//!   `feedback` (the skin pushing the sphere back, or pulling the grasp back), before the
//!   haptics process's own stiffness and force limits.
//!
//! Model frame: y up, metres. The tool's centre is the core's (`ContactFeedback::x_ref`).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use lamina_bridge::{Bridge, BridgeConfig, FeedbackSubscriber, NodesSubscriber, SampleReceiveError, ToolSubscriber};

/// The figures of one demo run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Peaks {
    /// Node frames examined.
    pub frames: u64,
    /// Feedback messages read.
    pub feedback: u64,
    /// Largest downward displacement of the skin under the tool while pressing, m.
    pub press_m: f64,
    /// How far the tool's lowest point went below the highest rest node under it, m.
    pub tool_depth_m: f64,
    /// Largest upward displacement of the skin under the tool while grasping, m.
    pub pull_m: f64,
    /// Largest force on the tool the core reported, N.
    pub force_n: f64,
    /// Largest force on the tool before the first grasp (pressing), N.
    pub press_force_n: f64,
    /// Whether every force read was finite.
    pub force_finite: bool,
}

impl std::fmt::Display for Peaks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "peak skin displacement under the tool: {:.2} mm down pressing (tool {:.2} mm below the rest skin), \
             {:.2} mm up pulling; peak force on the tool {:.4} N{} ({:.4} N pressing) (from {} node frames and {} \
             feedback messages of the core)",
            self.press_m * 1e3,
            self.tool_depth_m * 1e3,
            self.pull_m * 1e3,
            self.force_n,
            if self.force_finite { "" } else { " (non-finite forces seen)" },
            self.press_force_n,
            self.frames,
            self.feedback
        )
    }
}

/// The running watcher.
pub struct Watch {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Result<Peaks, String>>,
}

impl Watch {
    /// Subscribes under `prefix` (before the core starts, so no frame is missed) with the
    /// scene's tool `radius_m`, used until a tool command names one.
    pub fn start(prefix: &str, radius_m: f64) -> Result<Self, String> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let prefix = prefix.to_owned();
        // The ports belong to the thread that uses them; it says when they are open.
        let (ready_tx, ready_rx) = std::sync::mpsc::sync_channel::<Result<(), String>>(1);
        let thread = std::thread::Builder::new()
            .name("demo-watch".into())
            .spawn(move || {
                let ports = open(&prefix);
                let (_bridge, nodes, tool, feedback) = match ports {
                    Ok(p) => {
                        let _ = ready_tx.send(Ok(()));
                        p
                    }
                    Err(e) => {
                        let _ = ready_tx.send(Err(e.clone()));
                        return Err(e);
                    }
                };
                watch(&nodes, &tool, &feedback, radius_m, &flag)
            })
            .map_err(|e| format!("demo watch: {e}"))?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Self { stop, thread }),
            Ok(Err(e)) => Err(e),
            Err(_) => Err("demo watch: the thread stopped before subscribing".into()),
        }
    }

    /// Stops the watcher and returns what it measured.
    pub fn finish(self) -> Result<Peaks, String> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().map_err(|_| "demo watch: the thread panicked".to_string())?
    }
}

fn open(prefix: &str) -> Result<(Bridge, NodesSubscriber, ToolSubscriber, FeedbackSubscriber), String> {
    let bridge = Bridge::open(&BridgeConfig::with_prefix(prefix)).map_err(|e| format!("demo watch: {e}"))?;
    let port = |what: &str, e: &dyn std::fmt::Display| format!("demo watch: {what} service: {e}");
    let nodes = NodesSubscriber::create(&bridge).map_err(|e| port("nodes", &e))?;
    let tool = ToolSubscriber::create(&bridge).map_err(|e| port("tool", &e))?;
    let feedback = FeedbackSubscriber::create(&bridge).map_err(|e| port("feedback", &e))?;
    Ok((bridge, nodes, tool, feedback))
}

fn watch(
    nodes: &NodesSubscriber,
    tool: &ToolSubscriber,
    feedback: &FeedbackSubscriber,
    mut radius: f64,
    stop: &AtomicBool,
) -> Result<Peaks, String> {
    let mut peaks = Peaks { force_finite: true, ..Peaks::default() };
    let mut rest: Vec<[f32; 3]> = Vec::new();
    let mut centre: Option<[f64; 3]> = None;
    let mut buttons = 0u32;
    let mut grasped = false;
    while !stop.load(Ordering::Relaxed) {
        if let Ok(Some(c)) = tool.latest() {
            let c = c.message();
            buttons = c.buttons;
            grasped |= buttons & 1 != 0;
            if c.tool_radius_m > 0.0 && c.tool_radius_m.is_finite() {
                radius = c.tool_radius_m;
            }
        }
        while let Ok(Some(s)) = feedback.try_receive() {
            let m = s.message();
            peaks.feedback += 1;
            let f = m.force.iter().map(|v| v * v).sum::<f64>().sqrt();
            if f.is_finite() {
                peaks.force_n = peaks.force_n.max(f);
                if !grasped {
                    peaks.press_force_n = peaks.press_force_n.max(f);
                }
            } else {
                peaks.force_finite = false;
            }
            centre = m.x_ref.iter().all(|v| v.is_finite() && v.abs() < 1e3).then_some(m.x_ref);
        }
        match nodes.receive_timeout(Duration::from_millis(2)) {
            Ok(Some(frame)) => {
                let x = frame.positions();
                peaks.frames += 1;
                if rest.len() != x.len() {
                    // The first frame (or a restarted core's) is the rest shape.
                    rest = x.to_vec();
                    continue;
                }
                if let Some(c) = centre {
                    under_tool(&rest, x, c, radius, buttons, grasped, &mut peaks);
                }
            }
            // A signal (the demo's Ctrl-C) interrupts the wait: check the stop flag again.
            Ok(None) | Err(SampleReceiveError::Interrupted) => {}
            Err(e) => return Err(format!("demo watch: node frames: {e}")),
        }
    }
    Ok(peaks)
}

/// Updates `peaks` with the nodes under a tool at `centre` of `radius` (model frame, y up).
/// `grasped`: a grasp was made earlier in the run (press figures are no longer taken).
fn under_tool(
    rest: &[[f32; 3]],
    x: &[[f32; 3]],
    centre: [f64; 3],
    radius: f64,
    buttons: u32,
    grasped: bool,
    peaks: &mut Peaks,
) {
    let mut top = f64::NEG_INFINITY;
    for (r, p) in rest.iter().zip(x) {
        let (dx, dz) = (f64::from(r[0]) - centre[0], f64::from(r[2]) - centre[2]);
        if dx * dx + dz * dz >= radius * radius {
            continue;
        }
        let dy = f64::from(p[1]) - f64::from(r[1]);
        top = top.max(f64::from(r[1]));
        if buttons & 1 != 0 {
            peaks.pull_m = peaks.pull_m.max(dy);
        } else if !grasped {
            peaks.press_m = peaks.press_m.max(-dy);
        }
    }
    if !grasped && top.is_finite() {
        peaks.tool_depth_m = peaks.tool_depth_m.max(top - (centre[1] - radius));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_nodes_under_the_tool_count() {
        let rest = [[0.0, 0.0, 0.0], [0.02, 0.0, 0.0], [0.0, -0.01, 0.004]];
        let x = [[0.0, -0.005, 0.0], [0.02, -0.009, 0.0], [0.0, -0.012, 0.004]];
        let mut p = Peaks::default();
        under_tool(&rest, &x, [0.0, 0.006, 0.0], 0.01, 0, false, &mut p);
        // The node 2 cm away (9 mm down) is outside the 1 cm footprint.
        assert!((p.press_m - 0.005).abs() < 1e-6, "{p:?}");
        assert!((p.tool_depth_m - 0.004).abs() < 1e-9, "{p:?}");
        let pulled = [[0.0, 0.003, 0.0], [0.02, 0.0, 0.0], [0.0, -0.01, 0.004]];
        under_tool(&rest, &pulled, [0.0, 0.006, 0.0], 0.01, 1, true, &mut p);
        assert!((p.pull_m - 0.003).abs() < 1e-6, "{p:?}");
        // A deeper dip after the grasp (the skin's recoil) is not the press.
        under_tool(&rest, &x.map(|q| [q[0], q[1] - 0.01, q[2]]), [0.0, 0.0, 0.0], 0.01, 0, true, &mut p);
        assert!((p.press_m - 0.005).abs() < 1e-6, "after a grasp the press peak stays: {p:?}");
    }
}
