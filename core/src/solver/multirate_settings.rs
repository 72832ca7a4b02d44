//! Multirate settings: where the tick-rate region is, how much slower the bulk steps, and
//! what the region does when work on the bulk's thread is late.

/// Where the tick-rate region is and how much slower the bulk steps.
///
/// # Examples
///
/// The default limb pressed by its tool, the 5 cm about the tool every 1 ms tick and the whole
/// limb every 8 ms on a second thread:
///
/// ```
/// use lamina_core::scene::{Scene, ToolSource};
/// use lamina_core::solver::{IntegratorKind, LateBuild, MultirateSettings, Simulation, SphereTool};
///
/// let scene = Scene::builtin_default();
/// let model = scene.build_model()?;
/// let tool = scene.tool.expect("the default scene has a tool");
/// let ToolSource::Haptics { device_origin: top, .. } = tool.source else { unreachable!() };
/// let mut params = scene.solver.clone();
/// params.integrator = IntegratorKind::ImplicitFactored;
/// // Work late on the bulk's thread waited for: the same result however fast this machine.
/// let late_build = LateBuild::Wait;
/// params.multirate = Some(MultirateSettings { centre: top, late_build, ..MultirateSettings::default() });
/// let mut effects = scene.effects.clone();
/// effects.tool = Some(SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: top, velocity: [0.0; 3] });
/// let mut sim = Simulation::<f32>::new(&model, params, effects)?;
/// for k in 1..=200 {
///     // 4 mm into the skin over 0.2 s.
///     let depth = 0.004 * f64::from(k) / 200.0;
///     sim.effects_mut().tool.as_mut().unwrap().start = [top[0], top[1] - depth, top[2]];
///     sim.step();
/// }
/// let status = sim.multirate_status().expect("multirate on");
/// assert_eq!(status.bulk_steps, 200 / 8);
/// assert!(status.region_nodes < status.bulk_nodes);
/// assert!(sim.tool_feedback().force[1] > 0.0); // the tissue pushes the tool up
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultirateSettings {
    /// Centre of the region stepped every tick, m, in the model's frame: where the tool works.
    pub centre: [f64; 3],
    /// Radius of that region, m: free nodes within it are stepped every tick. Default 0.05. With
    /// `follow_tool`, a tool wider than three quarters of it gets a region of 4/3 its radius
    /// ([`region_radius`](super::region_radius)), so the tool's contacts lie inside the region
    /// wherever the tool goes before a region about it is built; the region returns to this radius
    /// when the tool shrinks back.
    pub radius: f64,
    /// The bulk takes one step per this many ticks, 2 to [`MAX_MULTIRATE_RATIO`]. Default 8.
    pub ratio: u32,
    /// Whether the region moves with the tool: once the tool's centre is more than a quarter
    /// of `radius` from the region's centre at an exchange, a region about it and the bulk
    /// holding its core are built off the loop's thread and taken `build_exchanges` exchanges
    /// later. Default true.
    pub follow_tool: bool,
    /// Exchanges from asking for a region about the tool to taking it, 2 to
    /// [`MAX_BUILD_EXCHANGES`]: the region and the bulk that holds its core are built in the
    /// meantime on a thread of the lowest priority. Default `None`: with [`LateBuild::Defer`] 2
    /// (taken as soon as it is built), with [`LateBuild::Wait`] three times the first bulk's build
    /// time in exchanges, at least 2
    /// ([`MultirateStatus::build_exchanges`](super::MultirateStatus::build_exchanges)); set it with
    /// `Wait` for runs reproducible from one machine to another.
    pub build_exchanges: Option<u32>,
    /// What happens when a region's build is still under way `build_exchanges` exchanges
    /// after asking. Default [`LateBuild::Defer`].
    pub late_build: LateBuild,
}

/// What the region does when work on the bulk's thread is late: a region about the tool
/// still being built, or the bulk's step not back once it has had its real-time share.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LateBuild {
    /// The loop never waits for either in real time. A region is taken at the first exchange after
    /// it is done (on a machine too loaded to build in time, the region trails the tool further). A
    /// bulk step not back at its exchange once `ratio - 1` ticks of wall-clock time (`(ratio - 1) ·
    /// dt`) have passed since it was sent is taken at the first tick it is back: the region goes on
    /// meanwhile with the ring where the bulk last left it, as it does between exchanges
    /// ([`MultirateStatus::held_ticks`](super::MultirateStatus::held_ticks)). A caller stepping
    /// faster than real time still waits for the bulk. For real-time runs.
    #[default]
    Defer,
    /// Both are waited for (the loop waits with the bulk, counted in
    /// [`MultirateStatus::waits`](super::MultirateStatus::waits)), so a run's result never depends
    /// on the threads' timing. For studies and replays.
    Wait,
}

impl LateBuild {
    /// The scene file's name of it: `defer` or `wait`.
    pub fn name(self) -> &'static str {
        match self {
            LateBuild::Defer => "defer",
            LateBuild::Wait => "wait",
        }
    }
}

/// [`MultirateSettings::build_exchanges`] with [`LateBuild::Defer`] when not given: a region
/// is taken at the first exchange after it is built.
pub(crate) const DEFER_BUILD_EXCHANGES: u32 = 2;

/// Largest [`MultirateSettings::build_exchanges`].
pub const MAX_BUILD_EXCHANGES: u32 = 100_000;

/// Largest [`MultirateSettings::ratio`].
pub const MAX_MULTIRATE_RATIO: u32 = 1000;

impl Default for MultirateSettings {
    fn default() -> Self {
        Self {
            centre: [0.0; 3],
            radius: 0.05,
            ratio: 8,
            follow_tool: true,
            build_exchanges: None,
            late_build: LateBuild::Defer,
        }
    }
}
