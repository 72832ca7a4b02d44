//! Forces and accelerations of the model at a given state: the spring pass plus the
//! effects a scene turned on. Integrators call it; it owns the worker pool and the
//! per-stage timers.

use super::disjoint::DisjointSlice;
use super::effects::Effects;
use super::node_accel::{NodeTerms, accelerations};
use super::params::IntegrationParameters;
use super::spring_pass::{NODE_CHUNK, SpringPass};
use super::vec3s::Vec3s;
use super::worker_pool::WorkerPool;
use crate::model::{Model, NodeKind};
use crate::real::Real;
use std::time::{Duration, Instant};

/// Most tool contact points listed for an implicit solver per evaluation. Default 8192.
pub const MAX_CONTACT_SAMPLES: usize = 8192;

/// One contact point of the tool: a point on a skin triangle (barycentric weights) or a
/// node (weights `[1, 0, 0]`), pushed along `normal` with penalty stiffness `stiffness`.
/// Its force on node `nodes[j]` is `weights[j] · f`, and its stiffness between nodes `j`
/// and `k` is `weights[j] weights[k] stiffness · normal normalᵀ`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactSample {
    /// Nodes carrying the point.
    pub nodes: [u32; 3],
    /// Barycentric weights of the point on them.
    pub weights: [f64; 3],
    /// Outward unit normal (from the tool's centre).
    pub normal: [f64; 3],
    /// Penalty stiffness, N/m.
    pub stiffness: f64,
}

/// Positions (m), velocities (m/s) and time (s) of every node.
#[derive(Clone, Debug, PartialEq)]
pub struct State<T> {
    /// Positions, m.
    pub x: Vec3s<T>,
    /// Velocities, m/s.
    pub v: Vec3s<T>,
    /// Simulated time, s.
    pub time: f64,
}

impl<T: Real> State<T> {
    /// Copies `other` without allocating.
    pub fn copy_from(&mut self, other: &Self) {
        self.x.copy_from(&other.x);
        self.v.copy_from(&other.v);
        self.time = other.time;
    }
}

/// Time spent per stage, summed since the last reset.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageCounters {
    /// Loads and drag handles.
    pub external: Duration,
    /// Spring forces (all workers, wall time).
    pub springs: Duration,
    /// Per-node accelerations and the integrator's update.
    pub nodes: Duration,
    /// Kinematic bone nodes.
    pub bone: Duration,
    /// Guard checks, snapshots and recoveries.
    pub guard: Duration,
    /// Implicit solve (tangent assembly and conjugate gradients).
    pub implicit: Duration,
    /// Of `implicit`: the prefactored preconditioner's triangular solves.
    pub preconditioner: Duration,
    /// Conjugate-gradient iterations.
    pub cg_iterations: u64,
    /// Frames stepped.
    pub frames: u64,
    /// Sub-steps taken.
    pub substeps: u64,
}

/// Everything needed to evaluate accelerations.
pub struct Dynamics<T> {
    pub(crate) pass: SpringPass<T>,
    pub(crate) pool: WorkerPool,
    pub(crate) mass: Vec<T>,
    pub(crate) free: Vec<T>,
    pub(crate) rest: Vec3s<T>,
    pub(crate) kinematic: Vec<u32>,
    pub(crate) external: Vec3s<T>,
    pub(crate) effects: Effects,
    /// Nodes the tool pushed at the last evaluation (capacity: every node, so no allocation).
    pub(crate) tool_touched: Vec<u32>,
    /// `tool_touched` as a flag per node (each node is listed once).
    pub(crate) tool_marked: Vec<bool>,
    /// The point shell on the outer skin the tool meets (empty: node contact only).
    pub(crate) skin_shell: super::skin_contact::SkinShell,
    /// The skin layer's tetrahedra (their volume term is on when `effects.skin_volume` is).
    pub(crate) skin_volume: super::skin_volume::SkinVolume,
    /// Free nodes off the shell, which the tool pushes one by one.
    pub(crate) tool_nodes: Vec<u32>,
    /// What the tool felt at the last evaluation.
    pub(crate) tool_feedback: super::effects::ToolFeedback,
    /// The tool's contact points at the last evaluation, with their normal stiffness, for
    /// an implicit solver (filled only when `record_contacts` is set; at most its capacity,
    /// [`MAX_CONTACT_SAMPLES`]).
    pub(crate) contacts: Vec<ContactSample>,
    /// Contact points beyond `contacts`' capacity at the last evaluation (their forces are
    /// applied, their stiffness is not).
    pub(crate) contacts_dropped: u32,
    /// Whether the tool evaluation lists its contacts.
    pub(crate) record_contacts: bool,
    /// Per-stage timers.
    pub counters: StageCounters,
}

