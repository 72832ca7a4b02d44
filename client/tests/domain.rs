//! The library comes first: with no core and no domain folder yet, `lamina_open` creates the
//! user's domain folder with mode 0700 (as the core needs it), and refuses one that lets the
//! group in (mode 0750, as iceoryx2 itself would create it) with a message naming the mode.
//!
//! One test in its own binary: it sets `LAMINA_IPC_DIR` for the whole process.

use core::ffi::CStr;
use std::os::unix::fs::PermissionsExt;

use lamina_client::*;

fn message() -> String {
    // SAFETY: a NUL-terminated string valid until the next failing call on this thread.
    unsafe { CStr::from_ptr(lamina_last_error_message()) }.to_string_lossy().into_owned()
}

fn open(prefix: &core::ffi::CStr) -> LaminaStatus {
    let mut client = 0;
    // SAFETY: a NUL-terminated prefix and a valid out pointer.
    unsafe { lamina_open(prefix.as_ptr(), 50, &mut client) }
}

#[test]
fn a_client_first_creates_the_domain_folder_0700_and_refuses_an_open_one_works() {
    let dir = std::env::temp_dir().join(lamina_tests::unique_prefix("client_domain"));
    assert!(!dir.exists());
    // SAFETY: this binary's only test sets the variable before any other thread reads it.
    unsafe { std::env::set_var("LAMINA_IPC_DIR", &dir) };

    assert_eq!(open(c"t_client_domain"), LaminaStatus::Timeout, "{}", message());
    let mode = std::fs::metadata(&dir).expect("the folder was created").permissions().mode() & 0o7777;
    assert_eq!(mode, 0o700, "created {mode:04o}");

    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o750)).unwrap();
    assert_eq!(open(c"t_client_domain"), LaminaStatus::Connect);
    let text = message();
    assert!(text.contains("mode 0750 lets other users in; the iceoryx2 domain must be 0700"), "{text}");
    assert!(text.contains(&dir.display().to_string()), "the folder is named: {text}");

    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}
