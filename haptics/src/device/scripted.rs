//! A device that replays a trajectory: push and pull scripts like the paper's Fig. 12, for
//! demos and end-to-end tests.

use std::path::{Path, PathBuf};

use super::{DeviceError, DeviceInfo, DeviceState, HapticDevice};
use lamina_bridge::wire::ToolKind;
use lamina_rt::now_ns;

/// Latest script time a trajectory may hold, s: one day.
pub const MAX_SCRIPT_S: f64 = 86_400.0;

/// Reach of the scripted device, m: its workspace radius. A trajectory row farther from the
/// workspace centre is refused when the file is read.
pub const SCRIPT_REACH_M: f64 = 0.08;

/// One row of a trajectory: where the handle is at a script time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectoryPoint {
    /// Script time, s (strictly increasing along the file).
    pub t_s: f64,
    /// Handle position, device frame, m.
    pub position_m: [f64; 3],
    /// Buttons held from this row on (bit `i` = button `i`).
    pub buttons: u32,
    /// The tool from this row on: `sphere` unless the file has a `kind` column.
    pub kind: ToolKind,
}

/// A handle trajectory read from CSV.
///
/// Format: a header line `t_s,x_m,y_m,z_m` followed by the optional columns `buttons` (a bit
/// set) and `kind` (the tool: `sphere` or `scalpel`, or their codes `0` and `1`), each at most
/// once, in either order; then one row per point; `#` starts a comment line; blank lines are
/// ignored. Times strictly increase within 0 to [`MAX_SCRIPT_S`]; every position lies within
/// [`SCRIPT_REACH_M`] of the workspace centre. Positions are linear between rows; buttons and
/// kind switch at rows; after the last row the handle holds still.
///
/// # Examples
///
/// ```
/// use lamina_haptics::device::Trajectory;
///
/// let t = Trajectory::parse("t_s,x_m,y_m,z_m\n0,0,0,0.02\n1,0,0,-0.01\n", "press.csv").unwrap();
/// let z = t.position_at(0.5)[2]; // halfway from 2 cm above to 1 cm below
/// assert!((z - 0.005).abs() < 1e-15);
/// assert_eq!(t.duration_s(), 1.0);
/// assert_eq!(t.kind_at(0.5), None, "no kind column: the haptics process's --tool decides");
///
/// let cut = Trajectory::parse("t_s,x_m,y_m,z_m,kind\n0,0,0,0,scalpel\n", "cut.csv").unwrap();
/// assert_eq!(cut.kind_at(0.0), Some(lamina_bridge::wire::ToolKind::Scalpel));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    points: Vec<TrajectoryPoint>,
    has_kind: bool,
    source: PathBuf,
}

