//! The scripted device against hand-computed values: interpolation, buttons, held end,
//! malformed files named by line, the preallocated force log, and a pulled cable.

use lamina_haptics::device::{DeviceError, HapticDevice, ScriptedDevice, Trajectory};

const PRESS: &str = "# press\nt_s,x_m,y_m,z_m,buttons\n0,0,0,0.02,0\n\n1.0,0.01,0,-0.01,0\n2.0,0.01,0,-0.01,1\n";

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() < 1e-15)
}

#[test]
fn trajectory_interpolates_and_holds_works() {
    let t = Trajectory::parse(PRESS, "press.csv").unwrap();
    assert_eq!(t.points().len(), 3);
    assert!(close(t.position_at(-1.0), [0.0, 0.0, 0.02]), "held before the start");
    assert!(close(t.position_at(0.25), [0.0025, 0.0, 0.0125]), "a quarter of the way: 0.02 - 0.25 * 0.03");
    assert!(close(t.position_at(1.5), [0.01, 0.0, -0.01]));
    assert!(close(t.position_at(9.0), [0.01, 0.0, -0.01]), "held after the end");
    assert_eq!((t.buttons_at(1.9), t.buttons_at(2.0), t.buttons_at(5.0)), (0, 1, 1));
    assert_eq!(t.duration_s(), 2.0);
    assert!(!t.is_finished(1.99) && t.is_finished(2.0));
}

#[test]
fn trajectory_malformed_names_line_fails() {
    let cases = [
        ("", 0, "empty"),
        ("t,x,y,z\n0,0,0,0\n", 1, "header"),
        ("t_s,x_m,y_m,z_m\n", 1, "no points"),
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1,0,0\n", 3, "3 values"),
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1,0,zero,0\n", 3, "not a number"),
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1,0,NaN,0\n", 3, "not finite"),
        ("t_s,x_m,y_m,z_m\n# c\n0,0,0,0\n0,0,0,1\n", 4, "does not increase"),
        ("t_s,x_m,y_m,z_m,buttons\n0,0,0,0,-1\n", 2, "bit set"),
        // A last time of 1e12 s asked for a 3.2e17-byte trace; 1e300 s never ended.
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1e12,0,0,0\n", 3, "outside 0 to 86400 s"),
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1e300,0,0,0\n", 3, "outside 0 to 86400 s"),
        ("t_s,x_m,y_m,z_m\n-1,0,0,0\n", 2, "outside 0 to 86400 s"),
        // Rows beyond the scripted device's 8 cm reach, up to |z| = 1e308.
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1,0,0,1e308\n", 3, "beyond the scripted device's reach of 0.08 m"),
        ("t_s,x_m,y_m,z_m\n0,0,0,0\n1,0,0,-1e308\n", 3, "1.000e308 m from the workspace centre"),
        ("t_s,x_m,y_m,z_m\n0,0.06,0.06,0\n", 2, "beyond the scripted device's reach of 0.08 m"),
    ];
    for (text, line, what) in cases {
        match Trajectory::parse(text, "bad.csv") {
            Err(e @ DeviceError::Script { .. }) => {
                let DeviceError::Script { file, line: l, what: w } = &e else { unreachable!() };
                assert_eq!((file.as_str(), *l), ("bad.csv", line), "{text:?}: {e}");
                assert!(w.contains(what), "{text:?}: '{w}' should say '{what}'");
                assert!(e.to_string().starts_with("bad.csv"), "{e}");
            }
            other => panic!("{text:?}: expected a script error, got {other:?}"),
        }
    }
    // A row at the reach itself, 8 cm along an axis, is accepted.
    assert!(Trajectory::parse("t_s,x_m,y_m,z_m\n0,0,0,0.08\n1,0,-0.08,0\n", "edge.csv").is_ok());
    let missing = Trajectory::load(std::path::Path::new("/nonexistent/press.csv")).unwrap_err();
    assert!(missing.to_string().contains("/nonexistent/press.csv"), "{missing}");
}

#[test]
fn scripted_device_replays_and_logs_forces_works() {
    let t = Trajectory::parse(PRESS, "press.csv").unwrap();
    let mut d = ScriptedDevice::new(t, ScriptedDevice::default_info(), 2);
    d.set_time_s(0.5);
    let s = d.read().unwrap();
    assert!(close(s.position_m, [0.005, 0.0, 0.005]));
    assert_eq!((s.buttons, s.orientation), (0, [0.0, 0.0, 0.0, 1.0]));
    d.write_force([0.0, 0.0, 1.0]).unwrap();
    d.set_time_s(2.5);
    assert_eq!(d.read().unwrap().buttons, 1);
    d.write_force([0.0, 0.0, 2.0]).unwrap();
    d.write_force([0.0, 0.0, 3.0]).unwrap();
    assert_eq!(d.forces(), &[(0.5, [0.0, 0.0, 1.0]), (2.5, [0.0, 0.0, 2.0])]);
    assert_eq!(d.dropped_forces(), 1, "the log keeps its capacity; the rest is counted");
}

#[test]
fn scripted_device_disconnect_fails() {
    let t = Trajectory::parse(PRESS, "press.csv").unwrap();
    let mut d = ScriptedDevice::new(t, ScriptedDevice::default_info(), 0);
    d.disconnect_after(1.0);
    d.set_time_s(0.9);
    assert!(d.read().is_ok());
    d.set_time_s(1.0);
    assert!(matches!(d.read(), Err(DeviceError::Disconnected { .. })));
    assert!(matches!(d.write_force([0.0; 3]), Err(DeviceError::Disconnected { .. })));
}
