//! Why a device call failed.

/// Why a device call failed.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceError {
    /// The device vanished mid-run (unplugged, powered off, driver gone).
    Disconnected {
        /// What the driver said.
        detail: String,
    },
    /// A plugin library could not be loaded, or lacks a function of the ABI.
    PluginLoad {
        /// The library.
        path: String,
        /// What the loader said (names the missing symbol).
        detail: String,
    },
    /// A plugin speaks another ABI version.
    PluginAbi {
        /// The library.
        path: String,
        /// Version the plugin reports.
        found: u32,
        /// Version this Lamina speaks.
        expected: u32,
    },
    /// The plugin could not open its device (or reported unusable limits).
    PluginOpen {
        /// The library.
        path: String,
        /// The plugin's own message.
        detail: String,
    },
    /// A plugin call failed for another reason than a disconnection.
    Plugin {
        /// The library.
        path: String,
        /// The return code.
        code: i32,
        /// The plugin's own message.
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
            Self::PluginLoad { path, detail } => write!(f, "device plugin {path}: cannot load: {detail}"),
            Self::PluginAbi { path, found, expected } => write!(
                f,
                "device plugin {path}: ABI version {found}, this Lamina speaks {expected} (rebuild it against haptics/include/lamina_device.h)"
            ),
            Self::PluginOpen { path, detail } => write!(f, "device plugin {path}: could not open the device: {detail}"),
            Self::Plugin { path, code, detail } => write!(f, "device plugin {path}: call failed ({code}): {detail}"),
            Self::Script { file, line: 0, what } => write!(f, "{file}: {what}"),
            Self::Script { file, line, what } => write!(f, "{file}:{line}: {what}"),
        }
    }
}

impl core::error::Error for DeviceError {}
