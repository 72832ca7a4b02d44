//! Devices in shared libraries built against `haptics/include/lamina_device.h`: a vendor SDK
//! wrapper loads without rebuilding Lamina.

use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{DeviceError, DeviceInfo, DeviceState, EmergencyStop, HapticDevice, norm3, within_ceilings};

/// The ABI version this build of Lamina speaks (`LAMINA_DEVICE_ABI_VERSION`).
pub const DEVICE_ABI_VERSION: u32 = 1;

/// `LaminaDeviceInfo` of the header.
#[repr(C)]
struct RawInfo {
    name: [c_char; 64],
    max_force_n: f64,
    max_stiffness_n_per_m: f64,
    max_damping_n_s_per_m: f64,
    workspace_radius_m: f64,
}

/// `LaminaDeviceState` of the header.
#[repr(C)]
#[derive(Default)]
struct RawState {
    position_m: [f64; 3],
    orientation_xyzw: [f64; 4],
    buttons: u32,
    reserved: u32,
}

type AbiVersionFn = unsafe extern "C" fn() -> u32;
type OpenFn = unsafe extern "C" fn(*const c_char, *mut RawInfo) -> *mut c_void;
type ReadFn = unsafe extern "C" fn(*mut c_void, *mut RawState) -> c_int;
type WriteFn = unsafe extern "C" fn(*mut c_void, *const f64) -> c_int;
type LastErrorFn = unsafe extern "C" fn(*mut c_void) -> *const c_char;
type CloseFn = unsafe extern "C" fn(*mut c_void);

/// `LAMINA_DEVICE_DISCONNECTED`.
const DISCONNECTED: c_int = -1;

type EmergencyStopFn = unsafe extern "C" fn(*mut c_void);

/// The plugin's open device and its functions, shared with the [`EmergencyStop`] handle so
/// that the device is closed (and the library unloaded) only when neither uses it any more.
struct Shared {
    device: *mut c_void,
    read: ReadFn,
    write: WriteFn,
    last_error: LastErrorFn,
    close: CloseFn,
    emergency_stop: Option<EmergencyStopFn>,
    // Last field: dropped after `Drop::drop` closed the device through its functions.
    _library: libloading::Library,
}

// SAFETY: `read`, `write` and `last_error` are called only through `&mut PluginDevice` (one
// thread at a time, as the header requires); the one function called from another thread is
// `lamina_device_emergency_stop`, which the header allows from any thread at any time.
unsafe impl Send for Shared {}
// SAFETY: as above: shared references only ever call `lamina_device_emergency_stop`.
unsafe impl Sync for Shared {}

impl Drop for Shared {
    fn drop(&mut self) {
        // SAFETY: `device` was opened by this plugin and is closed exactly once, before the
        // library is unloaded (the library field drops after this).
        unsafe { (self.close)(self.device) };
    }
}

/// A device driven through a plugin library.
///
/// Opened by [`PluginDevice::load`]; closed (zero force, device released) when it and its
/// emergency-stop handle are dropped.
pub struct PluginDevice {
    info: DeviceInfo,
    /// The force `write_force` never exceeds, N: the reported limit held to the class ceiling.
    force_ceiling_n: f64,
    shared: Arc<Shared>,
    path: PathBuf,
}

impl std::fmt::Debug for PluginDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginDevice").field("path", &self.path).field("info", &self.info).finish()
    }
}

/// A plugin's `lamina_device_emergency_stop`, callable from any thread.
struct PluginEmergencyStop {
    shared: Arc<Shared>,
    stop: EmergencyStopFn,
}

impl EmergencyStop for PluginEmergencyStop {
    fn zero_force(&self) {
        // SAFETY: the device is open while `shared` lives; the header allows this call from
        // any thread, during any other call.
        unsafe { (self.stop)(self.shared.device) };
    }
}

fn symbol<T: Copy>(library: &libloading::Library, name: &str, path: &Path) -> Result<T, DeviceError> {
    // SAFETY: T is one of the function pointer types above, matching the header's prototypes.
    unsafe { library.get::<T>(name.as_bytes()) }.map(|s| *s).map_err(|e| DeviceError::PluginLoad {
        path: path.display().to_string(),
        detail: format!("missing symbol {name}: {e}"),
    })
}

fn c_text(ptr: *const c_char) -> String {
    if ptr.is_null() {
        return "(no message)".into();
    }
    // SAFETY: the header promises a NUL-terminated string valid until the next call.
    unsafe { CStr::from_ptr(ptr) }.to_string_lossy().into_owned()
}

