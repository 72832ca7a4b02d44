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
pub fn inspect_state<T: Real>(
    state: &State<T>,
    rest: &Vec3s<T>,
    settings: &GuardSettings,
) -> Option<(GuardReason, u32)> {
    let v2max = settings.max_speed * settings.max_speed;
    let d2max = settings.max_displacement * settings.max_displacement;
    for i in 0..state.x.len() {
        let (x, v, r) = (state.x.get(i), state.v.get(i), rest.get(i));
        let mut v2 = 0.0f64;
        let mut d2 = 0.0f64;
        for c in 0..3 {
            let (xc, vc) = (x[c].to_f64(), v[c].to_f64());
            v2 += vc * vc;
            let d = xc - r[c].to_f64();
            d2 += d * d;
        }
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
    None
}
