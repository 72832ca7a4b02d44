//! Multirate stepping: the region around the tool at the tick rate, the whole model (the
//! bulk) at a fraction of it on a thread of its own, coupled through their overlap.
//!
//! # How a tick goes
//! The model's free nodes are cut by a sphere ([`MultirateSettings`]). The region, the free
//! nodes inside it, is stepped every tick by the calling thread's
//! [`Simulation`](super::Simulation) on a model of its own: the region's nodes and their
//! spring neighbours (the ring, held). The bulk, the whole model, is stepped once per `ratio`
//! ticks with step `ratio · dt` by a second simulation on its own thread. Both use
//! `implicit_factored` (one implicit step, no critical step), so the bulk's long step is as
//! stable as the region's short one; a tick costs the region's step, whatever the model's size.
//!
//! Every `ratio` ticks, at time `T`, the two exchange states through one preallocated packet
//! (lock-free queues, no allocation, no lock):
//! 1. the region takes the bulk's state at `T` for every node outside it (waiting for it if
//!    the bulk thread is late, so the result never depends on timing); the ring holds it
//!    until the next exchange;
//! 2. the bulk takes the region's state at `T` for the region's core (its nodes more than
//!    `OVERLAP_SPRINGS` spring from the edge) and holds it there, as it holds bone, while it
//!    steps the rest to `T + ratio · dt` with the tool where it is at `T` (between core and
//!    ring both halves step the nodes, each its own way); the region ticks on meanwhile.
//!
//! Neither half steps what the other holds: a bulk that stepped the core too, on its long
//! step, oscillated at the region's edge with skin 10^4 times stiffer than fat, centimetres
//! from the single-rate solver. Held, it cannot; a stiff sheet spanning both halves then
//! moves only as fast as the exchanges pass it on, and lags the single-rate solver until it
//! settles (docs/accuracy-and-stability.md).
//!
//! When the tool has moved a quarter of the radius from the region's centre, a region about
//! it and the bulk holding its core (a factorisation of the whole model) are built on a thread
//! of the lowest priority ([`MultirateSettings::follow_tool`]); the caller's thread takes the
//! region at the first exchange [`MultirateSettings::build_exchanges`] after asking where it
//! is built (or waits for it, [`LateBuild::Wait`]), swapping the region's simulation for the
//! new one without allocating, and the bulk's thread its bulk.
//!
//! The bulk feels the tool at its own rate; the tool's force is the region's, every tick. At
//! rest both halves are exact, and a held press reaches the single-rate equilibrium (the
//! default limb pressed 8 mm at ratio 8: the force within 0.05 %, every node within 0.07 mm,
//! `core/tests/multirate.rs`).
//!
//! Effects changed through [`Simulation::effects_mut`](super::Simulation::effects_mut) reach
//! the region at the next tick; the tool, the loads and the handles (grasps among them) reach
//! the bulk with the next exchange, as the region had them then. State written through
//! [`Simulation::state_mut`](super::Simulation::state_mut) on nodes outside the region is
//! overwritten at the next exchange.

use super::cut_log::CutLog;
use super::dynamics::State;
use super::effects::{DragHandle, Effects, PointLoad, SphereTool};
use super::multirate_settings::{DEFER_BUILD_EXCHANGES, LateBuild, MAX_BUILD_EXCHANGES, MultirateSettings};
use super::vec3s::Vec3s;
use crate::generator::vec3::distance;
use crate::model::{Model, NodeKind};
use crate::real::Real;
use crossbeam::queue::ArrayQueue;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The tool may move this fraction of the region's radius from its centre before a region
/// about it is built.
const RECENTRE_FRACTION: f64 = 0.25;

/// A region that grew for a wide tool is built again at its needed radius once that is
/// less than this fraction of its own (hysteresis against rebuilding for every small change).
const SHRINK_FRACTION: f64 = 0.9;

/// Radius (m) of a region following a tool of radius `tool_radius` (m), at least `radius`:
/// the tool's centre may stray a quarter of the region's radius (`RECENTRE_FRACTION`) from the
/// region's centre, so its contacts, within `tool_radius` of its centre, stay inside a
/// region of radius `tool_radius / (1 - RECENTRE_FRACTION)` or more.
///
/// ```
/// use lamina_core::solver::region_radius;
/// assert_eq!(region_radius(0.025, 0.012), 0.025); // the 12 mm tool fits
/// assert!((region_radius(0.025, 0.03) - 0.04).abs() < 1e-12); // a 3 cm tool: 4 cm
/// ```
pub fn region_radius(radius: f64, tool_radius: f64) -> f64 {
    radius.max(tool_radius / (1.0 - RECENTRE_FRACTION))
}

/// Springs between the region's edge and its core: the nodes between are stepped by both
/// halves, and the bulk keeps its own values there. Without this overlap, exchanging states
/// right at the edge is unstable once the skin's springs reach their stiff phase (the
/// default limb pressed 3 mm diverges within 50 ms at ratio 2); with it, the press follows
/// the single-rate solver to 5e-5 m.
const OVERLAP_SPRINGS: usize = 1;

/// The model's free nodes split by the region's sphere, and the region's own model.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Partition {
    /// Free nodes inside the sphere (the region), ascending.
    pub inner: Vec<u32>,
    /// Region nodes a few springs from its edge, ascending: what the bulk takes from the
    /// region (the overlap between them is the bulk's own in its step).
    pub core: Vec<u32>,
    /// The region's other nodes (within `OVERLAP_SPRINGS` of its edge), ascending: both
    /// halves step them, each its own way; how far apart they put them is the coupling gap.
    pub overlap: Vec<u32>,
    /// Free nodes outside it (the bulk's), ascending.
    pub outer: Vec<u32>,
    /// The region's nodes and their spring neighbours (the ring, held in the region's model),
    /// ascending: the region's model's nodes, in order.
    pub kept: Vec<u32>,
    /// Per model node, its index in the region's model (`u32::MAX` when not kept).
    pub local_of: Vec<u32>,
}

impl Partition {
    /// Per model spring, its index among the region's model's springs (`u32::MAX` when the
    /// region does not hold it): [`Partition::region_model`] keeps, in file order, the springs
    /// with both nodes kept.
    pub fn region_springs(&self, model: &Model) -> Vec<u32> {
        let s = &model.springs;
        let mut next = 0u32;
        (0..s.len())
            .map(|k| {
                let kept = |i: u32| self.local_of[i as usize] != u32::MAX;
                if kept(s.a[k]) && kept(s.b[k]) {
                    next += 1;
                    next - 1
                } else {
                    u32::MAX
                }
            })
            .collect()
    }

    /// Splits `model`'s free nodes by `settings`' sphere.
    pub fn of(model: &Model, settings: &MultirateSettings) -> Self {
        let n = model.nodes.len();
        let mut in_region = vec![false; n];
        let (mut inner, mut outer) = (Vec::new(), Vec::new());
        for (i, (p, kind)) in model.nodes.position.iter().zip(&model.nodes.kind).enumerate() {
            if *kind != NodeKind::Free {
                continue;
            }
            let d2: f64 = (0..3).map(|k| (p[k] - settings.centre[k]).powi(2)).sum();
            if d2 <= settings.radius * settings.radius {
                in_region[i] = true;
                inner.push(i as u32);
            } else {
                outer.push(i as u32);
            }
        }
        let keep = spread_along_springs(model, in_region.clone(), 1);
        let kept: Vec<u32> = (0..n as u32).filter(|&i| keep[i as usize]).collect();
        // The core: region nodes more than OVERLAP_SPRINGS springs from any node outside it.
        let outside = in_region.iter().map(|r| !r).collect();
        let near_edge = spread_along_springs(model, outside, OVERLAP_SPRINGS);
        let (overlap, core) = inner.iter().partition(|&&i| near_edge[i as usize]);
        let mut local_of = vec![u32::MAX; n];
        for (l, &i) in kept.iter().enumerate() {
            local_of[i as usize] = l as u32;
        }
        Self { inner, core, overlap, outer, kept, local_of }
    }

