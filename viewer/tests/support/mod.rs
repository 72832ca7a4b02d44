//! What the viewer's multi-process tests share.

use std::path::PathBuf;
use std::process::Command;

/// The `lamina` binary beside this package's `lamina-viewer`, with `lamina-haptics` beside
/// it: both built (or found up to date) by cargo in the same profile first.
pub fn lamina_bin() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_BIN_EXE_lamina-viewer")).with_file_name("lamina");
    let release = path.parent().is_some_and(|d| d.ends_with("release"));
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.args(["build", "-p", "lamina", "-p", "lamina-haptics", "--bins"]);
    if release {
        cmd.arg("--release");
    }
    assert!(cmd.status().expect("cargo build").success(), "building lamina failed");
    path
}
