//! The haptic device driver interface: what a force-feedback device must do for Lamina.
//!
//! # Frame and units (CHAI3D's convention)
//! Everything is SI and in the **device frame**: origin at the centre of the device's
//! workspace, **x toward the operator, y to the operator's right, z up** (right-handed).
//! Positions are metres, forces newtons, orientations unit quaternions `[x, y, z, w]` rotating
//! the handle frame into the device frame. The haptics process maps this frame onto the model
//! frame ([`crate::DeviceMapping`]); a device never sees the model.
//!
//! # Implementations
//! - [`NullDevice`]: no device connected; reads a fixed pose, swallows forces. Nothing ever
//!   has to handle "no device".
//! - [`ScriptedDevice`]: replays a push/pull trajectory from a CSV file (the paper's Fig. 12),
//!   recording every force it was sent.
//! - [`SimulatedDevice`]: a handle with mass and damping held by a simulated [`Hand`],
//!   integrating its own dynamics under the commanded force (tests of stability and passivity).
//! - [`PluginDevice`]: a vendor SDK wrapper (Force Dimension, OpenHaptics, libnifalcon) built
//!   as a shared library against `haptics/include/lamina_device.h` and loaded at run time.
//!
//! # Contract
//! `read` samples the handle (call it once per device-loop tick); `write_force` commands the
//! force held until the next call. A device that is unplugged returns
//! [`DeviceError::Disconnected`] from either; the caller stops writing and reports it. Forces
//! reaching `write_force` have already been made finite and clamped to
//! [`DeviceInfo::max_force_n`] by the haptics process; implementations clamp again anyway.
//!
//! # Examples
//!
//! ```
//! use lamina_haptics::device::{HapticDevice, NullDevice};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let mut device = NullDevice::default();
//! let state = device.read()?;
//! assert_eq!(state.position_m, [0.0; 3]);
//! device.write_force([0.0, 0.0, 1.0])?;
//! assert!(device.info().max_force_n > 0.0);
//! # Ok(())
//! # }
//! ```

mod ceiling;
mod error;
mod null;
mod plugin;
mod scripted;
mod simulated;

pub(crate) use ceiling::norm3;
pub use ceiling::{DEVICE_CLASSES, DeviceClass, LimitClamp, UNLISTED, show_number, within_ceilings};
pub use error::DeviceError;
pub use null::NullDevice;
pub use plugin::{DEVICE_ABI_VERSION, PluginDevice};
pub use scripted::{MAX_SCRIPT_S, SCRIPT_REACH_M, ScriptedDevice, Trajectory, TrajectoryPoint};
pub use simulated::{DeviceDynamics, Hand, SIMULATED_SUBSTEP_S, SimulatedDevice};

/// What a device is and what it can safely do.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceInfo {
    /// Human-readable model name, e.g. `"Force Dimension omega.3"`.
    pub name: String,
    /// Largest force the device may be commanded, N (norm of the force vector).
    pub max_force_n: f64,
    /// Largest stiffness the device renders stably, N/m; the haptics process never renders a
    /// stiffer local model.
    pub max_stiffness_n_per_m: f64,
    /// Largest viscous damping the device renders stably, N·s/m.
    pub max_damping_n_s_per_m: f64,
    /// Radius of the sphere (about the origin) the handle can reach, m.
    pub workspace_radius_m: f64,
}

/// One sample of the handle, in the device frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceState {
    /// Handle position, m.
    pub position_m: [f64; 3],
    /// Handle orientation as a unit quaternion `[x, y, z, w]` (identity `[0, 0, 0, 1]`).
    pub orientation: [f64; 4],
    /// Button bit set: bit `i` set means button `i` is pressed.
    pub buttons: u32,
}

impl Default for DeviceState {
    /// At the workspace centre, identity orientation, no buttons.
    fn default() -> Self {
        Self { position_m: [0.0; 3], orientation: [0.0, 0.0, 0.0, 1.0], buttons: 0 }
    }
}

/// A force-feedback device (see the module docs for frame, units and contract).
pub trait HapticDevice: Send {
    /// What the device is and the limits it reports (the haptics process holds them to the
    /// class ceilings of [`within_ceilings`]).
    fn info(&self) -> &DeviceInfo;
    /// Samples the handle.
    fn read(&mut self) -> Result<DeviceState, DeviceError>;
    /// Commands `force_n` (N, device frame) until the next call.
    fn write_force(&mut self, force_n: [f64; 3]) -> Result<(), DeviceError>;
    /// A way to zero the force from another thread while a `read` or `write_force` is blocked,
    /// if the device has one. Default: none.
    fn emergency_stop(&self) -> Option<std::sync::Arc<dyn EmergencyStop>> {
        None
    }
    /// The tool the handle holds as of the last `read`, when the device says so itself (a
    /// trajectory's `kind` column); `None` leaves it to the haptics process (`--tool`). Called
    /// once per tick after `read`; must not block. Default: `None`.
    fn tool_kind(&self) -> Option<lamina_bridge::wire::ToolKind> {
        None
    }
}

/// Zeroes a device's force from any thread, even while another call on the device is in
/// progress (a plugin's `lamina_device_emergency_stop`).
pub trait EmergencyStop: Send + Sync {
    /// Asks the device for zero force now.
    fn zero_force(&self);
}