impl Trajectory {
    /// Reads a trajectory file.
    pub fn load(path: &Path) -> Result<Self, DeviceError> {
        let text = std::fs::read_to_string(path).map_err(|e| DeviceError::Script {
            file: path.display().to_string(),
            line: 0,
            what: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parses trajectory text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Self, DeviceError> {
        let err = |line: usize, what: String| DeviceError::Script { file: file.to_string(), line, what };
        let mut lines =
            text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let (hline, header) = lines.next().ok_or_else(|| err(0, "empty: expected a header t_s,x_m,y_m,z_m".into()))?;
        let columns: Vec<&str> = header.split(',').map(str::trim).collect();
        let bad_header = || err(hline + 1, format!("header '{header}': expected t_s,x_m,y_m,z_m[,buttons][,kind]"));
        if columns.len() < 4 || columns[..4] != ["t_s", "x_m", "y_m", "z_m"] {
            return Err(bad_header());
        }
        let (mut buttons_at, mut kind_at) = (None, None);
        for (k, name) in columns.iter().enumerate().skip(4) {
            let slot = match *name {
                "buttons" => &mut buttons_at,
                "kind" => &mut kind_at,
                _ => return Err(bad_header()),
            };
            if slot.replace(k).is_some() {
                return Err(err(hline + 1, format!("header '{header}': column '{name}' twice")));
            }
        }
        let mut points: Vec<TrajectoryPoint> = Vec::new();
        for (i, line) in lines {
            let n = i + 1;
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() != columns.len() {
                return Err(err(n, format!("{} values, expected {}", fields.len(), columns.len())));
            }
            let mut v = [0.0f64; 4];
            for (k, f) in fields.iter().take(4).enumerate() {
                v[k] = f.parse::<f64>().map_err(|_| err(n, format!("{}: '{f}' is not a number", columns[k])))?;
                if !v[k].is_finite() {
                    return Err(err(n, format!("{}: '{f}' is not finite", columns[k])));
                }
            }
            let buttons = match buttons_at {
                Some(k) => fields[k]
                    .parse::<u32>()
                    .map_err(|_| err(n, format!("buttons: '{}' is not a bit set", fields[k])))?,
                None => 0,
            };
            let kind = match kind_at {
                Some(k) => ToolKind::parse(fields[k]).ok_or_else(|| {
                    err(n, format!("kind: '{}' is not a tool (expected sphere, scalpel, 0 or 1)", fields[k]))
                })?,
                None => ToolKind::Sphere,
            };
            if !(0.0..=MAX_SCRIPT_S).contains(&v[0]) {
                return Err(err(n, format!("t_s: {} is outside 0 to {MAX_SCRIPT_S} s (one day)", fields[0])));
            }
            if let Some(last) = points.last()
                && v[0] <= last.t_s
            {
                return Err(err(n, format!("t_s {} does not increase (previous {})", v[0], last.t_s)));
            }
            let reach = super::norm3([v[1], v[2], v[3]]);
            if reach > SCRIPT_REACH_M {
                return Err(err(
                    n,
                    format!(
                        "position ({}, {}, {}) m is {reach:.3e} m from the workspace centre, beyond the scripted device's reach of {SCRIPT_REACH_M} m",
                        fields[1], fields[2], fields[3]
                    ),
                ));
            }
            points.push(TrajectoryPoint { t_s: v[0], position_m: [v[1], v[2], v[3]], buttons, kind });
        }
        if points.is_empty() {
            return Err(err(hline + 1, "no points after the header".into()));
        }
        Ok(Self { points, has_kind: kind_at.is_some(), source: PathBuf::from(file) })
    }

    /// The points, in time order.
    pub fn points(&self) -> &[TrajectoryPoint] {
        &self.points
    }

    /// Time of the last point, s (0 for a single point).
    pub fn duration_s(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.t_s) - self.points[0].t_s.min(0.0)
    }

    /// Whether script time `t_s` is past the last point.
    pub fn is_finished(&self, t_s: f64) -> bool {
        self.points.last().is_none_or(|p| t_s >= p.t_s)
    }

    /// Index of the last point at or before `t_s` (0 before the first).
    fn segment(&self, t_s: f64) -> usize {
        self.points.partition_point(|p| p.t_s <= t_s).saturating_sub(1)
    }

    /// Handle position at script time `t_s`, m (linear between points; held outside them).
    pub fn position_at(&self, t_s: f64) -> [f64; 3] {
        let i = self.segment(t_s);
        let a = &self.points[i];
        match self.points.get(i + 1) {
            Some(b) if t_s > a.t_s => {
                let s = (t_s - a.t_s) / (b.t_s - a.t_s);
                [0, 1, 2].map(|c| a.position_m[c] + s * (b.position_m[c] - a.position_m[c]))
            }
            _ => a.position_m,
        }
    }

    /// Buttons held at script time `t_s`.
    pub fn buttons_at(&self, t_s: f64) -> u32 {
        if t_s < self.points[0].t_s { 0 } else { self.points[self.segment(t_s)].buttons }
    }

    /// Whether the file has a `kind` column (then it, not `--tool`, names the tool).
    pub fn has_kind(&self) -> bool {
        self.has_kind
    }

    /// The tool at script time `t_s` (the first row's before it); `None` when the file has no
    /// `kind` column.
    pub fn kind_at(&self, t_s: f64) -> Option<ToolKind> {
        self.has_kind.then(|| self.points[self.segment(t_s)].kind)
    }

    /// The file it came from.
    pub fn source(&self) -> &Path {
        &self.source
    }
}

/// Where a scripted device's time comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ScriptClock {
    /// `CLOCK_MONOTONIC` since the first `read`.
    Monotonic { start_ns: Option<u64> },
    /// Set by [`ScriptedDevice::set_time_s`] (deterministic tests).
    Manual { t_s: f64 },
}

/// Replays a [`Trajectory`] and records every force it is sent.
///
/// The force log is allocated at construction (`log_capacity` entries); writes beyond it are
/// counted in [`dropped_forces`](Self::dropped_forces), so `read` and `write_force` never
/// allocate.
#[derive(Debug)]
pub struct ScriptedDevice {
    info: DeviceInfo,
    trajectory: Trajectory,
    clock: ScriptClock,
    last_t_s: f64,
    forces: Vec<(f64, [f64; 3])>,
    dropped: u64,
    disconnect_after_s: Option<f64>,
}

impl ScriptedDevice {
    /// Limits of the scripted device: those of a Force Dimension omega.3 class device
    /// (12 N, 14.5 kN/m rendered stably, ±8 cm workspace), with stiffness set to 3 kN/m,
    /// a value such devices render without buzz at 4 kHz.
    pub fn default_info() -> DeviceInfo {
        DeviceInfo {
            name: "scripted".into(),
            max_force_n: 12.0,
            max_stiffness_n_per_m: 3000.0,
            max_damping_n_s_per_m: 20.0,
            workspace_radius_m: SCRIPT_REACH_M,
        }
    }