    /// The region's model: the kept nodes (the ring fixed to bone), the springs and surface
    /// triangles among them, every layer. No cells and no surface grids (the region is
    /// neither exported nor drawn).
    pub fn region_model(&self, model: &Model) -> Model {
        let local = |i: u32| self.local_of[i as usize];
        let pick = |i: &u32| *i as usize;
        let nodes = &model.nodes;
        let mut out = Model {
            name: format!("{} (multirate region)", model.name),
            layers: model.layers.clone(),
            provenance: model.provenance.clone(),
            ..Model::default()
        };
        out.nodes.position = self.kept.iter().map(|i| nodes.position[pick(i)]).collect();
        out.nodes.mass = self.kept.iter().map(|i| nodes.mass[pick(i)]).collect();
        out.nodes.layer = self.kept.iter().map(|i| nodes.layer[pick(i)]).collect();
        out.nodes.texcoord = self.kept.iter().map(|i| nodes.texcoord[pick(i)]).collect();
        out.nodes.kind = self
            .kept
            .iter()
            .map(|i| {
                if self.inner.binary_search(i).is_ok() {
                    NodeKind::Free
                } else {
                    match nodes.kind[pick(i)] {
                        NodeKind::Free => NodeKind::Fixed,
                        held => held,
                    }
                }
            })
            .collect();
        let s = &model.springs;
        for k in 0..s.len() {
            let (a, b) = (local(s.a[k]), local(s.b[k]));
            if a != u32::MAX && b != u32::MAX {
                out.springs.a.push(a);
                out.springs.b.push(b);
                out.springs.rest_length.push(s.rest_length[k]);
                out.springs.law.push(s.law[k]);
                out.springs.damping.push(s.damping[k]);
                out.springs.layer.push(s.layer[k]);
            }
        }
        out.surfaces = model
            .surfaces
            .iter()
            .map(|surface| crate::model::Surface {
                name: surface.name.clone(),
                triangles: surface
                    .triangles
                    .iter()
                    .filter_map(|t| {
                        let l = t.map(local);
                        (!l.contains(&u32::MAX)).then_some(l)
                    })
                    .collect(),
                grid: None,
            })
            .collect();
        out
    }
}

impl Partition {
    /// The bulk's model: the whole model with the region's core held (as bone is), its
    /// positions and velocities set from the region's at every exchange. Holding the core
    /// keeps the bulk from stepping, on its long step, the nodes the region steps on its
    /// short one: with skin 10^4 times stiffer than fat, a bulk stepping them too oscillates
    /// at the region's edge and drifts centimetres from the single-rate solver.
    pub fn bulk_model(&self, model: &Model) -> Model {
        let mut bulk = model.clone();
        for &i in &self.core {
            bulk.nodes.kind[i as usize] = NodeKind::Fixed;
        }
        bulk.name = format!("{} (multirate bulk)", model.name);
        bulk
    }
}

/// `marked` grown `springs` times along the model's springs: a node joins when a spring links
/// it to a marked node.
fn spread_along_springs(model: &Model, mut marked: Vec<bool>, springs: usize) -> Vec<bool> {
    for _ in 0..springs {
        let mut next = marked.clone();
        for (&a, &b) in model.springs.a.iter().zip(&model.springs.b) {
            let (a, b) = (a as usize, b as usize);
            if marked[a] || marked[b] {
                next[a] = true;
                next[b] = true;
            }
        }
        marked = next;
    }
    marked
}

impl Partition {
    /// Refuses a partition the coupling cannot run: a region with no free node or with all of
    /// them, or one whose nodes are all within a spring of its edge (no core).
    pub fn check(&self, settings: &MultirateSettings) -> Result<(), String> {
        let (inner, outer) = (self.inner.len(), self.outer.len());
        if inner == 0 || outer == 0 {
            return Err(format!(
                "the sphere of radius {} m about {:?} m holds {inner} of the model's {} free nodes: it must hold some, not all",
                settings.radius,
                settings.centre,
                inner + outer
            ));
        }
        if self.core.is_empty() {
            return Err(format!(
                "the sphere of radius {} m about {:?} m holds {inner} free nodes, none of them more than a spring from its edge: enlarge the radius",
                settings.radius, settings.centre
            ));
        }
        Ok(())
    }
}

/// A partition with the index maps the exchange uses.
pub(crate) struct Layout {
    /// The region's sphere.
    sphere: Sphere,
    pub(crate) partition: Partition,
    /// The region's nodes, indices in the region's model (in [`Partition::inner`] order).
    inner_local: Vec<u32>,
    /// The region's core (what the bulk takes), indices in the region's model.
    core_local: Vec<u32>,
    /// The overlap ([`Partition::overlap`]), indices in the region's model.
    overlap_local: Vec<u32>,
    /// The ring (held in the region's model, stepped by the bulk): indices in the region's
    /// model and in the model.
    ring_local: Vec<u32>,
    ring_model: Vec<u32>,
    /// Per model spring, its index in the region's model (`u32::MAX` when not there).
    spring_local: Vec<u32>,
    /// The cuts (the first ones of the [`CutLog`]) the region's simulation was built with,
    /// its factor among them.
    cuts_built: usize,
}

impl Layout {
    fn new(partition: Partition, sphere: Sphere, spring_local: Vec<u32>, cuts_built: usize) -> Self {
        let local = |nodes: &[u32]| nodes.iter().map(|&i| partition.local_of[i as usize]).collect();
        let (inner_local, core_local) = (local(&partition.inner), local(&partition.core));
        let overlap_local = local(&partition.overlap);
        let (ring_local, ring_model) = partition
            .outer
            .iter()
            .filter(|&&i| partition.local_of[i as usize] != u32::MAX)
            .map(|&i| (partition.local_of[i as usize], i))
            .unzip();
        Self {
            sphere,
            partition,
            inner_local,
            core_local,
            overlap_local,
            ring_local,
            ring_model,
            spring_local,
            cuts_built,
        }
    }

    /// `effects` (model node indices) in the region's node indices, into `into`: loads and
    /// handles on nodes outside the region are dropped (those nodes are the bulk's).
    /// Allocates nothing unless `effects`' lists outgrew `into`'s capacity.
    fn map_effects(&self, effects: &Effects, into: &mut Effects) {
        into.gravity = effects.gravity;
        into.viscous_damping = effects.viscous_damping;
        into.guard = effects.guard;
        into.tool = effects.tool;
        into.skin_volume = effects.skin_volume;
        let local = |node: u32| self.region_index(node as usize).map(|l| l as u32);
        into.loads.clear();
        into.loads.reserve(effects.loads.capacity());
        into.loads.extend(effects.loads.iter().filter_map(|l| Some(PointLoad { node: local(l.node)?, ..*l })));
        into.handles.clear();
        into.handles.reserve(effects.handles.capacity());
        into.handles.extend(effects.handles.iter().filter_map(|h| Some(DragHandle { node: local(h.node)?, ..*h })));
    }

