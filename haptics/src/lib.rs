//! Lamina's haptics process (`lamina-haptics`) as a library: the device driver interface, the
//! force renderer and the device loop. It talks to the core only through `lamina-bridge`'s
//! `tool` and `feedback` services. A device loop at 1-4 kHz sends the handle's pose to the
//! core and renders force locally from the core's latest contact model, so that a late core
//! tick never makes the device unstable, and never hurts the hand holding it.
//!
//! # How it fits together
//! 1. [`DeviceMapping`] places the device frame (CHAI3D convention, see [`crate::device`]) in
//!    the model frame.
//! 2. [`ForceRenderer`] turns the newest `feedback` message (force and local stiffness) into a
//!    force at the handle's current position, with stiffness and force limits, unilateral
//!    contact, coupling damping, and a fade to zero when the core goes quiet.
//! 3. [`run_device_loop`] runs it on absolute deadlines with a deadline monitor, and measures
//!    core-to-device latency.
//! 4. [`PassivityObserver`] books the energy the commanded force gives the hand (Hannaford
//!    and Ryu's time-domain passivity observer) and damps whatever the rendering would
//!    create.
//! 5. [`SafetyEvent`]s leave the loop over a bounded channel to be logged elsewhere.
//! 6. Whatever a device reports, its limits are held to the ceilings of its class
//!    ([`device::within_ceilings`]); a pose beyond its workspace and a device call longer than
//!    [`watchdog::DEVICE_CALL_LIMIT_NS`] are faults that take the force to zero.
//!
//! Vendor devices plug in as shared libraries built against the C header
//! `haptics/include/lamina_device.h` (example: `haptics/plugins/sim_device.c`), loaded by
//! [`device::PluginDevice`].
//!
//! Architecture invariant: the haptics process knows nothing of the physics. It sees a tool
//! pose, a force and a stiffness.

pub mod core_model;
pub mod device;
mod device_loop;
mod mapping;
mod passivity;
mod renderer;
pub mod run_context;
mod safety;
pub mod watchdog;

pub use device_loop::{HapticsConfig, HapticsReport, HapticsStartError, TraceRow, check_force_cap, run_device_loop};
pub use mapping::DeviceMapping;
pub use passivity::{PassivityFigures, PassivityObserver};
pub use renderer::{ForceRenderer, RenderLimits, RenderedForce};
pub use safety::{SafetyCounts, SafetyEvent, SafetyEventKind};
