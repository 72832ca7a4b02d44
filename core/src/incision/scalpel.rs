//! The scalpel beside a [`Simulation`]: it presses the skin with its tip until the skin
//! gives, then cuts every spring its edge sweeps, and resists the hand with the tissue's
//! cutting toughness.
//!
//! # A tick
//! [`Scalpel::move_to`] takes the blade's new pose (from the haptics command or a script)
//! before the step:
//! 1. **Outside** the tissue the tip is a sphere of the tool's smallest radius pressing the
//!    skin (the hand tool's penalty contact): pressing without cutting. When the contact force
//!    of the last step reaches [`ScalpelSettings::puncture_force`] the skin gives: the blade
//!    is **in** the tissue and the sphere leaves the loop.
//! 2. **In** the tissue, every spring whose segment crosses the surface the edge swept since
//!    the last tick is cut ([`Simulation::cut_spring`]), layer by layer down to the tip; a
//!    spring of a bone layer never is. The springs tested are those of nodes within reach of
//!    the sweep (a preallocated candidate list, no allocation).
//! 3. The tissue's force on the blade opposes its motion across the edge: per tissue, its
//!    cutting toughness (J/m², the work per area of new cut surface, which is the force per
//!    metre of edge in it) times the length of edge inside it, eased in with the speed
//!    (`tanh(v / force_speed)`), so the force is continuous and zero at rest. The blade leaves
//!    the tissue when its tip is above the skin again.
//!
//! # Cutting toughness (defaults, J/m² = N per m of edge)
//! | tissue | value | source |
//! |---|---|---|
//! | skin | 1,700 | rat skin, scissors cutting test (Pereira, Lucas and Teoh, J Biomech 30:91, 1997), measured |
//! | fat | 170 | scalpel blades 10-15 in phantom gel, 0.16-0.19 N/mm of edge (Yeung et al., Proc IMechE B 2017), derived: the gel stands in for fat |
//! | muscle | 550 | porcine muscle, single-edge notched, lower end of 550-8,000 (review table, Chinese J Mech Eng 35:102, 2022), measured |
//!
//! The puncture force defaults to 36 N, a sharp blade pressed on ventral porcine skin (39 N
//! dorsal; Kim et al., J Mech Med Biol 17:1750114, 2017, measured); a point-first stab
//! takes less (the median of 24 needle studies is 1.22 N; van Gerwen, Dankelman and van den
//! Dobbelsteen, Med Eng Phys 34:665, 2012).

use super::blade::{Blade, Sweep, segment_crosses_triangle};
use crate::generator::vec3::{cross, dot, norm, sub};
use crate::model::{Model, Tissue};
use crate::real::Real;
use crate::scene::ToolSettings;
use crate::solver::{CutError, Simulation, SphereTool, ToolFeedback};

/// Samples along the edge that find the tissue each part of it is in.
pub const EDGE_SAMPLES: usize = 24;

/// The springs tested are those of nodes within the sweep's reach plus this many longest
/// rest lengths: a spring stretched to up to three times its rest length is seen.
const REACH_REST_LENGTHS: f64 = 1.5;

/// Consecutive ticks the tip must be above the skin before the blade counts as out of the
/// tissue (a wound's edges shift under it; a single tick's reading does not pull it out).
pub const TICKS_TO_LEAVE: u32 = 20;

/// Cutting toughness per tissue, J/m² (N per m of edge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Toughness {
    /// Skin. Default 1,700.
    pub skin: f64,
    /// Fat. Default 170.
    pub fat: f64,
    /// Muscle. Default 550.
    pub muscle: f64,
}

impl Default for Toughness {
    fn default() -> Self {
        Self { skin: 1700.0, fat: 170.0, muscle: 550.0 }
    }
}

impl Toughness {
    /// The toughness of `tissue` (0 for bone and other tissues, which the blade does not cut).
    pub fn of(&self, tissue: Tissue) -> f64 {
        match tissue {
            Tissue::Skin => self.skin,
            Tissue::Fat => self.fat,
            Tissue::Muscle => self.muscle,
            Tissue::Bone | Tissue::Other => 0.0,
        }
    }
}