    /// Model spring `spring`'s index in the region's model, when the region holds it.
    fn region_spring(&self, spring: usize) -> Option<usize> {
        self.spring_local.get(spring).filter(|&&l| l != u32::MAX).map(|&l| l as usize)
    }

    fn region_index(&self, i: usize) -> Option<usize> {
        self.partition.local_of.get(i).filter(|&&l| l != u32::MAX).map(|&l| l as usize)
    }
}

/// Builds regions about the tool, and the bulks that hold their cores, on a thread of low
/// priority, for a region that follows it.
pub(crate) struct RegionBuilder {
    /// The whole model (its own copy, for the builder's thread).
    model: Model,
    /// The region's solver settings: the caller's on one thread, without multirate.
    params: super::IntegrationParameters,
    /// The bulk's solver settings: the region's step times the ratio.
    bulk_params: super::IntegrationParameters,
    /// The effects the simulation was built with, model node indices.
    effects: Effects,
    /// The coupling's settings, `build_exchanges` set (how long a build has, and whether a
    /// late one is waited for).
    settings: MultirateSettings,
    /// The first region's and the first bulk's stiffest-mode estimates, reused by those built
    /// after them (the same tissue; `implicit_factored` has no critical step).
    known_stability: super::critical_step::StabilityEstimate,
    known_bulk_stability: super::critical_step::StabilityEstimate,
    /// The springs cut so far, which regions and bulks built here are built without.
    log: Arc<CutLog>,
}

/// A region built about a new centre, on its way to the loop's thread; on its way back, the
/// region it replaced, to be dropped off the loop's thread.
pub(crate) struct Relocation<T: Real> {
    pub(crate) layout: Layout,
    pub(crate) region: super::Simulation<T>,
}

/// A region about a new centre and the bulk that holds its core: the region goes to the
/// loop's thread, the bulk stays on the bulk's until the region is taken.
pub(crate) struct Built<T: Real> {
    relocation: Relocation<T>,
    bulk: super::Simulation<T>,
    /// The cuts (the first ones of the log) both were built with.
    cuts: usize,
}

impl RegionBuilder {
    /// A builder with its own copy of `model`; `first` and `first_bulk` are the region and
    /// the bulk built at start.
    pub fn new<T: Real>(
        model: &Model,
        params: super::IntegrationParameters,
        bulk_params: super::IntegrationParameters,
        effects: Effects,
        settings: MultirateSettings,
        (first, first_bulk): (&super::Simulation<T>, &super::Simulation<T>),
    ) -> Self {
        Self {
            model: model.clone(),
            params,
            bulk_params,
            effects,
            settings,
            known_stability: first.stability(),
            known_bulk_stability: first_bulk.stability(),
            // The coupling's own, given at its start.
            log: Arc::new(CutLog::with_capacity(0)),
        }
    }

    /// The region `sphere` asks for and its simulation at rest, its loads and handles lists
    /// holding at least `capacity` (loads, handles) entries, and the bulk holding its core;
    /// both without the first `cuts` springs of the log, factored so.
    pub fn build<T: Real>(
        &self,
        sphere: Sphere,
        capacity: (usize, usize),
        cuts: usize,
    ) -> Result<Built<T>, super::SimulationBuildError> {
        let settings = MultirateSettings { centre: sphere.centre, radius: sphere.radius, ..self.settings };
        let cut: Vec<usize> = self.log.springs(0, cuts).collect();
        let known = Some(self.known_stability);
        let relocation = build_region(&self.model, &self.params, &self.effects, &settings, capacity, known, &cut)?;
        let bulk = build_bulk(
            &self.model,
            &relocation.layout.partition,
            &self.bulk_params,
            &self.effects,
            capacity,
            Some(self.known_bulk_stability),
            &cut,
        )?;
        Ok(Built { relocation, bulk, cuts })
    }
}

/// The region of `model` about `settings.centre` and its simulation at rest (`params`, the
/// region's; `effects` in model node indices), its loads and handles lists holding at least
/// `capacity` (loads, handles) entries; `known` skips the stiffest-mode estimate. The model
/// springs `cut` are cut in it and its factor is the cut model's.
pub(crate) fn build_region<T: Real>(
    model: &Model,
    params: &super::IntegrationParameters,
    effects: &Effects,
    settings: &MultirateSettings,
    capacity: (usize, usize),
    known: Option<super::critical_step::StabilityEstimate>,
    cut: &[usize],
) -> Result<Relocation<T>, super::SimulationBuildError> {
    let partition = Partition::of(model, settings);
    partition.check(settings).map_err(super::SimulationBuildError::Multirate)?;
    let region_model = partition.region_model(model);
    let spring_local = partition.region_springs(model);
    let layout =
        Layout::new(partition, Sphere { centre: settings.centre, radius: settings.radius }, spring_local, cut.len());
    let mut region_effects = effects_with_room(effects, capacity);
    layout.map_effects(effects, &mut region_effects);
    let mut region = super::Simulation::new_single_rate_with(&region_model, params.clone(), region_effects, known)?;
    let local_cut: Vec<usize> = cut.iter().filter_map(|&s| layout.region_spring(s)).collect();
    region.cut_and_refactor(&region_model, &local_cut)?;
    Ok(Relocation { layout, region })
}

/// The bulk's simulation of `model` at rest with `partition`'s core held
/// ([`Partition::bulk_model`]); `params` the bulk's, its loads and handles lists holding at
/// least `capacity` (loads, handles) entries (each exchange copies the caller's into them);
/// `known` skips the stiffest-mode estimate. The model springs `cut` are cut in it and its
/// factor is the cut model's.
pub(crate) fn build_bulk<T: Real>(
    model: &Model,
    partition: &Partition,
    params: &super::IntegrationParameters,
    effects: &Effects,
    capacity: (usize, usize),
    known: Option<super::critical_step::StabilityEstimate>,
    cut: &[usize],
) -> Result<super::Simulation<T>, super::SimulationBuildError> {
    let bulk_effects = effects_with_room(effects, capacity);
    let bulk_model = partition.bulk_model(model);
    let mut bulk = super::Simulation::new_single_rate_with(&bulk_model, params.clone(), bulk_effects, known)?;
    bulk.cut_and_refactor(&bulk_model, cut)?;
    Ok(bulk)
}

/// A copy of `effects` whose loads and handles lists have room for `capacity` (loads,
/// handles) entries more, so copying a caller's lists into them later allocates nothing.
fn effects_with_room(effects: &Effects, capacity: (usize, usize)) -> Effects {
    let mut copy = effects.clone();
    copy.loads.reserve(capacity.0);
    copy.handles.reserve(capacity.1);
    copy
}

/// The first frame epoch of the next multirate simulation built in this process; each takes
/// 2^32 epochs.
static FRAME_EPOCHS: AtomicU64 = AtomicU64::new(0);

/// Which nodes of a multirate simulation's state move from one tick to the next
/// ([`Simulation::frame_changes`](super::Simulation::frame_changes)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameChanges<'a> {
    /// Changes whenever nodes outside `nodes` move (an exchange with the bulk, a region
    /// taken, a write through `state_mut`): between two ticks of the same epoch, only
    /// `nodes` differ.
    pub epoch: u64,
    /// The region's nodes, model indices.
    pub nodes: &'a [u32],
}

/// Where a region is asked for: its sphere's centre and radius, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Sphere {
    pub centre: [f64; 3],
    pub radius: f64,
}

