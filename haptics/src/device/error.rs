//! Why a device call failed.

/// Why a device call failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DeviceError {
    /// The device vanished mid-run (unplugged, powered off, driver gone).
    #[error("haptic device disconnected: {detail}")]
    Disconnected {
        /// What the driver said.
        detail: String,
    },
    /// A plugin library could not be loaded, or lacks a function of the ABI.
    #[error("device plugin {path}: cannot load: {detail}")]
    PluginLoad {
        /// The library.
        path: String,
        /// What the loader said (names the missing symbol).
        detail: String,
    },
    /// A plugin speaks another ABI version.
    #[error(
        "device plugin {path}: ABI version {found}, this Lamina speaks {expected} (rebuild it against haptics/include/lamina_device.h)"
    )]
    PluginAbi {
        /// The library.
        path: String,
        /// Version the plugin reports.
        found: u32,
        /// Version this Lamina speaks.
        expected: u32,
    },
    /// The plugin could not open its device (or reported unusable limits).
    #[error("device plugin {path}: could not open the device: {detail}")]
    PluginOpen {
        /// The library.
        path: String,
        /// The plugin's own message.
        detail: String,
    },
    /// A plugin call failed for another reason than a disconnection.
    #[error("device plugin {path}: call failed ({code}): {detail}")]
    Plugin {
        /// The library.
        path: String,
        /// The return code.
        code: i32,
        /// The plugin's own message.
        detail: String,
    },
    /// A trajectory file is malformed.
    #[error("{file}{}: {what}", if *.line == 0 { String::new() } else { format!(":{}", .line) })]
    Script {
        /// The file.
        file: String,
        /// 1-based line (0: the whole file).
        line: usize,
        /// What is wrong.
        what: String,
    },
}