impl<T: Real> Dynamics<T> {
    /// Builds the force evaluation for `model` with `effects`.
    pub fn new(model: &Model, params: &IntegrationParameters, effects: Effects) -> Self {
        let n = model.nodes.len();
        let threads = params.threads.max(1);
        let pass = SpringPass::new(
            &model.springs,
            n,
            threads,
            params.simd,
            effects.spring_damping,
            params.share_run_parameters,
        );
        let free: Vec<T> = model
            .nodes
            .kind
            .iter()
            .map(|k| if !effects.bone || *k == NodeKind::Free { T::ONE } else { T::ZERO })
            .collect();
        let kinematic = if effects.bone {
            (0..n as u32).filter(|&i| model.nodes.kind[i as usize] == NodeKind::Kinematic).collect()
        } else {
            Vec::new()
        };
        // Sampled for the tool's radius at construction (1 cm without a tool yet); a haptics
        // scene builds with its `min_radius`, the smallest a command may set.
        let skin_shell = super::skin_contact::SkinShell::of_model(model, effects.tool.map_or(0.01, |t| t.radius));
        let tool_nodes = (0..n as u32)
            .filter(|&i| free[i as usize] != T::ZERO && !skin_shell.on_shell.get(i as usize).copied().unwrap_or(false))
            .collect();
        let mut skin_volume = super::skin_volume::SkinVolume::of_model(model);
        skin_volume.retain_touching(|i| free[i as usize] != T::ZERO);
        Self {
            pass,
            pool: WorkerPool::new(threads, params.pin_workers),
            mass: model.nodes.mass.iter().map(|&m| T::from_f64(m)).collect(),
            free,
            rest: Vec3s::from_f64(&model.nodes.position),
            kinematic,
            external: Vec3s::zeros(n),
            effects,
            tool_touched: Vec::with_capacity(n),
            tool_marked: vec![false; n],
            skin_shell,
            skin_volume,
            tool_nodes,
            tool_feedback: Default::default(),
            contacts: Vec::new(),
            contacts_dropped: 0,
            record_contacts: false,
            counters: StageCounters::default(),
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// Whether loads, handles, the tool or the skin's volume term are on.
    pub(crate) fn has_external(&self) -> bool {
        !self.effects.loads.is_empty()
            || !self.effects.handles.is_empty()
            || self.effects.tool.is_some()
            || self.effects.skin_volume.is_some()
    }

    /// Loads, handle, tool and skin-volume forces at `(x, v)` and time `t` into the external
    /// array, when any of them is on.
    pub(crate) fn eval_external_at(&mut self, x: &Vec3s<T>, v: &Vec3s<T>, t: f64) {
        if self.has_external() {
            self.eval_external(x, v, t);
        }
    }

    /// Writes loads, handle, tool and skin-volume forces at state `(x, v)` and time `t` into the external array.
    fn eval_external(&mut self, x: &Vec3s<T>, v: &Vec3s<T>, t: f64) {
        let start = Instant::now();
        let ext = &mut self.external;
        for &i in &self.tool_touched {
            ext.set(i as usize, [T::ZERO; 3]);
            self.tool_marked[i as usize] = false;
        }
        self.tool_touched.clear();
        for l in &self.effects.loads {
            ext.set(l.node as usize, [T::ZERO; 3]);
        }
        for h in &self.effects.handles {
            ext.set(h.node as usize, [T::ZERO; 3]);
        }
        if self.effects.skin_volume.is_some() {
            for &i in &self.skin_volume.nodes {
                ext.set(i as usize, [T::ZERO; 3]);
            }
        }
        for l in &self.effects.loads {
            let scale = if l.ramp_s > 0.0 { (t / l.ramp_s).min(1.0) } else { 1.0 };
            let i = l.node as usize;
            let old = ext.get(i);
            ext.set(i, [0, 1, 2].map(|c| old[c] + T::from_f64(l.force[c] * scale)));
        }
        for h in &self.effects.handles {
            let i = h.node as usize;
            let (p, q, old) = (x.get_f64(i), v.get_f64(i), ext.get(i));
            ext.set(i, [0, 1, 2].map(|c| old[c] + T::from_f64(h.stiffness * (h.target[c] - p[c]) - h.damping * q[c])));
        }
        if let Some(tool) = self.effects.tool {
            let c = tool.centre(t);
            let mut fb = super::effects::ToolFeedback { centre: c, ..Default::default() };
            let r2 = tool.radius * tool.radius;
            let record = self.record_contacts;
            let (contacts, dropped) = (&mut self.contacts, &mut self.contacts_dropped);
            contacts.clear();
            *dropped = 0;
            let mut list = |nodes: [u32; 3], weights: [f64; 3], p: [f64; 3], k: f64| {
                if !record {
                    return;
                }
                let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
                if contacts.len() < contacts.capacity() {
                    contacts.push(ContactSample { nodes, weights, normal: d.map(|v| v / dist), stiffness: k });
                } else {
                    *dropped += 1;
                }
            };
            let shell = &self.skin_shell;
            let (touched, marked) = (&mut self.tool_touched, &mut self.tool_marked);
            // Pushes node `i` by `f` (N) and lists it for zeroing at the next evaluation.
            let mut push_node = |i: usize, f: [f64; 3]| {
                let old = ext.get(i);
                ext.set(i, [0, 1, 2].map(|k| old[k] + T::from_f64(f[k])));
                if !marked[i] {
                    marked[i] = true;
                    touched.push(i as u32);
                }
            };
            // A contact point at `p` inside the sphere: its outward push and the tool's feedback.
            let contact = |p: [f64; 3], k: f64, fb: &mut super::effects::ToolFeedback| -> Option<[f64; 3]> {
                let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if d2 >= r2 || !d2.is_finite() {
                    return None;
                }
                let dist = d2.sqrt().max(1e-9);
                let n = [d[0] / dist, d[1] / dist, d[2] / dist];
                let push = k * (tool.radius - dist);
                fb.nodes += 1;
                for a in 0..3 {
                    fb.force[a] -= push * n[a];
                    for b in 0..3 {
                        fb.stiffness[a][b] -= k * n[a] * n[b];
                    }
                }
                Some(n.map(|x| push * x))
            };
            // Free nodes off the skin shell (deep nodes once the tool is through, or every node
            // of a model without a skin surface).
            for &i in &self.tool_nodes {
                let p = x.get_f64(i as usize);
                if let Some(f) = contact(p, tool.stiffness, &mut fb) {
                    push_node(i as usize, f);
                    list([i; 3], [1.0, 0.0, 0.0], p, tool.stiffness);
                }
            }
            // The skin's point shell: triangles the sphere reaches.
            for tri in &shell.triangles {
                let v = tri.nodes.map(|i| x.get_f64(i as usize));
                let near = super::skin_contact::distance2_to_triangle(c, v[0], v[1], v[2]) < r2; // false if not finite
                if !near {
                    continue;
                }
                let k_sample = tool.stiffness * tri.sample_weight;
                // The samples' pushes, summed per node of the triangle, applied once.
                let mut on_nodes = [[0.0_f64; 3]; 3];
                super::skin_contact::for_each_sample_near(tri.subdivision, &v, c, tool.radius, |w| {
                    let p = [0, 1, 2].map(|k| w[0] * v[0][k] + w[1] * v[1][k] + w[2] * v[2][k]);
                    if let Some(f) = contact(p, k_sample, &mut fb) {
                        for (acc, wj) in on_nodes.iter_mut().zip(w) {
                            for k in 0..3 {
                                acc[k] += wj * f[k];
                            }
                        }
                        list(tri.nodes, w, p, k_sample);
                    }
                });
                for (&node, f) in tri.nodes.iter().zip(on_nodes) {
                    if self.free[node as usize] != T::ZERO && f != [0.0; 3] {
                        push_node(node as usize, f);
                    }
                }
            }
            fb.in_contact = fb.nodes > 0;
            self.tool_feedback = fb;
        }
        if let Some(k) = self.effects.skin_volume {
            self.skin_volume.add_forces(k, x, &mut self.external);
        }
        self.counters.external += start.elapsed();
    }

    fn terms(&self, with_external: bool) -> NodeTerms<'_, T> {
        NodeTerms {
            mass: &self.mass,
            free: &self.free,
            gravity: self.effects.gravity.map(|g| g.map(T::from_f64)),
            viscous: self.effects.viscous_damping.map(T::from_f64),
            external: with_external.then(|| self.external.slices()),
        }
    }

    /// Accelerations at state `(x, v)` and time `t` into `a`, m/s² (0 on held nodes).
    pub fn accelerations_into(&mut self, x: &Vec3s<T>, v: &Vec3s<T>, t: f64, a: &mut Vec3s<T>) {
        let ext = self.has_external();
        if ext {
            self.eval_external(x, v, t);
        }
        let start = Instant::now();
        self.pass.accumulate(&self.pool, x, v);
        let mid = Instant::now();
        let terms = self.terms(ext);
        let [ax, ay, az] = a.slices_mut();
        let out = [DisjointSlice::new(ax), DisjointSlice::new(ay), DisjointSlice::new(az)];
        self.pass.for_each_block(&self.pool, |range, f| {
            let mut acc = [[T::ZERO; NODE_CHUNK]; 3];
            let n = range.len();
            let vr = [&v.x[range.clone()], &v.y[range.clone()], &v.z[range.clone()]];
            accelerations(&terms, range.clone(), f, vr, &mut acc);
            for c in 0..3 {
                // SAFETY: blocks are disjoint.
                unsafe { out[c].range_mut(range.clone()) }.copy_from_slice(&acc[c][..n]);
            }
        });
        self.counters.springs += mid - start;
        self.counters.nodes += mid.elapsed();
    }

    /// One symplectic Euler sub-step of `h` seconds, fused: forces, then per block
    /// `v += h a; x += h v`.
    pub fn symplectic_substep(&mut self, state: &mut State<T>, h: f64) {
        let ext = self.has_external();
        if ext {
            self.eval_external(&state.x, &state.v, state.time);
        }
        let start = Instant::now();
        self.pass.accumulate(&self.pool, &state.x, &state.v);
        let mid = Instant::now();
        let terms = self.terms(ext);
        let h = T::from_f64(h);
        let [xx, xy, xz] = state.x.slices_mut();
        let [vx, vy, vz] = state.v.slices_mut();
        let xs = [DisjointSlice::new(xx), DisjointSlice::new(xy), DisjointSlice::new(xz)];
        let vs = [DisjointSlice::new(vx), DisjointSlice::new(vy), DisjointSlice::new(vz)];
        self.pass.for_each_block(&self.pool, |range, f| {
            let mut acc = [[T::ZERO; NODE_CHUNK]; 3];
            let n = range.len();
            // SAFETY: blocks are disjoint, so these ranges are touched by this worker only.
            let (v, x) = unsafe {
                (
                    [vs[0].range_mut(range.clone()), vs[1].range_mut(range.clone()), vs[2].range_mut(range.clone())],
                    [xs[0].range_mut(range.clone()), xs[1].range_mut(range.clone()), xs[2].range_mut(range.clone())],
                )
            };
            accelerations(&terms, range.clone(), f, [&*v[0], &*v[1], &*v[2]], &mut acc);
            for ((vc, xc), ac) in v.into_iter().zip(x).zip(&acc) {
                for i in 0..n {
                    vc[i] += h * ac[i];
                    xc[i] += h * vc[i];
                }
            }
        });
        self.counters.springs += mid - start;
        self.counters.nodes += mid.elapsed();
    }

    /// Puts kinematic nodes where the bone motion has them at time `t`.
    pub fn move_bone(&mut self, state: &mut State<T>, t: f64) {
        let Some(motion) = self.effects.bone_motion else { return };
        if self.kinematic.is_empty() {
            return;
        }
        let start = Instant::now();
        let w = 2.0 * std::f64::consts::PI * motion.frequency_hz;
        let (s, c) = (w * t).sin_cos();
        for &k in &self.kinematic {
            let i = k as usize;
            let r = self.rest.get_f64(i);
            state.x.set(i, [0, 1, 2].map(|j| T::from_f64(r[j] + motion.amplitude[j] * s)));
            state.v.set(i, [0, 1, 2].map(|j| T::from_f64(motion.amplitude[j] * w * c)));
        }
        self.counters.bone += start.elapsed();
    }
}