/// The state passed between the region and the bulk: one packet, owned by one side at a time.
struct Packet<T: Real> {
    /// Time of the region's state, s.
    region_time: f64,
    /// The region's core positions (m) and velocities (m/s), in [`Partition::core`] order
    /// (sized for every free node: a region that moves changes the count).
    core_x: Vec3s<T>,
    core_v: Vec3s<T>,
    /// Bulk to region: the bulk's whole state, positions (m) and velocities (m/s) of every
    /// model node, taken in place of the whole state's by swapping (the region's nodes then
    /// set again from the region). Region to bulk: the whole state it replaced, overwritten.
    x: Vec3s<T>,
    v: Vec3s<T>,
    /// The tool as the region had it at `region_time` (at rest there), for the bulk's step.
    tool: Option<SphereTool>,
    /// Region to bulk: the cuts made by `region_time` (the first ones of the log), for the
    /// bulk to cut before its step and for a region asked for here to be built without.
    cuts: usize,
    /// The caller's loads and handles at `region_time` (model node indices), for the bulk's
    /// step; their capacities, at least the caller's, size the lists of a region built here.
    loads: Vec<PointLoad>,
    handles: Vec<DragHandle>,
    /// Compute time of the bulk's step that filled `x` and `v`, ns.
    step_ns: u64,
    /// Time the builder's thread took to build `relocation` and its bulk, ns (0 without one).
    build_ns: u64,
    /// Whether the bulk's state is finite (the bulk's guard, when on, keeps it so).
    finite: bool,
    /// Region to bulk: build this region (after returning this packet; the region comes
    /// back with the next one).
    recentre: Option<Sphere>,
    /// Bulk to region: the region asked for with the packet before could not be built.
    recentre_refused: bool,
    /// Region to bulk: the region took the relocation this packet brought, so from this
    /// packet on the core and outer lists are the relocation's.
    adopted: bool,
    /// Bulk to region: the region asked for with the packet before. Region to bulk: the
    /// region it replaced, dropped on the bulk's thread.
    relocation: Option<Box<Relocation<T>>>,
}

/// What the bulk thread has done, for `lamina run`'s report.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MultirateStatus {
    /// Nodes stepped every tick.
    pub region_nodes: usize,
    /// Nodes stepped by the bulk.
    pub bulk_nodes: usize,
    /// Ticks per bulk step.
    pub ratio: u32,
    /// Centre of the region now, m.
    pub centre: [f64; 3],
    /// Radius of the region now, m: [`MultirateSettings::radius`], or more about a wide tool
    /// ([`region_radius`]).
    pub radius: f64,
    /// Bulk steps taken.
    pub bulk_steps: u64,
    /// Longest bulk step, ns.
    pub bulk_step_max_ns: u64,
    /// All bulk steps returned so far, ns.
    pub bulk_step_total_ns: u64,
    /// Exchanges at which the region waited for the bulk (its step took longer than
    /// `ratio` ticks of the caller's time).
    pub waits: u64,
    /// Longest such wait, ns.
    pub wait_max_ns: u64,
    /// Ticks the region went on past a due exchange because the bulk's step was late in real
    /// time ([`LateBuild::Defer`]), the ring held where the bulk last left it.
    pub held_ticks: u64,
    /// Longest run of such ticks before the late step was taken.
    pub held_max_ticks: u64,
    /// Bulk states refused for a non-finite value (the region kept the last good one).
    pub refused: u64,
    /// Times the region moved to follow the tool.
    pub recentres: u64,
    /// Regions about the tool that could not be built (the tool off the tissue, say): the
    /// region stayed where it was.
    pub recentres_refused: u64,
    /// Longest time the builder's thread took to build a region about the tool and the bulk
    /// holding its core, ns (at the lowest priority: a build longer than
    /// [`build_exchanges`](Self::build_exchanges) exchanges is waited for).
    pub recentre_build_max_ns: u64,
    /// The bulk thread has ended (only a panic in its step ends it early): the region goes
    /// on alone with the ring held where the bulk last left it.
    pub bulk_stopped: bool,
    /// At the last exchange, the largest distance between where the bulk and where the
    /// region put a node both step (the overlap, near the region's edge), m. Hundredths of a
    /// millimetre at rest, up to about 2 mm with the tool sliding at a large ratio, 3 mm and
    /// more where the coupling oscillates, and 12-15 mm where the bulk's own copy of the
    /// overlap lags a deep press on the 160x40 limb while the region's stays within 0.3 mm of
    /// single-rate (docs/accuracy-and-stability.md).
    pub coupling_gap_m: f64,
    /// The largest [`coupling_gap_m`](Self::coupling_gap_m) so far, m.
    pub coupling_gap_max_m: f64,
    /// Exchanges from asking for a region about the tool to taking it
    /// ([`MultirateSettings::build_exchanges`], or the one chosen from the first bulk's build
    /// time).
    pub build_exchanges: u32,
    /// Springs cut so far ([`Simulation::cut_spring`](super::Simulation::cut_spring)).
    pub cuts: usize,
    /// Of those, the cuts the region's factor was built with: a region and a bulk are built
    /// again about the tool after a cut, off the loop, like a region that follows the tool.
    pub cuts_in_factor: usize,
}

/// The region's side of the coupling: the partition, the whole model's state, the bulk's
/// last state, the bulk thread.
pub(crate) struct Multirate<T: Real> {
    /// Ticks since the last exchange.
    phase: u32,
    /// With [`LateBuild::Defer`]: how long a bulk step may take in wall-clock time before
    /// the region goes on without it, `(ratio - 1) · dt`. `None`: always waited for.
    late_after: Option<Duration>,
    /// When the packet with the bulk was sent.
    sent_at: Instant,
    /// Ticks held so far past the due exchange.
    held: u64,
    layout: Layout,
    /// Per model node, whether it moves.
    free: Vec<bool>,
    /// The smallest region radius (m, [`MultirateSettings::radius`]) and whether the region
    /// follows the tool.
    radius: f64,
    follow_tool: bool,
    /// The region asked of the bulk and not yet answered.
    requested: Option<Sphere>,
    /// The last region refused: asked again only once the tool has moved on from there or
    /// needs another radius.
    refused_at: Option<Sphere>,
    /// The whole model's state: the region's nodes as of the last tick, the others as the
    /// bulk left them at the last exchange, held nodes as built.
    pub(crate) full: State<T>,
    /// Counts the times nodes of `full` outside the region's moved (exchanges, a new region,
    /// the caller's writes): within one epoch only the region's nodes change.
    pub(crate) frame_epoch: u64,
    /// The whole model's rest positions, m.
    pub(crate) full_rest: Vec3s<T>,
    /// The effects as the caller sees them (model node indices).
    pub(crate) effects: Effects,
    /// The packet, while the region holds it.
    packet: Option<Box<Packet<T>>>,
    to_bulk: Arc<ArrayQueue<Box<Packet<T>>>>,
    to_region: Arc<ArrayQueue<Box<Packet<T>>>>,
    quit: Arc<AtomicBool>,
    bulk_thread: Option<JoinHandle<()>>,
    status: MultirateStatus,
    /// The springs cut, shared with the bulk's and the builder's threads.
    log: Arc<CutLog>,
    /// Per model spring: its nodes, and whether it is cut.
    spring_ends: Vec<[u32; 2]>,
    cut: Vec<bool>,
    /// Where the region follows when no sphere tool is on (a scalpel's tip), m.
    focus: Option<[f64; 3]>,
}

