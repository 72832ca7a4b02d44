//! A device with mass and damping, held by a simulated hand: the handle integrates its own
//! dynamics under the commanded force (held between writes, a zero-order hold), for tests of
//! stability and passivity against closed forms.

use super::{DeviceError, DeviceInfo, DeviceState, HapticDevice, Trajectory};
use lamina_rt::now_ns;

/// Largest integration sub-step, s (5 µs: fifty per 250 µs device period).
pub const SIMULATED_SUBSTEP_S: f64 = 5e-6;

/// The handle's own dynamics: `m ẍ = F + F_hand − b ẋ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceDynamics {
    /// Effective moving mass at the handle, kg. Default 0.2 (an omega-class device).
    pub mass_kg: f64,
    /// Physical viscous damping (friction, motor back-EMF), N·s/m. Default 0.05.
    pub damping_n_s_per_m: f64,
}

impl Default for DeviceDynamics {
    fn default() -> Self {
        Self { mass_kg: 0.2, damping_n_s_per_m: 0.05 }
    }
}

/// The hand on the handle: a constant push plus a grip, a spring and damper from the handle to
/// where the hand means it to be (a fixed point, or a trajectory).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Hand {
    /// Constant force of the hand, N, device frame. Default 0.
    pub push_n: [f64; 3],
    /// Grip stiffness, N/m (0: no grip). Default 0.
    pub grip_stiffness_n_per_m: f64,
    /// Grip damping on the velocity relative to the anchor, N·s/m. Default 0.
    pub grip_damping_n_s_per_m: f64,
    /// Where the grip pulls the handle, m, device frame: a trajectory over the device's time,
    /// or the origin when `None`. Default `None`.
    pub anchor: Option<Trajectory>,
}

impl Hand {
    fn anchor_at(&self, t_s: f64) -> ([f64; 3], [f64; 3]) {
        match &self.anchor {
            None => ([0.0; 3], [0.0; 3]),
            Some(tr) => {
                let h = 1e-4;
                let (a, b) = (tr.position_at(t_s - h), tr.position_at(t_s + h));
                (tr.position_at(t_s), [0, 1, 2].map(|c| (b[c] - a[c]) / (2.0 * h)))
            }
        }
    }

    /// The hand's force on the handle at `x`, `v` and device time `t_s`, N.
    fn force(&self, x: [f64; 3], v: [f64; 3], t_s: f64) -> [f64; 3] {
        if self.grip_stiffness_n_per_m == 0.0 && self.grip_damping_n_s_per_m == 0.0 {
            return self.push_n;
        }
        let (xa, va) = self.anchor_at(t_s);
        [0, 1, 2].map(|c| {
            self.push_n[c] + self.grip_stiffness_n_per_m * (xa[c] - x[c]) + self.grip_damping_n_s_per_m * (va[c] - v[c])
        })
    }
}

/// Where a simulated device's time comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SimClock {
    /// Integrates up to `CLOCK_MONOTONIC` at each read.
    Monotonic { last_ns: Option<u64> },
    /// Moved only by [`SimulatedDevice::advance`] (deterministic tests).
    Manual,
}

/// A handle of mass `m` with damping `b`, moved by the commanded force (held between writes)
/// and a [`Hand`].
///
/// `read` first integrates the dynamics up to now (the monotonic clock, from the first read;
/// or, after [`manual`](Self::manual), only as far as [`advance`](Self::advance) took it) with
/// classic Runge-Kutta sub-steps of at most [`SIMULATED_SUBSTEP_S`], under the force of the
/// last `write_force`, so a late device tick holds the force longer, as real hardware does.
/// Nothing allocates after construction.
///
/// # Examples
///
/// A 0.2 kg handle pushed by 1 N for 0.1 s with no damping moves `F t² / 2m` = 2.5 cm.
///
/// ```
/// use lamina_haptics::device::{DeviceDynamics, Hand, HapticDevice, SimulatedDevice};
///
/// # fn main() -> Result<(), Box<dyn core::error::Error>> {
/// let dynamics = DeviceDynamics { mass_kg: 0.2, damping_n_s_per_m: 0.0 };
/// let mut d = SimulatedDevice::new(SimulatedDevice::default_info(), dynamics, Hand::default()).manual();
/// d.write_force([0.0, 0.0, 1.0])?;
/// d.advance(0.1);
/// assert!((d.read()?.position_m[2] - 0.025).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct SimulatedDevice {
    info: DeviceInfo,
    dynamics: DeviceDynamics,
    hand: Hand,
    clock: SimClock,
    t_s: f64,
    x: [f64; 3],
    v: [f64; 3],
    force: [f64; 3],
}

