//! Why a device call failed.

/// Why a device call failed.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceError {
    /// The device vanished mid-run (unplugged, powered off, driver gone).
    Disconnected {
        /// What the driver said.
        detail: String,
    },
    /// A trajectory file is malformed.
    Script {
        /// The file.
        file: String,
        /// 1-based line (0: the whole file).
        line: usize,
        /// What is wrong.
        what: String,
    },
}

impl core::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Disconnected { detail } => write!(f, "haptic device disconnected: {detail}"),
            Self::Script { file, line: 0, what } => write!(f, "{file}: {what}"),
            Self::Script { file, line, what } => write!(f, "{file}:{line}: {what}"),
        }
    }
}

impl core::error::Error for DeviceError {}