fn gather<T: Real>(from: &Vec3s<T>, nodes: &[u32], into: &mut Vec3s<T>) {
    for (dst, src) in into.slices_mut().into_iter().zip(from.slices()) {
        for (d, &i) in dst.iter_mut().zip(nodes) {
            *d = src[i as usize];
        }
    }
}

/// `into` set to `from`, its capacity at least `from`'s: allocates only when `from` has
/// outgrown it (a caller reserving room for more, once).
fn copy_list<E: Copy>(from: &Vec<E>, into: &mut Vec<E>) {
    into.clear();
    into.reserve(from.capacity());
    into.extend_from_slice(from);
}

/// `into[nodes[k]] = from[k]` for every `k`, per axis.
fn scatter<T: Real>(from: &Vec3s<T>, nodes: &[u32], into: &mut Vec3s<T>) {
    for (dst, src) in into.slices_mut().into_iter().zip(from.slices()) {
        for (&i, &s) in nodes.iter().zip(src) {
            dst[i as usize] = s;
        }
    }
}

/// `to[to_nodes[k]] = from[from_nodes[k]]` for every `k`, per axis.
fn copy_nodes<T: Real>(from: &Vec3s<T>, from_nodes: &[u32], to: &mut Vec3s<T>, to_nodes: &[u32]) {
    for (dst, src) in to.slices_mut().into_iter().zip(from.slices()) {
        for (&t, &f) in to_nodes.iter().zip(from_nodes) {
            dst[t as usize] = src[f as usize];
        }
    }
}

impl<T: Real> Multirate<T> {
    /// Starts the bulk thread on `bulk` (a simulation of the whole model stepping
    /// `ratio · dt`, at rest like `model`). With `cpu`, the bulk thread is pinned to it. With
    /// `builder`, the region follows the tool, rebuilt on the bulk thread. `effects` are the
    /// caller's, in model node indices.
    pub fn start(
        model: &Model,
        bulk: super::Simulation<T>,
        layout: Layout,
        builder: Option<RegionBuilder>,
        settings: &MultirateSettings,
        effects: Effects,
        cpu: Option<core_affinity::CoreId>,
    ) -> std::io::Result<Self> {
        // The springs cut, shared with the bulk's thread and the builder.
        let log = Arc::new(CutLog::with_capacity(model.springs.len()));
        let builder = builder.map(|b| RegionBuilder { log: Arc::clone(&log), ..b });
        let build_exchanges = settings.build_exchanges.unwrap_or(DEFER_BUILD_EXCHANGES);
        // The bulk steps ratio · dt: one tick less is its real-time share, whatever the
        // jitter of the tick that sent it.
        let tick = bulk.params().dt / f64::from(settings.ratio);
        let late_after = (settings.late_build == LateBuild::Defer)
            .then(|| Duration::from_secs_f64(tick * f64::from(settings.ratio.saturating_sub(1))));
        let full = State { x: Vec3s::from_f64(&model.nodes.position), v: Vec3s::zeros(model.nodes.len()), time: 0.0 };
        let free: Vec<bool> = model.nodes.kind.iter().map(|k| *k == NodeKind::Free).collect();
        let free_count = free.iter().filter(|&&f| f).count();
        let packet = Box::new(Packet {
            region_time: 0.0,
            core_x: Vec3s::zeros(free_count),
            core_v: Vec3s::zeros(free_count),
            x: full.x.clone(),
            v: full.v.clone(),
            tool: None,
            cuts: 0,
            loads: effects.loads.clone(),
            handles: effects.handles.clone(),
            step_ns: 0,
            build_ns: 0,
            finite: true,
            recentre: None,
            recentre_refused: false,
            adopted: false,
            relocation: None,
        });
        let to_bulk = Arc::new(ArrayQueue::new(1));
        let to_region = Arc::new(ArrayQueue::new(1));
        let quit = Arc::new(AtomicBool::new(false));
        let thread = {
            let (to_bulk, to_region, quit) = (Arc::clone(&to_bulk), Arc::clone(&to_region), Arc::clone(&quit));
            let lists = BulkLists::of(&layout.partition);
            let log = Arc::clone(&log);
            std::thread::Builder::new().name("lamina-bulk".into()).spawn(move || {
                if let Some(cpu) = cpu {
                    core_affinity::set_for_current(cpu);
                }
                bulk_loop(bulk, lists, builder.map(Arc::new), &log, &to_bulk, &to_region, &quit);
            })?
        };
        let status = MultirateStatus {
            region_nodes: layout.partition.inner.len(),
            bulk_nodes: layout.partition.outer.len(),
            ratio: settings.ratio,
            centre: layout.sphere.centre,
            radius: layout.sphere.radius,
            build_exchanges,
            ..MultirateStatus::default()
        };
        Ok(Self {
            phase: 0,
            late_after,
            sent_at: Instant::now(),
            held: 0,
            layout,
            free,
            radius: settings.radius,
            follow_tool: settings.follow_tool,
            requested: None,
            refused_at: None,
            full_rest: full.x.clone(),
            full,
            // Apart from every other multirate simulation's in this process, so a publisher
            // that outlives one never takes another's epoch for its own.
            frame_epoch: FRAME_EPOCHS.fetch_add(1 << 32, Ordering::Relaxed),
            effects,
            packet: Some(packet),
            to_bulk,
            to_region,
            quit,
            bulk_thread: Some(thread),
            status,
            log,
            spring_ends: model.springs.a.iter().zip(&model.springs.b).map(|(&a, &b)| [a, b]).collect(),
            cut: vec![false; model.springs.len()],
            focus: None,
        })
    }

    /// Records the cut of model spring `spring` for the bulk and the regions built later;
    /// returns its index in the region's model when the region holds it (`Some(None)`: the
    /// bulk's alone), `None` when it cannot be cut (out of range, cut before, or between two
    /// nodes that never move). Allocates nothing.
    pub fn record_cut(&mut self, spring: usize) -> Option<Option<usize>> {
        let [a, b] = *self.spring_ends.get(spring)?;
        if self.cut[spring] || !(self.node_is_free(a as usize) || self.node_is_free(b as usize)) {
            return None;
        }
        if !self.log.push(spring as u32) {
            return None;
        }
        self.cut[spring] = true;
        self.status.cuts += 1;
        Some(self.layout.region_spring(spring))
    }

