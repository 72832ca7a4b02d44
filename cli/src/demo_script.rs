//! The scripted device's trajectory for `lamina demo`, fitted to the run's length.
//!
//! The script presses the sphere tool [`PRESS_DEPTH_M`] into the skin, holds, lets go, moves
//! [`GRASP_OFFSET_X_M`] toward the operator, grasps the skin (button 0) and pulls it up, then
//! lets go and lifts away (the paper's Fig. 12). Device frame (CHAI3D): x toward the operator,
//! y right, z up, metres; the origin is the scene's `effects.tool.device_origin`, where the
//! tool just touches the top of the skin, so device z = -12 mm is a 12 mm press.
//!
//! At its nominal pace the script takes [`NOMINAL_S`]; a shorter run plays it faster, down to
//! [`MIN_PACE`] of the nominal durations. A run too short for that drops the grasp-and-pull,
//! then the press, and [`DemoScript::skipped`] says so.

/// How deep the tool presses, m: one tool radius of the default scene (12 mm). Deeper, the
/// skin would close over the sphere's equator.
pub const PRESS_DEPTH_M: f64 = 0.012;
/// How far toward the operator (device x) the grasp is made, m.
pub const GRASP_OFFSET_X_M: f64 = -0.03;
/// Depth of the grasp, m (below the touching point, so skin nodes are within reach).
pub const GRASP_DEPTH_M: f64 = 0.004;
/// Height of the pull, m above the touching point.
pub const PULL_HEIGHT_M: f64 = 0.008;
/// Height the tool starts at and moves between sites at, m above the touching point.
pub const CLEAR_M: f64 = 0.010;
/// Fastest pace: durations are never shorter than this fraction of the nominal ones.
pub const MIN_PACE: f64 = 0.5;
/// Time the run keeps for the haptics process to start and for a margin at the end, s: the
/// script gets the run's seconds minus this.
pub const OVERHEAD_S: f64 = 1.0;

/// One move: to `x`, `z` (device frame, m) in `nominal_s`; `buttons` are held from its end
/// (the scripted device switches buttons at rows).
struct Move {
    x: f64,
    z: f64,
    nominal_s: f64,
    buttons: u32,
}

const fn mv(x: f64, z: f64, nominal_s: f64, buttons: u32) -> Move {
    Move { x, z, nominal_s, buttons }
}

/// Press, hold and release (from the start point at x = 0, z = [`CLEAR_M`]).
static PRESS: [Move; 4] = [
    mv(0.0, 0.0, 0.5, 0),            // down to the skin
    mv(0.0, -PRESS_DEPTH_M, 1.5, 0), // press 12 mm, 8 mm/s
    mv(0.0, -PRESS_DEPTH_M, 0.8, 0), // hold
    mv(0.0, CLEAR_M, 0.8, 0),        // release and lift
];

/// Move over, grasp, pull, let go and lift away.
static GRASP_PULL: [Move; 7] = [
    mv(GRASP_OFFSET_X_M, CLEAR_M, 0.5, 0),        // over the grasp site
    mv(GRASP_OFFSET_X_M, -GRASP_DEPTH_M, 0.6, 0), // down into the skin
    mv(GRASP_OFFSET_X_M, -GRASP_DEPTH_M, 0.2, 1), // grasp (button 0)
    mv(GRASP_OFFSET_X_M, PULL_HEIGHT_M, 1.2, 1),  // pull up
    mv(GRASP_OFFSET_X_M, PULL_HEIGHT_M, 0.6, 1),  // hold the pull
    mv(GRASP_OFFSET_X_M, PULL_HEIGHT_M, 0.1, 0),  // let go
    mv(GRASP_OFFSET_X_M, 0.03, 0.6, 0),           // lift away
];

fn nominal(moves: &[Move]) -> f64 {
    moves.iter().map(|m| m.nominal_s).sum()
}

/// Length of the whole script at its nominal pace, s.
pub const NOMINAL_S: f64 = 7.4;

/// The demo's device script for one run.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoScript {
    /// The trajectory as CSV (`t_s,x_m,y_m,z_m,buttons`, the scripted device's format).
    pub csv: String,
    /// Script length, s.
    pub duration_s: f64,
    /// Durations relative to the nominal ones (1: nominal pace; 0.5: twice as fast).
    pub pace: f64,
    /// Whether the press (and hold and release) is in it.
    pub press: bool,
    /// Whether the grasp-and-pull is in it.
    pub grasp_pull: bool,
}

