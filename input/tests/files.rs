//! Only regular files within their cap are read; everything else is refused by its
//! metadata, before a byte is read, with a message naming the file and what it is.

use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;

use lamina_input::{FileLimit, FileReadError, read_bytes, read_text};

const SMALL: FileLimit = FileLimit::new("test file", 100);

#[test]
fn regular_file_within_cap_works() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.txt");
    std::fs::write(&path, "line 1\nline 2\n").unwrap();
    assert_eq!(read_text(&path, &SMALL).unwrap(), "line 1\nline 2\n");
    // Exactly at the cap is accepted.
    std::fs::write(&path, [b'x'; 100]).unwrap();
    assert_eq!(read_bytes(&path, &SMALL).unwrap().len(), 100);
}

#[test]
fn file_over_cap_fails() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.txt");
    std::fs::write(&path, [b'x'; 101]).unwrap();
    let e = read_bytes(&path, &SMALL).unwrap_err();
    assert!(matches!(e, FileReadError::TooLarge { bytes: 101, max_bytes: 100, .. }), "{e}");
    let text = e.to_string();
    assert!(text.starts_with(&format!("{}: ", path.display())), "{text}");
    assert!(text.contains("101 bytes is larger than a test file may be (at most 100 bytes)"), "{text}");
}

#[test]
fn fifo_is_refused_without_blocking_fails() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pipe.stl");
    let c = CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    // No writer ever opens the FIFO: reading it would block forever.
    let e = read_bytes(&path, &SMALL).unwrap_err();
    assert!(matches!(e, FileReadError::NotRegular { kind: "a FIFO (named pipe)", .. }), "{e}");
    assert!(e.to_string().contains("pipe.stl: is a FIFO (named pipe), not a regular file"), "{e}");
}

#[test]
fn devices_and_directories_are_refused_fails() {
    for (path, kind) in [
        ("/dev/zero", "a character device"),
        ("/dev/urandom", "a character device"),
        ("/dev/null", "a character device"),
        ("/", "a directory"),
    ] {
        let e = read_bytes(path, &SMALL).unwrap_err();
        assert!(matches!(e, FileReadError::NotRegular { kind: k, .. } if k == kind), "{path}: {e}");
    }
}

#[test]
fn missing_file_names_it_fails() {
    let e = read_bytes("/nonexistent/x.obj", &SMALL).unwrap_err();
    assert!(matches!(e, FileReadError::Io { .. }), "{e}");
    assert!(e.to_string().starts_with("/nonexistent/x.obj: "), "{e}");
}

#[test]
fn not_utf8_names_its_line_fails() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.toml");
    std::fs::write(&path, b"a = 1\nb = 2\nc = \"\xff\"\n").unwrap();
    let e = read_text(&path, &SMALL).unwrap_err();
    assert!(matches!(e, FileReadError::NotUtf8 { line: 3, .. }), "{e}");
    assert_eq!(e.to_string(), format!("{}:3: not UTF-8 text", path.display()));
}
