//! The device used when none is connected.

use super::{DeviceError, DeviceInfo, DeviceState, HapticDevice};

/// No device: a fixed pose at the origin; forces are swallowed.
#[derive(Debug, Clone)]
pub struct NullDevice {
    info: DeviceInfo,
}

impl Default for NullDevice {
    fn default() -> Self {
        Self {
            info: DeviceInfo {
                name: "null".into(),
                max_force_n: 12.0,
                max_stiffness_n_per_m: 3000.0,
                max_damping_n_s_per_m: 20.0,
                workspace_radius_m: 0.08,
            },
        }
    }
}

impl HapticDevice for NullDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        Ok(DeviceState::default())
    }
    fn write_force(&mut self, _force_n: [f64; 3]) -> Result<(), DeviceError> {
        Ok(())
    }
}