impl PluginDevice {
    /// Loads the plugin at `path`, checks its ABI version, opens the device with `args` and
    /// checks the limits it reports.
    pub fn load(path: &Path, args: &str) -> Result<Self, DeviceError> {
        let load_err = |detail: String| DeviceError::PluginLoad { path: path.display().to_string(), detail };
        if path.as_os_str().is_empty() {
            // An empty name would load the program itself and blame its missing symbols.
            return Err(load_err("no library path given (expected plugin:PATH/TO/LIB.so)".into()));
        }
        // SAFETY: loading a library runs its initialisers; a plugin is trusted code the
        // operator chose to run, as a driver is.
        let library = unsafe { libloading::Library::new(path) }.map_err(|e| load_err(e.to_string()))?;
        let abi: AbiVersionFn = symbol(&library, "lamina_device_abi_version", path)?;
        let open: OpenFn = symbol(&library, "lamina_device_open", path)?;
        let read: ReadFn = symbol(&library, "lamina_device_read", path)?;
        let write: WriteFn = symbol(&library, "lamina_device_write_force", path)?;
        let last_error: LastErrorFn = symbol(&library, "lamina_device_last_error", path)?;
        let close: CloseFn = symbol(&library, "lamina_device_close", path)?;
        // Optional: a plugin without it still loads (its stalls are reported, not stopped).
        let emergency_stop: Option<EmergencyStopFn> = symbol(&library, "lamina_device_emergency_stop", path).ok();
        // SAFETY: a function of the header's prototype, taking no arguments.
        let found = unsafe { abi() };
        if found != DEVICE_ABI_VERSION {
            return Err(DeviceError::PluginAbi {
                path: path.display().to_string(),
                found,
                expected: DEVICE_ABI_VERSION,
            });
        }
        let c_args = CString::new(args).map_err(|_| load_err("device arguments contain a NUL byte".into()))?;
        let mut raw = RawInfo {
            name: [0; 64],
            max_force_n: 0.0,
            max_stiffness_n_per_m: 0.0,
            max_damping_n_s_per_m: 0.0,
            workspace_radius_m: 0.0,
        };
        // SAFETY: both pointers are valid for the call; the plugin fills `raw`.
        let device = unsafe { open(c_args.as_ptr(), &mut raw) };
        if device.is_null() {
            // SAFETY: the header allows NULL to ask for the failed open's message.
            let detail = c_text(unsafe { last_error(std::ptr::null_mut()) });
            return Err(DeviceError::PluginOpen { path: path.display().to_string(), detail });
        }
        let end = raw.name.iter().position(|&c| c == 0).unwrap_or(raw.name.len());
        let name: String = raw.name[..end].iter().map(|&c| c as u8 as char).collect();
        let info = DeviceInfo {
            name: if name.is_empty() { "plugin device".into() } else { name },
            max_force_n: raw.max_force_n,
            max_stiffness_n_per_m: raw.max_stiffness_n_per_m,
            max_damping_n_s_per_m: raw.max_damping_n_s_per_m,
            workspace_radius_m: raw.workspace_radius_m,
        };
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let limits_ok = positive(info.max_force_n)
            && positive(info.max_stiffness_n_per_m)
            && positive(info.workspace_radius_m)
            && info.max_damping_n_s_per_m.is_finite()
            && info.max_damping_n_s_per_m >= 0.0;
        if !limits_ok {
            // SAFETY: the device was opened above and is not used afterwards.
            unsafe { close(device) };
            return Err(DeviceError::PluginOpen {
                path: path.display().to_string(),
                detail: format!(
                    "'{}' reports unusable limits: max force {} N, stiffness {} N/m, damping {} N s/m, workspace {} m",
                    info.name,
                    info.max_force_n,
                    info.max_stiffness_n_per_m,
                    info.max_damping_n_s_per_m,
                    info.workspace_radius_m
                ),
            });
        }
        let force_ceiling_n = within_ceilings(&info).0.max_force_n;
        let shared = Arc::new(Shared { device, read, write, last_error, close, emergency_stop, _library: library });
        Ok(Self { info, force_ceiling_n, shared, path: path.to_path_buf() })
    }

    /// The library the device came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn error_of(&self, code: c_int) -> DeviceError {
        // SAFETY: `device` is open; the message is copied before the next call.
        let detail = c_text(unsafe { (self.shared.last_error)(self.shared.device) });
        if code == DISCONNECTED {
            DeviceError::Disconnected { detail }
        } else {
            DeviceError::Plugin { path: self.path.display().to_string(), code, detail }
        }
    }
}

impl HapticDevice for PluginDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    /// A sample; a non-finite pose is passed on (the haptics loop answers it with zero force
    /// and a logged event rather than ending the session over one glitch).
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        let mut raw = RawState::default();
        // SAFETY: `device` is open and `raw` is valid for writes.
        let code = unsafe { (self.shared.read)(self.shared.device, &mut raw) };
        if code != 0 {
            return Err(self.error_of(code));
        }
        Ok(DeviceState { position_m: raw.position_m, orientation: raw.orientation_xyzw, buttons: raw.buttons })
    }

    fn write_force(&mut self, force_n: [f64; 3]) -> Result<(), DeviceError> {
        // Clamped again here: whatever reaches a plugin is finite and within its reported
        // limit held to its class ceiling.
        let mut f = if force_n.iter().all(|c| c.is_finite()) { force_n } else { [0.0; 3] };
        let norm = norm3(f);
        if norm > self.force_ceiling_n {
            f = f.map(|c| c / norm * self.force_ceiling_n);
        }
        // SAFETY: `device` is open and `f` holds three doubles.
        let code = unsafe { (self.shared.write)(self.shared.device, f.as_ptr()) };
        if code != 0 {
            return Err(self.error_of(code));
        }
        Ok(())
    }

    /// The plugin's `lamina_device_emergency_stop`, when it has one.
    fn emergency_stop(&self) -> Option<Arc<dyn EmergencyStop>> {
        let stop = self.shared.emergency_stop?;
        Some(Arc::new(PluginEmergencyStop { shared: self.shared.clone(), stop }))
    }
}