/// What the scalpel is and how the tissue resists it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalpelSettings {
    /// Length of the cutting edge, m. Default 0.01.
    pub blade_length: f64,
    /// Contact force at which the tip punctures the skin, N. Default 36.
    pub puncture_force: f64,
    /// Cutting toughness per tissue.
    pub toughness: Toughness,
    /// Speed across the edge at which the cutting force reaches `tanh(1)` (76 %) of its full
    /// value, m/s. Default 0.002.
    pub force_speed: f64,
}

impl Default for ScalpelSettings {
    fn default() -> Self {
        Self { blade_length: 0.01, puncture_force: 36.0, toughness: Toughness::default(), force_speed: 0.002 }
    }
}

/// Where the blade is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BladeState {
    /// Outside the tissue: the tip presses the skin.
    Outside,
    /// Through the skin: the edge cuts what it sweeps.
    Cutting,
}

/// Length of edge in each tissue, m.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EdgeInTissue {
    /// In skin, m.
    pub skin: f64,
    /// In fat, m.
    pub fat: f64,
    /// In muscle, m.
    pub muscle: f64,
    /// In or below bone, m.
    pub bone: f64,
}

impl EdgeInTissue {
    fn add(&mut self, tissue: Tissue, length: f64) {
        match tissue {
            Tissue::Skin => self.skin += length,
            Tissue::Fat => self.fat += length,
            Tissue::Muscle => self.muscle += length,
            Tissue::Bone => self.bone += length,
            Tissue::Other => {}
        }
    }

    /// Length below the skin's outer surface, m.
    pub fn total(&self) -> f64 {
        self.skin + self.fat + self.muscle + self.bone
    }
}

/// One tick of the scalpel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalpelTick {
    /// Where the blade is after this tick's move.
    pub state: BladeState,
    /// Springs cut this tick.
    pub springs_cut: u32,
    /// The edge's length in each tissue, m.
    pub edge: EdgeInTissue,
    /// The tissue's cutting force on the blade, N (0 outside).
    pub force: [f64; 3],
    /// Whether the skin gave at this tick.
    pub punctured: bool,
}

/// Totals since the scalpel was made.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScalpelTotals {
    /// Springs cut, per tissue: skin, fat, muscle.
    pub springs_cut: [u64; 3],
    /// Times the skin gave.
    pub punctures: u64,
    /// Distance the tip moved while cutting, m.
    pub cut_length: f64,
    /// Deepest edge length in each tissue while cutting, m.
    pub deepest: EdgeInTissue,
    /// Largest cutting force, N.
    pub peak_force: f64,
    /// Largest press force before a puncture, N.
    pub peak_press: f64,
}

/// A boundary surface's nodes and, per node, its triangles (for the normal).
struct Boundary {
    tissue_beneath: Tissue,
    on: Vec<bool>,
    first: Vec<u32>,
    triangles_of: Vec<u32>,
    triangles: Vec<[u32; 3]>,
}