    /// The region's springs (its model's indices) cut after the region's simulation was
    /// built: a region taken at an exchange cuts them before its first tick.
    pub fn cuts_since_build(&self) -> impl Iterator<Item = usize> + '_ {
        let l = &self.layout;
        self.log.springs(l.cuts_built, self.log.len()).filter_map(|s| l.region_spring(s))
    }

    /// Where the region follows when no sphere tool is on, m (`None`: it stays).
    pub fn set_focus(&mut self, focus: Option<[f64; 3]>) {
        self.focus = focus;
    }

    /// The caller's effects in the region's node indices (loads and handles on nodes outside
    /// the region are dropped: those nodes are the bulk's). Allocates nothing unless the
    /// caller's lists outgrew their capacity.
    pub fn region_effects(&self, into: &mut Effects) {
        self.layout.map_effects(&self.effects, into);
    }

    /// Before a tick of the region from `region` (the region's model's state): takes the
    /// region's nodes from the whole state (where the caller may have set them). Allocates
    /// nothing.
    pub fn take_region_nodes(&self, region: &mut State<T>) {
        let l = &self.layout;
        copy_nodes(&self.full.x, &l.partition.inner, &mut region.x, &l.inner_local);
        copy_nodes(&self.full.v, &l.partition.inner, &mut region.v, &l.inner_local);
    }

    /// Whether this tick begins with an exchange ([`receive`](Self::receive), then
    /// [`send`](Self::send)): every `ratio` ticks, or at the first tick after that the bulk's
    /// step is back when it was late in real time ([`LateBuild::Defer`]). Allocates nothing.
    pub fn exchange_due(&mut self) -> bool {
        if self.phase != 0 {
            return false;
        }
        let Some(late_after) = self.late_after else { return true };
        if self.packet.is_none() {
            self.packet = self.to_region.pop();
        }
        let stopped = || self.bulk_thread.as_ref().is_none_or(JoinHandle::is_finished);
        if self.packet.is_some() || self.sent_at.elapsed() < late_after || stopped() {
            self.held = 0;
            return true;
        }
        self.held += 1;
        self.status.held_ticks += 1;
        self.status.held_max_ticks = self.status.held_max_ticks.max(self.held);
        false
    }

    /// Counts the tick; every `ratio` ticks an exchange is due (held at due while the bulk's
    /// step is late).
    pub fn end_tick(&mut self) {
        if self.held == 0 {
            self.phase = (self.phase + 1) % self.status.ratio;
        }
    }

    /// The first half of an exchange: takes the bulk's state (waiting for it if the bulk is
    /// late) into the whole state and the region's ring. Returns a region built about the
    /// tool when one came back, for the caller to take (the ring is then left to
    /// [`adopt`](Self::adopt)). Allocates nothing.
    pub fn receive(&mut self, region: &mut State<T>) -> Option<Box<Relocation<T>>> {
        // A new epoch for the bulk's nodes, and for a region taken at this exchange
        // (`adopt` is only called after `receive`).
        self.frame_epoch = self.frame_epoch.wrapping_add(1);
        let packet = match self.packet.take() {
            Some(p) => Some(p),
            None => self.wait_for_bulk(),
        };
        let Some(mut packet) = packet else {
            // The bulk thread has ended (it cannot, short of a panic in its step): the region
            // goes on with the ring where the bulk last left it.
            self.status.bulk_stopped = true;
            return None;
        };
        self.status.bulk_step_max_ns = self.status.bulk_step_max_ns.max(packet.step_ns);
        self.status.bulk_step_total_ns += packet.step_ns;
        self.status.recentre_build_max_ns = self.status.recentre_build_max_ns.max(packet.build_ns);
        let l = &self.layout;
        let mut relocation = None;
        if packet.finite {
            // Both halves at the bulk step's end (the region later by the ticks held when the
            // step was late), in the layout the bulk stepped.
            let gap = largest_distance(&region.x, &l.overlap_local, &packet.x, &l.partition.overlap);
            self.status.coupling_gap_m = gap;
            self.status.coupling_gap_max_m = self.status.coupling_gap_max_m.max(gap);
            // The bulk's nodes hold this state until the next exchange (zero-order hold: a
            // ring moved on its velocity between exchanges follows the single-rate solver no
            // better and is less damped). The bulk's whole state is taken by a swap, and the
            // region's nodes (the bulk held its core at the last exchange's values) are set
            // again from the region: the loop copies the region, not the bulk.
            std::mem::swap(&mut self.full.x, &mut packet.x);
            std::mem::swap(&mut self.full.v, &mut packet.v);
            copy_nodes(&region.x, &l.inner_local, &mut self.full.x, &l.partition.inner);
            copy_nodes(&region.v, &l.inner_local, &mut self.full.v, &l.partition.inner);
            relocation = packet.relocation.take();
            if relocation.is_none() {
                copy_nodes(&self.full.x, &l.ring_model, &mut region.x, &l.ring_local);
                copy_nodes(&self.full.v, &l.ring_model, &mut region.v, &l.ring_local);
            }
        } else {
            // A region built from a non-finite bulk goes back to be dropped there.
            self.status.refused += 1;
        }
        if packet.recentre_refused {
            self.status.recentres_refused += 1;
            self.refused_at = self.requested;
        }
        if packet.recentre_refused || relocation.is_some() || packet.relocation.is_some() {
            // The bulk answered the request outstanding.
            self.requested = None;
        }
        self.packet = Some(packet);
        relocation
    }

    /// Takes `relocation`'s layout in place of the region's (the old one goes into
    /// `relocation`) and sets `region`, the new region's state, from the whole state. Called
    /// between [`receive`](Self::receive) and [`send`](Self::send). Allocates nothing.
    pub fn adopt(&mut self, relocation: &mut Relocation<T>, region: &mut State<T>) {
        std::mem::swap(&mut self.layout, &mut relocation.layout);
        gather(&self.full.x, &self.layout.partition.kept, &mut region.x);
        gather(&self.full.v, &self.layout.partition.kept, &mut region.v);
        region.time = self.full.time;
        self.status.region_nodes = self.layout.partition.inner.len();
        self.status.bulk_nodes = self.layout.partition.outer.len();
        self.status.centre = self.layout.sphere.centre;
        self.status.radius = self.layout.sphere.radius;
        self.status.recentres += 1;
        self.status.cuts_in_factor = self.layout.cuts_built;
        self.refused_at = None;
        if let Some(p) = self.packet.as_mut() {
            p.adopted = true;
        }
    }

    /// The second half of an exchange: hands the bulk the region's core and the tool at the
    /// region's time, asks for a region about the tool if it has moved far enough, and
    /// returns `retired` (a region the caller replaced) to be dropped on the bulk's thread.
    /// Allocates nothing.
    pub fn send(&mut self, region: &State<T>, retired: Option<Box<Relocation<T>>>) {
        let Some(mut packet) = self.packet.take() else { return };
        packet.region_time = region.time;
        packet.tool = self.effects.tool.map(|t| SphereTool { start: t.centre(region.time), velocity: [0.0; 3], ..t });
        copy_list(&self.effects.loads, &mut packet.loads);
        copy_list(&self.effects.handles, &mut packet.handles);
        gather(&region.x, &self.layout.core_local, &mut packet.core_x);
        gather(&region.v, &self.layout.core_local, &mut packet.core_v);
        packet.relocation = retired.or(packet.relocation.take());
        packet.recentre = None;
        packet.cuts = self.log.len();
        // Where the region should be: about the sphere tool, else about the focus (a
        // scalpel's tip), else where it is.
        let wanted = match (packet.tool, self.focus) {
            (Some(tool), _) => Sphere { centre: tool.start, radius: region_radius(self.radius, tool.radius) },
            (None, Some(focus)) => Sphere { centre: focus, radius: self.radius },
            (None, None) => self.layout.sphere,
        };
        if self.follow_tool && self.requested.is_none() {
            // Built again when the tool strays from its centre, outgrows it, or has shrunk
            // well inside a region grown for it; and after a cut, for a factor of the cut model.
            let differs = |from: &Sphere| {
                distance(wanted.centre, from.centre) > RECENTRE_FRACTION * from.radius
                    || wanted.radius > from.radius
                    || wanted.radius < SHRINK_FRACTION * from.radius
            };
            let moved = differs(&self.layout.sphere) && self.refused_at.as_ref().is_none_or(differs);
            let cut_since = packet.cuts > self.layout.cuts_built && self.refused_at.is_none();
            if moved || cut_since {
                packet.recentre = Some(wanted);
                self.requested = Some(wanted);
            }
        }
        if let Err(p) = self.to_bulk.push(packet) {
            // Unreachable: the queue holds at most the one packet, which was here.
            self.packet = Some(p);
            return;
        }
        self.status.bulk_steps += 1;
        self.sent_at = Instant::now();
        if let Some(t) = &self.bulk_thread {
            t.thread().unpark();
        }
    }

    /// The whole state's epoch and the nodes (model indices) that move within it: the
    /// region's, taken into the whole state after every tick.
    pub fn frame_changes(&self) -> FrameChanges<'_> {
        FrameChanges { epoch: self.frame_epoch, nodes: &self.layout.partition.inner }
    }

    /// After a tick of the region: the whole state takes the region's nodes. Allocates
    /// nothing.
    pub fn after_tick(&mut self, region: &State<T>) {
        let l = &self.layout;
        copy_nodes(&region.x, &l.inner_local, &mut self.full.x, &l.partition.inner);
        copy_nodes(&region.v, &l.inner_local, &mut self.full.v, &l.partition.inner);
        self.full.time = region.time;
    }

    /// The packet back from the bulk, waiting for it; `None` when the bulk thread has ended.
    fn wait_for_bulk(&mut self) -> Option<Box<Packet<T>>> {
        let start = Instant::now();
        let mut spins = 0u32;
        loop {
            if let Some(p) = self.to_region.pop() {
                if spins > 0 {
                    let ns = start.elapsed().as_nanos() as u64;
                    self.status.waits += 1;
                    self.status.wait_max_ns = self.status.wait_max_ns.max(ns);
                }
                return Some(p);
            }
            spins += 1;
            if spins < 1000 {
                std::hint::spin_loop();
            } else if self.bulk_thread.as_ref().is_none_or(JoinHandle::is_finished) {
                return self.to_region.pop();
            } else {
                std::thread::yield_now();
            }
        }
    }

    /// Node `local` of the region's model in the model.
    pub fn model_index(&self, local: u32) -> u32 {
        self.layout.partition.kept.get(local as usize).copied().unwrap_or(local)
    }

    /// Whether model node `i` moves (in the region or the bulk).
    pub fn node_is_free(&self, i: usize) -> bool {
        self.free.get(i).copied().unwrap_or(false)
    }

    /// The coupling's counts so far (a bulk step under way counts as taken).
    pub fn status(&self) -> MultirateStatus {
        self.status
    }
}

