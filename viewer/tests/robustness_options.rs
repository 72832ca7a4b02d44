//! Option values of `lamina-viewer` outside their bounds are refused before anything starts,
//! naming the option, the value and the bound (NaN was clamped or never reached before).

use std::process::Command;

fn refused(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_lamina-viewer"))
        .args(["--headless", "--synthetic", "--frames", "1"])
        .args(args)
        .output()
        .expect("lamina-viewer starts");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?} is a usage error: {err}");
    err
}

#[test]
fn robustness_viewer_phi_and_wait_limit_outside_their_bounds_fail() {
    for phi in ["nan", "inf", "0", "0.05", "-10", "181", "1e300"] {
        let err = refused(&[&format!("--phi-deg={phi}")]);
        assert!(err.contains(&format!("'{phi}' for '--phi-deg")), "{err}");
        assert!(err.contains("φ must be from 0.1 to 180 degrees"), "{err}");
    }
    for wait in ["nan", "inf", "0", "-1", "1e300"] {
        let err = refused(&[&format!("--wait-limit-s={wait}")]);
        assert!(err.contains(&format!("'{wait}' for '--wait-limit-s")), "{err}");
        assert!(err.contains("must be a number of seconds above 0 and at most 1e9"), "{err}");
    }
}