impl Boundary {
    fn new(model: &Model, s: usize) -> Self {
        let n = model.nodes.len();
        let surface = &model.surfaces[s];
        let triangles: Vec<[u32; 3]> =
            surface.triangles.iter().copied().filter(|t| t.iter().all(|&i| (i as usize) < n)).collect();
        let mut count = vec![0u32; n + 1];
        for t in &triangles {
            for &i in t {
                count[i as usize + 1] += 1;
            }
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut triangles_of = vec![0u32; triangles.len() * 3];
        for (k, t) in triangles.iter().enumerate() {
            for &i in t {
                triangles_of[fill[i as usize] as usize] = k as u32;
                fill[i as usize] += 1;
            }
        }
        let on = (0..n).map(|i| count[i + 1] > count[i]).collect();
        Self { tissue_beneath: surface.tissue_beneath(), on, first: count, triangles_of, triangles }
    }

    /// The outward normal at node `i` (sum of its triangles' area vectors) at positions `x`.
    fn normal<T: Real>(&self, i: usize, x: &crate::solver::Vec3s<T>) -> [f64; 3] {
        let mut nrm = [0.0; 3];
        for &k in &self.triangles_of[self.first[i] as usize..self.first[i + 1] as usize] {
            let [a, b, c] = self.triangles[k as usize].map(|v| x.get_f64(v as usize));
            let area = cross(sub(b, a), sub(c, a));
            nrm = [0, 1, 2].map(|c| nrm[c] + area[c]);
        }
        nrm
    }
}

/// The scalpel's state beside a [`Simulation`]: the springs it has cut, where the blade is,
/// and the scratch of its search, all allocated by [`Scalpel::new`].
pub struct Scalpel {
    settings: ScalpelSettings,
    tip_radius: f64,
    contact_stiffness: f64,
    ends: Vec<[u32; 2]>,
    spring_tissue: Vec<Tissue>,
    cut: Vec<bool>,
    /// Springs in the order they were cut.
    cut_order: Vec<u32>,
    first_spring: Vec<u32>,
    springs_of: Vec<u32>,
    candidate: Vec<bool>,
    candidates: Vec<u32>,
    reach: f64,
    boundaries: Vec<Boundary>,
    state: BladeState,
    /// Ticks in a row the tip has been above the skin while cutting.
    tip_out_ticks: u32,
    /// Per boundary: the candidate nodes on it near the blade.
    near: Vec<Vec<u32>>,
    longest_rest: f64,
    last: Option<Blade>,
    force: [f64; 3],
    totals: ScalpelTotals,
}

impl Scalpel {
    /// A scalpel for `model`, simulated by `sim`, with `settings`; its tip presses with the
    /// hand tool's contact (`tool`: stiffness, and the smallest radius the skin's point shell
    /// is sampled for). Checks that `sim` can be cut.
    ///
    /// # Errors
    /// [`CutError`] when `sim` cannot be cut (not `implicit_factored`).
    pub fn new<T: Real>(
        model: &Model,
        sim: &Simulation<T>,
        tool: &ToolSettings,
        settings: ScalpelSettings,
    ) -> Result<Self, CutError> {
        sim.can_cut()?;
        let n = model.nodes.len();
        let s = &model.springs;
        let ends: Vec<[u32; 2]> = s.a.iter().zip(&s.b).map(|(&a, &b)| [a, b]).collect();
        let tissue_of = |layer: u16| model.layers.get(layer as usize).map_or(Tissue::Other, |l| l.tissue);
        let spring_tissue = s.layer.iter().map(|&l| tissue_of(l)).collect();
        let mut first = vec![0u32; n + 1];
        for &[a, b] in &ends {
            first[a as usize + 1] += 1;
            first[b as usize + 1] += 1;
        }
        for i in 0..n {
            first[i + 1] += first[i];
        }
        let mut fill = first.clone();
        let mut springs_of = vec![0u32; ends.len() * 2];
        for (k, &[a, b]) in ends.iter().enumerate() {
            for i in [a, b] {
                springs_of[fill[i as usize] as usize] = k as u32;
                fill[i as usize] += 1;
            }
        }
        let longest = s.rest_length.iter().copied().fold(0.0, f64::max);
        let boundaries: Vec<Boundary> = (0..model.surfaces.len())
            .filter(|&k| model.surfaces[k].tissue_beneath() != Tissue::Other)
            .map(|k| Boundary::new(model, k))
            .collect();
        Ok(Self {
            settings,
            tip_radius: tool.shell_radius(),
            contact_stiffness: tool.stiffness,
            cut: vec![false; ends.len()],
            cut_order: Vec::with_capacity(ends.len()),
            ends,
            spring_tissue,
            first_spring: first,
            springs_of,
            candidate: vec![false; n],
            candidates: Vec::with_capacity(n),
            reach: REACH_REST_LENGTHS * longest,
            near: boundaries.iter().map(|_| Vec::with_capacity(n)).collect(),
            longest_rest: longest,
            tip_out_ticks: 0,
            boundaries,
            state: BladeState::Outside,
            last: None,
            force: [0.0; 3],
            totals: ScalpelTotals::default(),
        })
    }

