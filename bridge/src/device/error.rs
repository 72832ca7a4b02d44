//! Why a device call failed (temporary minimal version; replaced by the device work).

/// Why a device call failed.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceError {
    /// The device vanished mid-run.
    Disconnected {
        /// What the driver said.
        detail: String,
    },
}

impl core::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Disconnected { detail } => write!(f, "haptic device disconnected: {detail}"),
        }
    }
}

impl core::error::Error for DeviceError {}
