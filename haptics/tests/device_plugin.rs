//! The C plugin ABI end to end: `haptics/plugins/sim_device.c` is compiled here with the
//! system C compiler against `haptics/include/lamina_device.h` (proving the header builds in
//! plain C), loaded with `PluginDevice`, and driven. The simulated handle is a 0.1 kg mass on a
//! 50 N/m spring to the origin, stepped 1 ms per read, so a constant force F settles it at F/k.

mod common;

use common::{build_plugin, plugin};
use lamina_haptics::device::{DEVICE_ABI_VERSION, DeviceError, HapticDevice, PluginDevice, within_ceilings};
use std::path::Path;
use std::process::Command;

/// The simulated handle's spring, N/m (sim_device.c's SIM_SPRING).
const SPRING: f64 = 50.0;

/// Reads `n` times with `force` held, returns the last position.
fn settle(d: &mut PluginDevice, force: [f64; 3], n: usize) -> [f64; 3] {
    d.write_force(force).unwrap();
    let mut x = [0.0; 3];
    for _ in 0..n {
        x = d.read().unwrap().position_m;
    }
    x
}

#[test]
fn plugin_loads_and_reports_limits_works() {
    let d = PluginDevice::load(plugin(), "").unwrap();
    let i = d.info();
    assert_eq!(i.name, "lamina simulated device");
    assert_eq!((i.max_force_n, i.max_stiffness_n_per_m, i.max_damping_n_s_per_m), (8.0, 2500.0, 15.0));
    assert_eq!(DEVICE_ABI_VERSION, 1);
}

#[test]
fn plugin_force_moves_handle_to_f_over_k_works() {
    let mut d = PluginDevice::load(plugin(), "").unwrap();
    let s = d.read().unwrap();
    assert_eq!(s.position_m, [0.0; 3]);
    assert_eq!(s.orientation, [0.0, 0.0, 0.0, 1.0]);
    // 1 N along +y settles at 1/50 m (3 s simulated; the spring-damper decays in ~0.2 s).
    let x = settle(&mut d, [0.0, 1.0, 0.0], 3000);
    assert!((x[1] - 1.0 / SPRING).abs() < 1e-6 && x[0].abs() < 1e-12, "{x:?}");
    // 100 N is clamped to the device's 8 N on the way in: 8/50 m.
    let x = settle(&mut d, [0.0, 100.0, 0.0], 3000);
    assert!((x[1] - 8.0 / SPRING).abs() < 1e-6, "{x:?}");
    // A NaN force is sent as zero: back to the origin.
    let x = settle(&mut d, [f64::NAN, 1.0, 0.0], 3000);
    assert!(x[1].abs() < 1e-6, "{x:?}");
}

