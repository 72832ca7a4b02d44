//! Two users on one host: root's core and an unprivileged user's core run side by side on the
//! same service prefix, each in its own iceoryx2 domain, and the other user can neither list
//! root's domain nor open root's shared memory. Needs root and `setpriv` (util-linux) to run a
//! process as another uid; skipped with a message otherwise.

use lamina_tests::{unique_prefix, wait_with_watchdog, workspace_bin};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// A uid no account uses here: the test's "other user".
const OTHER_UID: u32 = 64_321;

fn setpriv() -> Option<PathBuf> {
    ["/usr/bin/setpriv", "/bin/setpriv"].iter().map(PathBuf::from).find(|p| p.exists())
}

/// `program args...` run as OTHER_UID (no supplementary groups), with /tmp as its TMPDIR.
fn as_other(setpriv: &Path, program: &Path, args: &[&str]) -> Command {
    let mut cmd = Command::new(setpriv);
    cmd.arg(format!("--reuid={OTHER_UID}"))
        .arg(format!("--regid={OTHER_UID}"))
        .arg("--clear-groups")
        .arg("--")
        .arg(program)
        .args(args)
        .env("TMPDIR", "/tmp")
        .env_remove("LAMINA_IPC_DIR");
    cmd
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

#[test]
fn users_run_side_by_side_in_private_domains_works() {
    // SAFETY: geteuid cannot fail.
    if unsafe { libc::geteuid() } != 0 {
        println!("skipped: running a process as a second user needs root");
        return;
    }
    let Some(setpriv) = setpriv() else {
        println!("skipped: setpriv (util-linux) is not installed");
        return;
    };
    // A copy of `lamina` the other user can execute whatever the build directory's mode.
    let bin_dir = std::env::temp_dir().join(unique_prefix("users_bin"));
    std::fs::create_dir_all(&bin_dir).unwrap();
    std::fs::set_permissions(&bin_dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    let lamina = bin_dir.join("lamina");
    std::fs::copy(workspace_bin("lamina"), &lamina).unwrap();
    std::fs::set_permissions(&lamina, std::fs::Permissions::from_mode(0o755)).unwrap();
    let other_domain = PathBuf::from(format!("/tmp/lamina-{OTHER_UID}"));
    let _ = std::fs::remove_dir_all(&other_domain);

    let prefix = unique_prefix("users");
    let mut root_core = Command::new(&lamina)
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "4"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting root's core");
    std::thread::sleep(Duration::from_millis(800));
    let mut other_core = as_other(&setpriv, &lamina, &["run", "--quiet", "--prefix", &prefix, "--seconds", "2"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting the other user's core");
    std::thread::sleep(Duration::from_millis(500));

    // While both run: the other user cannot see into root's domain or its shared memory.
    let root_domain = lamina_bridge::UserDomain::current();
    let root_shm: Vec<PathBuf> = std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with(&root_domain.file_prefix))
        .collect();
    assert!(!root_shm.is_empty(), "root's core has shared memory in /dev/shm");
    let probe = format!(
        "ls {} >/dev/null 2>&1 && echo LISTED; for f in {}; do [ -r \"$f\" ] && echo READ $f; [ -w \"$f\" ] && echo WROTE $f; done; true",
        root_domain.root.display(),
        root_shm.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" ")
    );
    let probed = as_other(&setpriv, Path::new("/bin/sh"), &["-c", &probe]).output().unwrap();
    assert!(probed.status.success(), "{}", text(&probed));
    assert_eq!(text(&probed), "", "the other user got into root's domain");

    let status = wait_with_watchdog(&mut other_core, Duration::from_secs(60), "the other user's core");
    let other = other_core.wait_with_output().unwrap();
    assert!(status.success(), "the other user's core failed beside root's: {}", text(&other));
    assert!(text(&other).contains("published "), "{}", text(&other));
    let status = wait_with_watchdog(&mut root_core, Duration::from_secs(60), "root's core");
    let root = root_core.wait_with_output().unwrap();
    assert!(status.success(), "root's core: {}", text(&root));

    // The other user's domain is theirs alone.
    let meta = std::fs::symlink_metadata(&other_domain).unwrap();
    assert_eq!((meta.uid(), meta.mode() & 0o777), (OTHER_UID, 0o700));
    let _ = std::fs::remove_dir_all(&other_domain);
    let _ = std::fs::remove_dir_all(&bin_dir);
}