impl DemoScript {
    /// The script for a run of `seconds`: the whole script at its nominal pace when it fits,
    /// faster (down to [`MIN_PACE`]) when it does not, and without the grasp-and-pull, then
    /// without the press, when even that does not fit.
    pub fn for_run(seconds: f64) -> Self {
        let available = seconds - OVERHEAD_S;
        let press = nominal(&PRESS);
        let all = press + nominal(&GRASP_PULL);
        let (moves, total): (Vec<&Move>, f64) = if available >= MIN_PACE * all {
            (PRESS.iter().chain(GRASP_PULL.iter()).collect(), all)
        } else if available >= MIN_PACE * press {
            (PRESS.iter().collect(), press)
        } else {
            (Vec::new(), 1.0)
        };
        let pace = (available / total).clamp(MIN_PACE, 1.0);
        let mut csv = String::from(
            "# lamina demo: press into the skin, let go, then grasp (button 0) and pull it up (Fig. 12).\n\
             # Device frame (CHAI3D): x toward the operator, y right, z up, metres; the origin is the\n\
             # scene's effects.tool.device_origin (the tool just touching the skin). Linear between\n\
             # rows; the last row is held.\n\
             t_s,x_m,y_m,z_m,buttons\n",
        );
        csv.push_str(&format!("0,0,0,{CLEAR_M},0\n"));
        let mut t = 0.0;
        for m in &moves {
            t += m.nominal_s * pace;
            csv.push_str(&format!("{t:.4},{},0,{},{}\n", m.x, m.z, m.buttons));
        }
        let duration_s = if moves.is_empty() { 0.0 } else { t };
        Self {
            csv,
            duration_s,
            pace,
            press: !moves.is_empty(),
            grasp_pull: moves.len() == PRESS.len() + GRASP_PULL.len(),
        }
    }

    /// What the run leaves out, for the demo's opening lines (`None`: nothing).
    pub fn skipped(&self, seconds: f64) -> Option<String> {
        let need = |moves: f64| moves * MIN_PACE + OVERHEAD_S;
        let all = need(NOMINAL_S);
        match (self.press, self.grasp_pull) {
            (true, true) => None,
            (true, false) => Some(format!(
                "--seconds {seconds} is too short for the grasp-and-pull (it needs at least {all:.1} s): the scripted \
                 device only presses, holds and releases"
            )),
            _ => Some(format!(
                "--seconds {seconds} is too short for the scripted press (it needs at least {:.1} s, the \
                 grasp-and-pull {all:.1} s): the tool stays above the skin",
                need(nominal(&PRESS))
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_trajectory_is_the_script_at_nominal_pace() {
        let shipped = include_str!("../../config/trajectories/demo_press_pull.csv");
        assert_eq!(DemoScript::for_run(NOMINAL_S + OVERHEAD_S).csv, shipped);
    }

    #[test]
    fn nominal_length_is_the_sum_of_the_moves() {
        assert!((NOMINAL_S - nominal(&PRESS) - nominal(&GRASP_PULL)).abs() < 1e-12);
    }

    #[test]
    fn default_run_plays_the_whole_script_at_nominal_pace() {
        let s = DemoScript::for_run(8.5);
        assert!(s.press && s.grasp_pull && s.pace == 1.0, "{s:?}");
        assert!((s.duration_s - NOMINAL_S).abs() < 1e-3);
        assert_eq!(s.skipped(8.5), None);
    }

    #[test]
    fn five_seconds_play_everything_faster() {
        let s = DemoScript::for_run(5.0);
        assert!(s.press && s.grasp_pull, "{s:?}");
        assert!(s.duration_s <= 5.0 - OVERHEAD_S + 1e-9 && s.pace >= MIN_PACE, "{s:?}");
        assert!(s.csv.lines().any(|l| l.ends_with(",1")), "a grasp row:\n{}", s.csv);
    }

    #[test]
    fn short_runs_say_what_they_skip() {
        let s = DemoScript::for_run(3.5);
        assert!(s.press && !s.grasp_pull, "{s:?}");
        assert!(s.skipped(3.5).unwrap().contains("grasp-and-pull"));
        let s = DemoScript::for_run(1.5);
        assert!(!s.press && !s.grasp_pull, "{s:?}");
        assert!(s.skipped(1.5).unwrap().contains("stays above the skin"));
    }
}