    /// Moves the blade to `blade` for the next step of `sim` (`dt` s after the last move):
    /// presses, punctures or cuts as the module describes. Allocates nothing.
    pub fn move_to<T: Real>(&mut self, sim: &mut Simulation<T>, blade: Blade, dt: f64) -> ScalpelTick {
        let last = self.last.replace(blade).unwrap_or(blade);
        let mut tick = ScalpelTick {
            state: self.state,
            springs_cut: 0,
            edge: EdgeInTissue::default(),
            force: [0.0; 3],
            punctured: false,
        };
        let sweep = Sweep { from: last, to: blade };
        self.find_candidates(sim, &sweep);
        if self.state == BladeState::Outside {
            let press = norm(sim.tool_feedback().force);
            let pressing = sim.effects().tool.is_some() && sim.tool_feedback().in_contact;
            if pressing {
                self.totals.peak_press = self.totals.peak_press.max(press);
            }
            if pressing && press >= self.settings.puncture_force {
                self.state = BladeState::Cutting;
                self.tip_out_ticks = 0;
                self.totals.punctures += 1;
                tick.punctured = true;
                sim.effects_mut().tool = None;
            } else {
                // The tip as a sphere whose lowest point along the edge is the tip.
                let axis = sub(blade.back, blade.tip);
                let len = norm(axis).max(f64::MIN_POSITIVE);
                let r = self.tip_radius;
                let centre = [0, 1, 2].map(|c| blade.tip[c] + r * axis[c] / len);
                sim.effects_mut().tool = Some(SphereTool {
                    radius: r,
                    stiffness: self.contact_stiffness,
                    start: centre,
                    velocity: [0.0; 3],
                });
            }
        }
        self.find_near(sim, &blade);
        tick.edge = self.edge_in_tissue(sim, &blade);
        if self.state == BladeState::Cutting {
            let tip_out = self.tissue_at(sim, blade.tip).is_none();
            self.tip_out_ticks = if tip_out { self.tip_out_ticks + 1 } else { 0 };
            if self.tip_out_ticks >= TICKS_TO_LEAVE {
                // The tip is above the skin again.
                self.state = BladeState::Outside;
                self.tip_out_ticks = 0;
                self.force = [0.0; 3];
                sim.set_focus(None);
            } else {
                // A multirate region follows the tip while the sphere tool is off.
                sim.set_focus(Some(blade.tip));
                tick.springs_cut = self.cut_swept(sim, &sweep);
                self.force = self.cutting_force(&sweep, &tick.edge, dt);
                self.totals.cut_length += norm(sub(blade.tip, last.tip));
                let d = &mut self.totals.deepest;
                d.skin = d.skin.max(tick.edge.skin);
                d.fat = d.fat.max(tick.edge.fat);
                d.muscle = d.muscle.max(tick.edge.muscle);
                d.bone = d.bone.max(tick.edge.bone);
                self.totals.peak_force = self.totals.peak_force.max(norm(self.force));
            }
        }
        tick.state = self.state;
        tick.force = self.force;
        tick
    }

    /// Takes the blade out: no contact, nothing cut until the next [`Scalpel::move_to`], which
    /// starts outside the tissue.
    pub fn lift<T: Real>(&mut self, sim: &mut Simulation<T>) {
        if self.state == BladeState::Outside || self.last.is_some() {
            sim.effects_mut().tool = None;
        }
        self.state = BladeState::Outside;
        self.tip_out_ticks = 0;
        self.last = None;
        self.force = [0.0; 3];
        sim.set_focus(None);
    }

    /// The tissue's force on the blade after the last step: the tip's contact while outside,
    /// the cutting force (no stiffness: it follows the motion, not the position) while cutting.
    pub fn feedback<T: Real>(&self, sim: &Simulation<T>) -> ToolFeedback {
        let tip = self.last.map_or([0.0; 3], |b| b.tip);
        match self.state {
            BladeState::Outside if sim.effects().tool.is_some() => sim.tool_feedback(),
            BladeState::Outside => ToolFeedback { centre: tip, ..ToolFeedback::default() },
            BladeState::Cutting => {
                ToolFeedback { in_contact: true, nodes: 0, force: self.force, stiffness: [[0.0; 3]; 3], centre: tip }
            }
        }
    }

    /// Where the blade is.
    pub fn state(&self) -> BladeState {
        self.state
    }