impl<T: Real> Drop for Multirate<T> {
    fn drop(&mut self) {
        self.quit.store(true, Ordering::Release);
        if let Some(t) = self.bulk_thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

/// The node list of a region's layout the bulk thread uses (model indices): what it takes
/// from the region ([`Partition::core`]). It returns its whole state.
struct BulkLists {
    core: Vec<u32>,
}

impl BulkLists {
    fn of(p: &Partition) -> Self {
        Self { core: p.core.clone() }
    }
}

/// The largest distance (m) between `a[a_nodes[k]]` and `b[b_nodes[k]]` over `k`; 0 for no
/// node.
fn largest_distance<T: Real>(a: &Vec3s<T>, a_nodes: &[u32], b: &Vec3s<T>, b_nodes: &[u32]) -> f64 {
    let (a, b) = (a.slices(), b.slices());
    let mut largest = 0.0f64;
    for (&i, &j) in a_nodes.iter().zip(b_nodes) {
        let (i, j) = (i as usize, j as usize);
        let d2: f64 = (0..3).map(|c| (a[c][i].to_f64() - b[c][j].to_f64()).powi(2)).sum();
        largest = largest.max(d2);
    }
    largest.sqrt()
}

/// A region and its bulk being built on the builder's thread, which returns them with its
/// build time.
type Building<T> = JoinHandle<(Result<Built<T>, super::SimulationBuildError>, Duration)>;

/// The exchanges to give the builder's thread for a region and its bulk, waited for, when one
/// build of the bulk took `bulk_build`: three times that, in exchanges of `ratio · dt` seconds,
/// at least 2 (the region's own step and the bulk's go on meanwhile on the same CPUs).
pub(crate) fn auto_build_exchanges(bulk_build: Duration, dt: f64, ratio: u32) -> u32 {
    let exchanges = (3.0 * bulk_build.as_secs_f64() / (dt * f64::from(ratio))).ceil();
    exchanges.clamp(2.0, f64::from(MAX_BUILD_EXCHANGES)) as u32
}

/// Starts building the region about `centre` and its bulk on a thread of the lowest priority
/// (`SCHED_IDLE` on Linux: it runs only when the bulk's and the loop's threads leave a CPU
/// idle), so the build never delays a bulk step.
fn start_build<T: Real>(
    builder: &Arc<RegionBuilder>,
    sphere: Sphere,
    capacity: (usize, usize),
    cuts: usize,
) -> Result<Building<T>, super::SimulationBuildError> {
    let builder = Arc::clone(builder);
    let thread = std::thread::Builder::new()
        .name("lamina-region".into())
        .spawn(move || {
            super::idle_priority::lower_this_threads_priority();
            let start = Instant::now();
            let built = builder.build::<T>(sphere, capacity, cuts);
            (built, start.elapsed())
        })
        .map_err(|e| super::SimulationBuildError::Multirate(format!("starting the region builder's thread: {e}")))?;
    Ok(thread)
}

/// A region and its bulk built about the tool, waiting for the region to take them.
struct Pending<T: Real> {
    lists: BulkLists,
    bulk: super::Simulation<T>,
    /// The cuts the bulk was built with.
    cuts: usize,
}

/// The bulk thread: waits for the packet, takes the region's core and the tool into the
/// whole model's state, steps it, returns the bulk's nodes in the packet; has a region about
/// the tool and its bulk built when asked, returned `build_exchanges` exchanges after the
/// asking packet (or, deferred, once done after that), and switches to that bulk when the
/// region takes the region. `lists` are the node lists of the region's layout.
fn bulk_loop<T: Real>(
    mut bulk: super::Simulation<T>,
    mut lists: BulkLists,
    builder: Option<Arc<RegionBuilder>>,
    log: &CutLog,
    to_bulk: &ArrayQueue<Box<Packet<T>>>,
    to_region: &ArrayQueue<Box<Packet<T>>>,
    quit: &AtomicBool,
) {
    // The region built and sent, with its bulk, until the region says it took it.
    let mut pending: Option<Pending<T>> = None;
    // The build under way and the exchange whose packet returns it.
    let mut building: Option<(Building<T>, u64)> = None;
    // Packets taken so far.
    let mut exchange = 0u64;
    // The cuts the bulk has made (the first ones of the log).
    let mut cut = 0usize;
    loop {
        let Some(mut packet) = to_bulk.pop() else {
            if quit.load(Ordering::Acquire) {
                return;
            }
            std::thread::park_timeout(Duration::from_millis(100));
            continue;
        };
        exchange += 1;
        let start = Instant::now();
        // What the loop replaced or refused is dropped after the packet has gone back.
        let retired_region = packet.relocation.take();
        let mut retired_bulk = None;
        if std::mem::take(&mut packet.adopted)
            && let Some(next) = pending.take()
        {
            // The region took the new region: the bulk holding its core goes on from the
            // whole model's state here.
            lists = next.lists;
            cut = next.cuts;
            let old = std::mem::replace(&mut bulk, next.bulk);
            bulk.take_state_of(&old);
            retired_bulk = Some(old);
        }
        // The cuts the region made by the packet's time, before the step from it.
        for spring in log.springs(cut, packet.cuts) {
            bulk.cut_own_spring(spring);
        }
        cut = cut.max(packet.cuts);
        // A region sent and not taken (the bulk's state was refused) is dropped.
        let unadopted = pending.take();
        let core = &lists.core;
        let effects = bulk.effects_mut();
        effects.tool = packet.tool;
        copy_list(&packet.loads, &mut effects.loads);
        copy_list(&packet.handles, &mut effects.handles);
        let state = bulk.state_mut();
        scatter(&packet.core_x, core, &mut state.x);
        scatter(&packet.core_v, core, &mut state.v);
        state.time = packet.region_time;
        bulk.step();
        let state = bulk.state();
        packet.x.copy_from(&state.x);
        packet.v.copy_from(&state.v);
        packet.finite = packet.x.all_finite() && packet.v.all_finite();
        packet.step_ns = start.elapsed().as_nanos() as u64;
        (packet.recentre_refused, packet.build_ns) = (false, 0);
        // Due with this packet: waited for when late if the region is to take it at the same
        // exchange in every run, else returned with the first packet after it is done.
        let wait = builder.as_ref().is_some_and(|b| b.settings.late_build == LateBuild::Wait);
        if building.as_ref().is_some_and(|(thread, due)| *due <= exchange && (wait || thread.is_finished()))
            && let Some((thread, _)) = building.take()
        {
            let (result, took) = thread.join().unwrap_or_else(|_| {
                let why = "the region builder's thread panicked".to_string();
                (Err(super::SimulationBuildError::Multirate(why)), Duration::ZERO)
            });
            packet.build_ns = took.as_nanos() as u64;
            match result {
                Ok(Built { relocation, bulk, cuts }) => {
                    pending = Some(Pending { lists: BulkLists::of(&relocation.layout.partition), bulk, cuts });
                    packet.relocation = Some(Box::new(relocation));
                }
                Err(_) => packet.recentre_refused = true,
            }
        }
        let request = packet.recentre.take();
        // The packet's lists hold at least the caller's capacity (`copy_list`).
        let capacity = (packet.loads.capacity(), packet.handles.capacity());
        if let Some((sphere, builder)) = request.zip(builder.as_ref()) {
            let build_exchanges = builder.settings.build_exchanges.unwrap_or(DEFER_BUILD_EXCHANGES);
            match start_build::<T>(builder, sphere, capacity, packet.cuts) {
                // Asked with packet `exchange`, taken by the region at exchange
                // `exchange + build_exchanges`: returned with packet `exchange + build_exchanges - 1`.
                Ok(started) => building = Some((started, exchange + u64::from(build_exchanges) - 1)),
                // Answered now, as a region that could not be built.
                Err(_) => packet.recentre_refused = true,
            }
        }
        if to_region.push(packet).is_err() || quit.load(Ordering::Acquire) {
            return;
        }
        drop((retired_region, retired_bulk, unadopted));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn region_model_holds_the_ring_and_keeps_every_spring_of_the_region_works() {
        let model = Scene::builtin_default().build_model().unwrap();
        let settings = MultirateSettings { centre: [0.0, 0.062, 0.12], ..MultirateSettings::default() };
        let p = Partition::of(&model, &settings);
        let region = p.region_model(&model);
        region.validate().unwrap();
        let inner = |i: u32| p.inner.binary_search(&i).is_ok();
        // The region's free nodes are exactly the model's free nodes inside the sphere.
        let free: Vec<u32> =
            (0..region.nodes.len()).filter(|&l| region.nodes.kind[l] == NodeKind::Free).map(|l| p.kept[l]).collect();
        assert_eq!(free, p.inner);
        for &i in &p.inner {
            let x = model.nodes.position[i as usize];
            assert!((0..3).map(|k| (x[k] - settings.centre[k]).powi(2)).sum::<f64>() <= 0.05f64.powi(2));
        }
        // Every spring of the model touching the region is in the region's model, same rest length.
        let s = &model.springs;
        let mut touching: Vec<(u32, u32, u64)> = (0..s.len())
            .filter(|&k| inner(s.a[k]) || inner(s.b[k]))
            .map(|k| (s.a[k], s.b[k], s.rest_length[k].to_bits()))
            .collect();
        let r = &region.springs;
        let mut kept: Vec<(u32, u32, u64)> = (0..r.len())
            .map(|k| (p.kept[r.a[k] as usize], p.kept[r.b[k] as usize], r.rest_length[k].to_bits()))
            .filter(|&(a, b, _)| inner(a) || inner(b))
            .collect();
        touching.sort_unstable();
        kept.sort_unstable();
        assert!(!touching.is_empty());
        assert_eq!(kept, touching);
        // The core: region nodes none of whose springs leaves the region.
        assert!(!p.core.is_empty() && p.core.len() < p.inner.len());
        for k in 0..s.len() {
            let (a, b) = (s.a[k], s.b[k]);
            for (end, other) in [(a, b), (b, a)] {
                if p.core.binary_search(&end).is_ok() {
                    assert!(inner(other), "core node {end} has a spring to {other} outside the region");
                }
            }
        }
    }

    #[test]
    fn a_bulk_step_late_in_real_time_is_held_past_and_taken_when_back_works() {
        let model = Scene::builtin_default().build_model().unwrap();
        let settings = MultirateSettings {
            centre: [0.0, 0.062, 0.12],
            radius: 0.05,
            ratio: 4,
            follow_tool: false,
            ..MultirateSettings::default()
        };
        let params = crate::solver::IntegrationParameters {
            integrator: crate::solver::IntegratorKind::ImplicitFactored,
            threads: 1,
            ..Default::default()
        };
        let effects = Effects::default();
        let Relocation { layout, region } =
            build_region::<f64>(&model, &params, &effects, &settings, (0, 0), None, &[]).unwrap();
        let bulk_params = crate::solver::IntegrationParameters { dt: params.dt * 4.0, ..params.clone() };
        let bulk = build_bulk::<f64>(&model, &layout.partition, &bulk_params, &effects, (0, 0), None, &[]).unwrap();
        let mut m = Multirate::start(&model, bulk, layout, None, &settings, effects, None).unwrap();
        // Defer: a bulk step may take three ticks of wall-clock time.
        assert_eq!(m.late_after, Some(Duration::from_secs_f64(3.0 * params.dt)));
        let mut state = region.state().clone();
        // The first exchange: the packet is here. The test keeps it as the bulk would while
        // stepping, so the step is in flight for as long as the test says.
        assert!(m.exchange_due());
        assert!(m.receive(&mut state).is_none());
        let in_flight = m.packet.take().expect("received");
        m.end_tick();
        for _ in 1..4 {
            assert!(!m.exchange_due());
            m.end_tick();
        }
        // Due again; a caller faster than real time (less than three ticks since the send) waits.
        m.sent_at = Instant::now();
        m.late_after = Some(Duration::from_secs(3600));
        assert!(m.exchange_due());
        // In real time (three ticks have passed): the region goes on, the exchange stays due.
        m.late_after = Some(Duration::ZERO);
        for held in 1..=5 {
            assert!(!m.exchange_due(), "tick {held} past the exchange");
            m.end_tick();
            assert_eq!((m.status.held_ticks, m.status.held_max_ticks, m.phase), (held, held, 0));
        }
        // The step comes back: taken at once, and the next exchange is `ratio` ticks later.
        assert!(m.to_region.push(in_flight).is_ok());
        assert!(m.exchange_due());
        m.end_tick();
        assert_eq!((m.phase, m.status.held_ticks, m.status.held_max_ticks), (1, 5, 5));
        // Wait: always due on time (the caller then waits in `receive`).
        m.late_after = None;
        m.phase = 0;
        assert!(m.exchange_due());
    }
}
