//! The hand-held tool a haptic device drives: a sphere that presses the tissue, grasps the
//! nodes within its reach and pulls them, and lets go.
//!
//! - **Press**: without a grasp the tool is the scene's rigid sphere pushing nodes and the
//!   skin's point shell out (penalty contact, [`SphereTool`]).
//! - **Grasp**: [`HandTool::grasp`] takes the free nodes within [`GRASP_REACH`] radii of the
//!   centre (at most [`MAX_GRASPED`], in index order) and hangs each on a spring of the tool's
//!   stiffness at its offset from the centre, so moving the tool pulls the tissue (the paper's
//!   Fig. 12). The sphere leaves the loop while grasping.
//! - **Release** lets the nodes go; **park** also takes the sphere out of the loop (no
//!   contact, no cost) until the next move.
//!
//! The simulation is built with the tool in its effects ([`HandTool::simulation`]), so the
//! explicit critical step accounts for the tool's stiffness and the skin's point shell is
//! sampled for the smallest radius the tool can take, and then the tool is parked. Build
//! through it whenever a tool will appear later: a simulation built without the tool has a
//! critical step the tool's contact can break. Nothing allocates after
//! [`HandTool::simulation`].
//!
//! # Examples
//!
//! Press the built-in default limb 4 mm with its tool, then grasp and pull 2 mm up:
//!
//! ```
//! use lamina_core::hand_tool::HandTool;
//! use lamina_core::scene::{Scene, ToolSource};
//!
//! let scene = Scene::builtin_default();
//! let model = scene.build_model()?;
//! let settings = scene.tool.expect("the default scene has a tool");
//! let ToolSource::Haptics { device_origin: top, .. } = settings.source else { unreachable!() };
//! let (mut sim, mut tool) =
//!     HandTool::simulation::<f32>(&model, scene.solver.clone(), scene.effects.clone(), settings)?;
//! for k in 1..=100 {
//!     // Lower the sphere from touching the skin to 4 mm into it over 0.1 s.
//!     let depth = 0.004 * f64::from(k) / 100.0;
//!     tool.move_to(&mut sim, [top[0], top[1] - depth, top[2]], None);
//!     sim.step();
//! }
//! let pressed = tool.feedback(&sim);
//! assert!(pressed.in_contact && pressed.force[1] > 0.0); // the tissue pushes the tool up
//! assert!(tool.grasp(&mut sim) > 0);
//! for k in 1..=100 {
//!     let lift = 0.002 * f64::from(k) / 100.0;
//!     tool.move_to(&mut sim, [top[0], top[1] - 0.004 + lift, top[2]], None);
//!     sim.step();
//! }
//! assert!(tool.feedback(&sim).force[1] < pressed.force[1]); // less push, or a pull
//! tool.release(&mut sim);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::model::Model;
use crate::real::Real;
use crate::scene::ToolSettings;
use crate::solver::{
    DragHandle, Effects, IntegrationParameters, Simulation, SimulationBuildError, SphereTool, ToolFeedback,
};

/// Most nodes one grasp holds.
pub const MAX_GRASPED: usize = 32;

/// Grasp reach, in tool radii: nodes closer than this to the centre are grasped.
pub const GRASP_REACH: f64 = 1.25;

/// Damping of a grasp spring, N·s/m.
pub const GRASP_DAMPING: f64 = 0.01;

/// Where the tool waits while the simulation is built: far outside any model, m.
const PARKED_AT_M: f64 = 1e3;

/// Nodes held by the tool.
#[derive(Clone, Copy, Debug)]
struct Grasp {
    /// Index of the first grasp handle in the effects' handles (the scene's own come first).
    first_handle: usize,
    count: usize,
    offsets: [[f64; 3]; MAX_GRASPED],
}

/// The tool's state beside a [`Simulation`]: where it is, its radius, what it holds.
#[derive(Clone, Debug)]
pub struct HandTool {
    settings: ToolSettings,
    centre: [f64; 3],
    radius: f64,
    grasp: Option<Grasp>,
    grasps: u64,
}

impl HandTool {
    /// Builds the simulation of `model` with this tool able to appear in it: the critical
    /// step counts the tool's stiffness and the skin's point shell is sampled for
    /// [`ToolSettings::shell_radius`]. The tool starts parked (a scripted tool already in
    /// `effects` stays as it is), and room for a grasp's handles is reserved.
    ///
    /// # Errors
    /// Whatever [`Simulation::new`] refuses.
    pub fn simulation<T: Real>(
        model: &Model,
        params: IntegrationParameters,
        mut effects: Effects,
        settings: ToolSettings,
    ) -> Result<(Simulation<T>, Self), SimulationBuildError> {
        let scripted = effects.tool.is_some();
        if !scripted {
            effects.tool = Some(SphereTool {
                radius: settings.shell_radius(),
                stiffness: settings.stiffness,
                start: [PARKED_AT_M; 3],
                velocity: [0.0; 3],
            });
        }
        let mut sim = Simulation::new(model, params, effects)?;
        if !scripted {
            sim.effects_mut().tool = None;
        }
        sim.effects_mut().handles.reserve(MAX_GRASPED);
        let tool = Self { settings, centre: [PARKED_AT_M; 3], radius: settings.radius, grasp: None, grasps: 0 };
        Ok((sim, tool))
    }