    /// Totals since the scalpel was made.
    pub fn totals(&self) -> ScalpelTotals {
        self.totals
    }

    /// The settings.
    pub fn settings(&self) -> &ScalpelSettings {
        &self.settings
    }

    /// Per model spring (file order): whether it is cut.
    pub fn cut_springs(&self) -> &[bool] {
        &self.cut
    }

    /// The cut springs in the order they were cut.
    pub fn cut_order(&self) -> &[u32] {
        &self.cut_order
    }

    /// `model` without the springs this scalpel cut (the rest in file order), and its cells
    /// with an edge or a face diagonal on a cut spring removed: what a recorder or a model
    /// file holds after the incision. Allocates; call it off the loop.
    pub fn cut_model(&self, model: &Model) -> Model {
        let mut out = model.clone();
        let s = &mut out.springs;
        keep_uncut(&mut s.a, &self.cut);
        keep_uncut(&mut s.b, &self.cut);
        keep_uncut(&mut s.rest_length, &self.cut);
        keep_uncut(&mut s.law, &self.cut);
        keep_uncut(&mut s.damping, &self.cut);
        keep_uncut(&mut s.layer, &self.cut);
        keep_uncut(&mut out.cells, &self.cut_cells(model));
        out
    }

    /// Per cell of `model`: whether a cut spring joins two of its nodes.
    pub fn cut_cells(&self, model: &Model) -> Vec<bool> {
        model
            .cells
            .iter()
            .map(|cell| {
                let nodes = cell.nodes();
                self.cut_order.iter().any(|&s| {
                    let [a, b] = self.ends[s as usize];
                    nodes.contains(&a) && nodes.contains(&b)
                })
            })
            .collect()
    }

    /// Cuts every spring that crosses `sweep` whatever the blade's state (a scripted
    /// incision, or a cut drawn on the skin); returns how many it cut now. Allocates nothing.
    pub fn cut_along<T: Real>(&mut self, sim: &mut Simulation<T>, sweep: &Sweep) -> u32 {
        self.find_candidates(sim, sweep);
        self.cut_swept(sim, sweep)
    }

    /// Marks the nodes within reach of `sweep`.
    fn find_candidates<T: Real>(&mut self, sim: &Simulation<T>, sweep: &Sweep) {
        for &i in &self.candidates {
            self.candidate[i as usize] = false;
        }
        self.candidates.clear();
        let (centre, radius) = sweep.bounding_sphere();
        let reach = radius + self.reach;
        let reach2 = reach * reach;
        let x = &sim.state().x;
        for i in 0..self.candidate.len() {
            let d = sub(x.get_f64(i), centre);
            if dot(d, d) <= reach2 {
                self.candidate[i] = true;
                self.candidates.push(i as u32);
            }
        }
    }

    /// Lists, per boundary, the candidate nodes on it within half the blade plus a longest
    /// rest length of the blade's middle: those a sample of the edge can be nearest.
    fn find_near<T: Real>(&mut self, sim: &Simulation<T>, blade: &Blade) {
        let mid = blade.point(0.5);
        let r = 0.5 * blade.length() + 2.0 * self.longest_rest;
        let x = &sim.state().x;
        for (b, near) in self.boundaries.iter().zip(self.near.iter_mut()) {
            near.clear();
            for &i in &self.candidates {
                if b.on[i as usize] {
                    let d = sub(x.get_f64(i as usize), mid);
                    if dot(d, d) <= r * r {
                        near.push(i);
                    }
                }
            }
        }
    }

