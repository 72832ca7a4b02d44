//! Detecting bad state: non-finite numbers, or speeds and displacements no tissue shows.
//! Bad state is data, not an error: the simulation rolls back and records a [`GuardEvent`].

use super::dynamics::State;
use super::effects::GuardSettings;
use super::vec3s::Vec3s;
use crate::real::Real;
use std::fmt;

/// What was wrong with a state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuardReason {
    /// A position or velocity was NaN or infinite.
    NonFinite,
    /// A node moved faster than `max_speed`.
    TooFast,
    /// A node moved further than `max_displacement` from rest.
    TooFar,
}

/// How the frame was saved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recovery {
    /// Rolled back and re-stepped with this many sub-steps.
    Substeps(u32),
    /// Rolled back and re-stepped with implicit Euler.
    Implicit,
    /// Rolled back to the last good state with velocities zeroed: the frame did not advance.
    Frozen,
}

/// One rollback: what was found, where, and how the frame was saved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuardEvent {
    /// Simulated time at the start of the frame, s.
    pub time: f64,
    /// First problem found.
    pub reason: GuardReason,
    /// Node where it was found.
    pub node: u32,
    /// What the guard did.
    pub recovery: Recovery,
}

impl fmt::Display for GuardEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "t={:.6} s node {}: {:?}, recovered by {:?}", self.time, self.node, self.reason, self.recovery)
    }
}

/// First problem in `state` under `settings`, with the node, or `None` for a good state.
///
/// A fast vectorisable pass computes Σ(|v|² + |u|²) (NaN and infinity propagate) and the
/// largest of `|v|²/v_max²` and `|u|²/u_max²`; only a bad state is scanned node by node.
pub fn inspect_state<T: Real>(
    state: &State<T>,
    rest: &Vec3s<T>,
    settings: &GuardSettings,
) -> Option<(GuardReason, u32)> {
    let iv = T::from_f64(1.0 / (settings.max_speed * settings.max_speed));
    let id = T::from_f64(1.0 / (settings.max_displacement * settings.max_displacement));
    let (x, v) = (&state.x, &state.v);
    let n = x.len();
    let mut sum = T::ZERO;
    let mut worst = T::ZERO;
    for i in 0..n {
        let (dx, dy, dz) = (x.x[i] - rest.x[i], x.y[i] - rest.y[i], x.z[i] - rest.z[i]);
        let v2 = v.x[i] * v.x[i] + v.y[i] * v.y[i] + v.z[i] * v.z[i];
        let d2 = dx * dx + dy * dy + dz * dz;
        sum += v2 + d2;
        worst = worst.max((v2 * iv).max(d2 * id));
    }
    if sum.is_finite() && worst <= T::ONE {
        return None;
    }
    let v2max = settings.max_speed * settings.max_speed;
    let d2max = settings.max_displacement * settings.max_displacement;
    for i in 0..n {
        let (p, q, r) = (x.get_f64(i), v.get_f64(i), rest.get_f64(i));
        let v2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
        let d2 = (p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2);
        if !(v2.is_finite() && d2.is_finite()) {
            return Some((GuardReason::NonFinite, i as u32));
        }
        if v2 > v2max {
            return Some((GuardReason::TooFast, i as u32));
        }
        if d2 > d2max {
            return Some((GuardReason::TooFar, i as u32));
        }
    }
    // Only f32 round-off can get here (the f64 rescan found nothing): call it good.
    None
}