impl SimulatedDevice {
    /// The limits it reports: a Force Dimension omega.3's data sheet (12 N continuous,
    /// 14.5 kN/m, the damping ceiling of its class), with the scripted device's 8 cm reach.
    pub fn default_info() -> DeviceInfo {
        DeviceInfo {
            name: "simulated".into(),
            max_force_n: 12.0,
            max_stiffness_n_per_m: 14_500.0,
            max_damping_n_s_per_m: 30.0,
            workspace_radius_m: super::SCRIPT_REACH_M,
        }
    }

    /// A handle at rest at the workspace centre, on the monotonic clock.
    pub fn new(info: DeviceInfo, dynamics: DeviceDynamics, hand: Hand) -> Self {
        Self {
            info,
            dynamics,
            hand,
            clock: SimClock::Monotonic { last_ns: None },
            t_s: 0.0,
            x: [0.0; 3],
            v: [0.0; 3],
            force: [0.0; 3],
        }
    }

    /// Starts at `position_m` (m) with `velocity_m_s` (m/s).
    pub fn starting_at(mut self, position_m: [f64; 3], velocity_m_s: [f64; 3]) -> Self {
        self.x = position_m;
        self.v = velocity_m_s;
        self
    }

    /// Switches to manual time: only [`advance`](Self::advance) moves the handle.
    pub fn manual(mut self) -> Self {
        self.clock = SimClock::Manual;
        self
    }

    /// Integrates `dt_s` seconds under the force last written.
    pub fn advance(&mut self, dt_s: f64) {
        if dt_s.is_nan() || dt_s <= 0.0 {
            return;
        }
        let steps = (dt_s / SIMULATED_SUBSTEP_S).ceil().max(1.0);
        let h = dt_s / steps;
        for _ in 0..steps as u64 {
            self.rk4(h);
        }
    }

    fn accel(&self, x: [f64; 3], v: [f64; 3], t_s: f64) -> [f64; 3] {
        let hand = self.hand.force(x, v, t_s);
        let (m, b) = (self.dynamics.mass_kg, self.dynamics.damping_n_s_per_m);
        [0, 1, 2].map(|c| (self.force[c] + hand[c] - b * v[c]) / m)
    }

    fn rk4(&mut self, h: f64) {
        let (x, v, t) = (self.x, self.v, self.t_s);
        let add = |a: [f64; 3], b: [f64; 3], s: f64| [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]];
        let a1 = self.accel(x, v, t);
        let (x2, v2) = (add(x, v, h / 2.0), add(v, a1, h / 2.0));
        let a2 = self.accel(x2, v2, t + h / 2.0);
        let (x3, v3) = (add(x, v2, h / 2.0), add(v, a2, h / 2.0));
        let a3 = self.accel(x3, v3, t + h / 2.0);
        let (x4, v4) = (add(x, v3, h), add(v, a3, h));
        let a4 = self.accel(x4, v4, t + h);
        for c in 0..3 {
            self.x[c] += h / 6.0 * (v[c] + 2.0 * v2[c] + 2.0 * v3[c] + v4[c]);
            self.v[c] += h / 6.0 * (a1[c] + 2.0 * a2[c] + 2.0 * a3[c] + a4[c]);
        }
        self.t_s += h;
    }

    /// Handle position, m.
    pub fn position(&self) -> [f64; 3] {
        self.x
    }

    /// Handle velocity, m/s.
    pub fn velocity(&self) -> [f64; 3] {
        self.v
    }

    /// Device time, s.
    pub fn time_s(&self) -> f64 {
        self.t_s
    }

    /// The force held now, N.
    pub fn force(&self) -> [f64; 3] {
        self.force
    }
}

impl HapticDevice for SimulatedDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        if let SimClock::Monotonic { last_ns } = &mut self.clock {
            let now = now_ns();
            let dt = last_ns.map_or(0.0, |l| now.saturating_sub(l) as f64 * 1e-9);
            *last_ns = Some(now);
            self.advance(dt);
        }
        Ok(DeviceState { position_m: self.x, ..DeviceState::default() })
    }

    fn write_force(&mut self, force_n: [f64; 3]) -> Result<(), DeviceError> {
        // Clamped again to the device's limit, as hardware does.
        let n = super::norm3(force_n);
        self.force = if n.is_finite() {
            let s = if n > self.info.max_force_n { self.info.max_force_n / n } else { 1.0 };
            force_n.map(|c| c * s)
        } else {
            [0.0; 3]
        };
        Ok(())
    }
}