#[test]
fn plugin_abi_mismatch_fails() {
    let bad = build_plugin("bad_abi", &["-DLAMINA_SIM_BAD_ABI"]);
    match PluginDevice::load(&bad, "") {
        Err(e @ DeviceError::PluginAbi { found: 2, expected: 1, .. }) => {
            assert!(e.to_string().contains("lamina_device.h"), "{e}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn plugin_missing_symbol_or_library_fails() {
    let no_close = build_plugin("no_close", &["-DLAMINA_SIM_NO_CLOSE"]);
    match PluginDevice::load(&no_close, "") {
        Err(DeviceError::PluginLoad { detail, .. }) => assert!(detail.contains("lamina_device_close"), "{detail}"),
        other => panic!("{other:?}"),
    }
    let missing = Path::new("/nonexistent/libvendor.so");
    match PluginDevice::load(missing, "") {
        Err(e @ DeviceError::PluginLoad { .. }) => assert!(e.to_string().contains("/nonexistent/libvendor.so"), "{e}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn plugin_open_failure_carries_its_message_fails() {
    match PluginDevice::load(plugin(), "fail_open") {
        Err(DeviceError::PluginOpen { detail, .. }) => assert!(detail.contains("no device on the USB bus"), "{detail}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn plugin_disconnect_is_reported_fails() {
    let mut d = PluginDevice::load(plugin(), "disconnect_after=5").unwrap();
    for _ in 0..5 {
        d.read().unwrap();
    }
    match d.read() {
        Err(DeviceError::Disconnected { detail }) => assert!(detail.contains("cable pulled"), "{detail}"),
        other => panic!("{other:?}"),
    }
    assert!(matches!(d.write_force([0.0; 3]), Err(DeviceError::Disconnected { .. })));
}

#[test]
fn haptics_process_with_vanishing_plugin_exits_with_clear_error_fails() {
    let out = Command::new(env!("CARGO_BIN_EXE_lamina-haptics"))
        .args(["--prefix", &format!("t_plugin_{}", std::process::id()), "--fifo", "0", "--quiet", "--seconds", "5"])
        .arg("--device")
        .arg(format!("plugin:{}", plugin().display()))
        .args(["--device-args", "disconnect_after=400"])
        // No core runs here: the mapping is given instead of waited for.
        .args(["--origin", "0,0,0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("cable pulled") && err.contains("Force set to zero"), "{err}");
    // A plugin that cannot open is refused at start (exit 2), naming the library.
    let out = Command::new(env!("CARGO_BIN_EXE_lamina-haptics"))
        .args(["--prefix", &format!("t_plugin2_{}", std::process::id()), "--fifo", "0", "--seconds", "1"])
        .arg("--device")
        .arg(format!("plugin:{}", plugin().display()))
        .args(["--device-args", "fail_open"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("libsim_ok.so") && err.contains("no device on the USB bus"), "{err}");
}

#[test]
fn haptics_process_without_core_or_origin_names_the_prefix_fails() {
    let prefix = format!("t_nocore_{}", std::process::id());
    let out = Command::new(env!("CARGO_BIN_EXE_lamina-haptics"))
        .args(["--prefix", &prefix, "--fifo", "0", "--quiet", "--seconds", "5", "--wait-core-s", "0.5"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("no Lamina core published its model on prefix '{prefix}'")), "{err}");
    assert!(err.contains("--origin"), "says how to run without a core: {err}");
    let out = Command::new(env!("CARGO_BIN_EXE_lamina-haptics"))
        .args(["--prefix", &prefix, "--fifo", "0", "--quiet", "--wait-core-s", "nan"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--wait-core-s"), "{err}");
}

#[test]
fn plugin_reporting_huge_limits_is_held_to_its_class_ceiling_works() {
    let mut d = PluginDevice::load(plugin(), "huge_limits").unwrap();
    assert_eq!(d.info().max_force_n, 1e308, "the plugin's own report is kept for the record");
    let (held, clamps) = within_ceilings(d.info());
    // "lamina simulated device" is in no listed class: the unlisted ceilings hold.
    assert_eq!((held.max_force_n, held.max_stiffness_n_per_m, held.max_damping_n_s_per_m), (12.0, 5000.0, 30.0));
    let named: Vec<String> = clamps.iter().map(ToString::to_string).collect();
    assert_eq!(named.len(), 3, "{named:?}");
    assert!(named[0].contains("max force 1e308 N reported") && named[0].contains("12 N used"), "{named:?}");
    // A 1e308 N command (its square overflows) reaches the device as the 12 N ceiling: 12/50 m.
    let x = settle(&mut d, [0.0, 1e308, 0.0], 3000);
    assert!((x[1] - 12.0 / SPRING).abs() < 1e-6, "{x:?}");
}

#[test]
fn plugin_with_an_empty_path_is_refused_naming_it_fails() {
    match PluginDevice::load(Path::new(""), "") {
        Err(DeviceError::PluginLoad { detail, .. }) => assert!(detail.contains("no library path"), "{detail}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn plugin_emergency_stop_zeroes_the_force_from_another_thread_works() {
    let mut d = PluginDevice::load(plugin(), "").unwrap();
    let x = settle(&mut d, [0.0, 2.0, 0.0], 3000);
    assert!((x[1] - 2.0 / SPRING).abs() < 1e-6, "{x:?}");
    let stop = d.emergency_stop().expect("the test plugin has lamina_device_emergency_stop");
    std::thread::spawn(move || stop.zero_force()).join().unwrap();
    // No force written since: the handle goes back to its spring's rest, the origin.
    let mut x = [1.0; 3];
    for _ in 0..3000 {
        x = d.read().unwrap().position_m;
    }
    assert!(x[1].abs() < 1e-6, "{x:?}");
}