    /// Moves the tool's centre to `centre` (m, model frame) with `radius` (m; `None` keeps
    /// the current one): the sphere when pressing, the grasped nodes' anchors when grasping.
    /// A radius below the smallest the skin's point shell supports is raised to it; returns
    /// whether it was.
    pub fn move_to<T: Real>(&mut self, sim: &mut Simulation<T>, centre: [f64; 3], radius: Option<f64>) -> bool {
        let (radius, raised) = match radius {
            Some(r) => self.settings.commanded_radius(r),
            None => (self.radius, false),
        };
        self.centre = centre;
        self.radius = radius;
        match &self.grasp {
            Some(g) => {
                let handles = &mut sim.effects_mut().handles[g.first_handle..g.first_handle + g.count];
                for (h, off) in handles.iter_mut().zip(&g.offsets) {
                    h.target = [0, 1, 2].map(|c| centre[c] + off[c]);
                }
            }
            None => {
                sim.effects_mut().tool =
                    Some(SphereTool { radius, stiffness: self.settings.stiffness, start: centre, velocity: [0.0; 3] });
            }
        }
        raised
    }

    /// Grasps the free nodes within [`GRASP_REACH`] radii of the centre (at most
    /// [`MAX_GRASPED`], in index order); returns how many. With none in reach nothing
    /// changes; while already grasping it returns the nodes held.
    pub fn grasp<T: Real>(&mut self, sim: &mut Simulation<T>) -> usize {
        if let Some(g) = &self.grasp {
            return g.count;
        }
        let reach2 = (GRASP_REACH * self.radius).powi(2);
        let mut g = Grasp { first_handle: sim.effects().handles.len(), count: 0, offsets: [[0.0; 3]; MAX_GRASPED] };
        for i in 0..sim.state().x.len() {
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
            self.grasps += 1;
        }
        g.count
    }

    /// Lets go of the grasped nodes (nothing when not grasping). The sphere comes back at the
    /// next [`HandTool::move_to`].
    pub fn release<T: Real>(&mut self, sim: &mut Simulation<T>) {
        if let Some(g) = self.grasp.take() {
            sim.effects_mut().handles.truncate(g.first_handle);
        }
    }

    /// Lets go and takes the sphere out of the loop until the next [`HandTool::move_to`].
    pub fn park<T: Real>(&mut self, sim: &mut Simulation<T>) {
        self.release(sim);
        sim.effects_mut().tool = None;
    }

    /// The tissue's force on the tool after the last step and its stiffness with respect to
    /// the tool's position: the sphere's contact, or the grasp springs' reaction (stiffness
    /// `−k` per grasped node on the diagonal); no contact when parked.
    pub fn feedback<T: Real>(&self, sim: &Simulation<T>) -> ToolFeedback {
        match &self.grasp {
            Some(g) => {
                let k = self.settings.stiffness;
                let mut force = [0.0; 3];
                for h in &sim.effects().handles[g.first_handle..g.first_handle + g.count] {
                    let p = sim.state().x.get_f64(h.node as usize);
                    for c in 0..3 {
                        force[c] -= k * (h.target[c] - p[c]);
                    }
                }
                let kn = -k * g.count as f64;
                ToolFeedback {
                    in_contact: true,
                    nodes: g.count as u32,
                    force,
                    stiffness: [[kn, 0.0, 0.0], [0.0, kn, 0.0], [0.0, 0.0, kn]],
                    centre: self.centre,
                }
            }
            None if sim.effects().tool.is_some() => sim.tool_feedback(),
            None => ToolFeedback { centre: self.centre, ..ToolFeedback::default() },
        }
    }

    /// Whether the tool holds nodes.
    pub fn is_grasping(&self) -> bool {
        self.grasp.is_some()
    }

    /// Grasps made so far.
    pub fn grasps(&self) -> u64 {
        self.grasps
    }

    /// Centre, m (model frame), as last moved.
    pub fn centre(&self) -> [f64; 3] {
        self.centre
    }

    /// Radius, m, as last moved.
    pub fn radius(&self) -> f64 {
        self.radius
    }
}