    /// Cuts the springs of the candidate nodes that cross `sweep`; returns how many.
    fn cut_swept<T: Real>(&mut self, sim: &mut Simulation<T>, sweep: &Sweep) -> u32 {
        if sweep.area() < super::blade::MIN_SWEPT_AREA_M2 {
            return 0;
        }
        let triangles = sweep.triangles();
        let mut count = 0;
        for k in 0..self.candidates.len() {
            let i = self.candidates[k] as usize;
            for j in self.first_spring[i] as usize..self.first_spring[i + 1] as usize {
                let s = self.springs_of[j] as usize;
                let [a, b] = self.ends[s];
                // Each spring once: from its first node when both are candidates.
                if self.cut[s] || (b as usize == i && self.candidate[a as usize]) {
                    continue;
                }
                let tissue = self.spring_tissue[s];
                if matches!(tissue, Tissue::Bone | Tissue::Other) {
                    continue;
                }
                let x = &sim.state().x;
                let (pa, pb) = (x.get_f64(a as usize), x.get_f64(b as usize));
                if triangles.iter().any(|t| segment_crosses_triangle(pa, pb, t)) && sim.cut_spring(s) {
                    self.cut[s] = true;
                    self.cut_order.push(s as u32);
                    let t = match tissue {
                        Tissue::Skin => 0,
                        Tissue::Fat => 1,
                        _ => 2,
                    };
                    self.totals.springs_cut[t] += 1;
                    count += 1;
                }
            }
        }
        count
    }

    /// The length of the edge of `blade` in each tissue, from [`EDGE_SAMPLES`] samples.
    fn edge_in_tissue<T: Real>(&self, sim: &Simulation<T>, blade: &Blade) -> EdgeInTissue {
        let mut out = EdgeInTissue::default();
        let step = blade.length() / EDGE_SAMPLES as f64;
        for k in 0..EDGE_SAMPLES {
            let p = blade.point((k as f64 + 0.5) / EDGE_SAMPLES as f64);
            if let Some(t) = self.tissue_at(sim, p) {
                out.add(t, step);
            }
        }
        out
    }

    /// The tissue at `p` (m) at the simulation's positions; `None` outside the skin.
    pub fn tissue_at_point<T: Real>(&mut self, sim: &Simulation<T>, p: [f64; 3]) -> Option<Tissue> {
        let blade = Blade { tip: p, back: p };
        self.find_candidates(sim, &Sweep { from: blade, to: blade });
        self.find_near(sim, &blade);
        self.tissue_at(sim, p)
    }

    /// The tissue at `p` (m): beneath the deepest boundary `p` is inside of (by the outward
    /// normal at the boundary's candidate node nearest `p`); `None` outside the skin.
    fn tissue_at<T: Real>(&self, sim: &Simulation<T>, p: [f64; 3]) -> Option<Tissue> {
        let x = &sim.state().x;
        let mut inside = None;
        for (b, near) in self.boundaries.iter().zip(&self.near) {
            let nearest = near
                .iter()
                .map(|&i| {
                    let d = sub(p, x.get_f64(i as usize));
                    (dot(d, d), i as usize, d)
                })
                .min_by(|u, v| u.0.total_cmp(&v.0));
            let Some((_, i, d)) = nearest else { break };
            if dot(d, b.normal(i, x)) < 0.0 {
                inside = Some(b.tissue_beneath);
            } else {
                break;
            }
        }
        inside
    }

    /// The cutting force of the edge in tissue `edge` moving as `sweep` over `dt` s.
    fn cutting_force(&self, sweep: &Sweep, edge: &EdgeInTissue, dt: f64) -> [f64; 3] {
        if dt.is_nan() || dt <= 0.0 {
            return [0.0; 3];
        }
        let axis = sub(sweep.to.back, sweep.to.tip);
        let len = norm(axis);
        let v = sub(sweep.to.tip, sweep.from.tip).map(|d| d / dt);
        // The velocity across the edge.
        let along = if len > 0.0 { dot(v, axis) / (len * len) } else { 0.0 };
        let across = [0, 1, 2].map(|c| v[c] - along * axis[c]);
        let speed = norm(across);
        if speed == 0.0 {
            return [0.0; 3];
        }
        let t = &self.settings.toughness;
        let full = t.skin * edge.skin + t.fat * edge.fat + t.muscle * edge.muscle;
        let magnitude = full * (speed / self.settings.force_speed).tanh();
        across.map(|c| -magnitude * c / speed)
    }
}

/// Keeps the entries of `v` whose `cut` flag is false.
fn keep_uncut<V>(v: &mut Vec<V>, cut: &[bool]) {
    let mut k = cut.iter();
    v.retain(|_| !*k.next().unwrap_or(&false));
}