    /// A device replaying `trajectory` in real time from its first `read`, keeping up to
    /// `log_capacity` forces.
    pub fn new(trajectory: Trajectory, info: DeviceInfo, log_capacity: usize) -> Self {
        Self {
            info,
            trajectory,
            clock: ScriptClock::Monotonic { start_ns: None },
            last_t_s: 0.0,
            forces: Vec::with_capacity(log_capacity),
            dropped: 0,
            disconnect_after_s: None,
        }
    }

    /// Switches to manual time at `t_s` (script seconds); later reads use the last value set.
    pub fn set_time_s(&mut self, t_s: f64) {
        self.clock = ScriptClock::Manual { t_s };
    }

    /// Makes the device vanish at script time `t_s`: from then on `read` and `write_force`
    /// return [`DeviceError::Disconnected`] (a cable pulled mid-run).
    pub fn disconnect_after(&mut self, t_s: f64) {
        self.disconnect_after_s = Some(t_s);
    }

    /// The trajectory being replayed.
    pub fn trajectory(&self) -> &Trajectory {
        &self.trajectory
    }

    /// Every force written so far with its script time, N, device frame.
    pub fn forces(&self) -> &[(f64, [f64; 3])] {
        &self.forces
    }

    /// Forces not kept because the log was full.
    pub fn dropped_forces(&self) -> u64 {
        self.dropped
    }

    fn now_s(&mut self) -> f64 {
        match &mut self.clock {
            ScriptClock::Manual { t_s } => *t_s,
            ScriptClock::Monotonic { start_ns } => {
                let now = now_ns();
                let start = *start_ns.get_or_insert(now);
                now.saturating_sub(start) as f64 * 1e-9
            }
        }
    }

    fn check_connected(&self, t_s: f64) -> Result<(), DeviceError> {
        match self.disconnect_after_s {
            Some(at) if t_s >= at => Err(DeviceError::Disconnected {
                detail: format!("scripted device stopped answering at {at} s (disconnect_after)"),
            }),
            _ => Ok(()),
        }
    }
}

impl HapticDevice for ScriptedDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        let t = self.now_s();
        self.last_t_s = t;
        self.check_connected(t)?;
        Ok(DeviceState {
            position_m: self.trajectory.position_at(t),
            orientation: [0.0, 0.0, 0.0, 1.0],
            buttons: self.trajectory.buttons_at(t),
        })
    }

    fn tool_kind(&self) -> Option<ToolKind> {
        self.trajectory.kind_at(self.last_t_s)
    }

    fn write_force(&mut self, force_n: [f64; 3]) -> Result<(), DeviceError> {
        self.check_connected(self.last_t_s)?;
        if self.forces.len() < self.forces.capacity() {
            self.forces.push((self.last_t_s, force_n));
        } else {
            self.dropped += 1;
        }
        Ok(())
    }
}
