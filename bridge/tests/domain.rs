//! Each user's iceoryx2 domain and one node-frame publisher per prefix.

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::PathBuf;

use lamina_bridge::domain::effective_uid;
use lamina_bridge::{
    Bridge, BridgeConfig, DomainError, NodesPublisher, NodesPublisherCreateError, PrefixLockError, UserDomain,
};

fn unique(tag: &str) -> String {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    format!("t_{tag}_{}_{nanos}", std::process::id())
}

#[test]
fn prefix_second_publisher_is_refused_works() {
    let prefix = unique("second");
    let first_bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let first = NodesPublisher::create(&first_bridge, 10).unwrap();
    let second_bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let e = NodesPublisher::create(&second_bridge, 10).unwrap_err();
    let NodesPublisherCreateError::PrefixInUse(PrefixLockError::InUse { prefix: p, holder_pid, lock }) = &e else {
        panic!("expected the prefix to be in use, got {e}")
    };
    assert_eq!((p.as_str(), *holder_pid), (prefix.as_str(), Some(std::process::id())));
    assert!(lock.starts_with(&first_bridge.domain().root));
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("prefix '{prefix}' is live: another process (pid {})", std::process::id())),
        "{text}"
    );
    // Another prefix is free, and the prefix is free again once the first publisher is gone.
    let other = Bridge::open(&BridgeConfig::with_prefix(&unique("other"))).unwrap();
    assert!(NodesPublisher::create(&other, 10).is_ok());
    drop(first);
    assert!(NodesPublisher::create(&second_bridge, 10).is_ok());
}

#[test]
fn domain_is_private_to_the_user_works() {
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&unique("private"))).unwrap();
    let domain = bridge.domain();
    let uid = effective_uid();
    assert_eq!(domain.file_prefix, format!("iox2_lamina_u{uid}_"));
    let meta = std::fs::metadata(&domain.root).unwrap();
    assert_eq!((meta.uid(), meta.mode() & 0o777), (uid, 0o700));
    // The management segment iceoryx2 creates world-writable is this user's alone.
    let mgmt: Vec<PathBuf> = std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            name.starts_with(&domain.file_prefix) && name.ends_with(".global_mgmt")
        })
        .collect();
    assert_eq!(mgmt.len(), 1, "{mgmt:?}");
    let meta = std::fs::metadata(&mgmt[0]).unwrap();
    assert_eq!((meta.uid(), meta.mode() & 0o777), (uid, 0o600), "{}", mgmt[0].display());
}

fn scratch_domain(tag: &str) -> UserDomain {
    let root = std::env::temp_dir().join(unique(tag));
    UserDomain { root, file_prefix: format!("iox2_{}_", unique(tag)), uid: effective_uid() }
}

#[test]
fn domain_directory_open_to_others_is_refused_works() {
    let domain = scratch_domain("open");
    domain.prepare().unwrap();
    std::fs::set_permissions(&domain.root, std::fs::Permissions::from_mode(0o755)).unwrap();
    let e = domain.prepare().unwrap_err();
    assert_eq!(e, DomainError::TooOpen { path: domain.root.clone(), mode: 0o755 });
    assert!(e.to_string().contains("mode 0755 lets other users in"), "{e}");
    std::fs::remove_dir(&domain.root).unwrap();
}

#[test]
fn domain_directory_as_symlink_is_refused_works() {
    let domain = scratch_domain("link");
    std::os::unix::fs::symlink("/tmp", &domain.root).unwrap();
    assert_eq!(domain.prepare().unwrap_err(), DomainError::NotADirectory { path: domain.root.clone() });
    std::fs::remove_file(&domain.root).unwrap();
}

#[test]
fn domain_directory_of_another_user_is_refused_works() {
    let domain = scratch_domain("foreign");
    domain.prepare().unwrap();
    let nobody = 65_534;
    let c = std::ffi::CString::new(domain.root.display().to_string()).unwrap();
    // SAFETY: a valid path; chown has no other preconditions.
    if unsafe { libc::chown(c.as_ptr(), nobody, nobody) } != 0 {
        println!("skipped: cannot give a directory to another user here (not root)");
        std::fs::remove_dir(&domain.root).unwrap();
        return;
    }
    let e = domain.prepare().unwrap_err();
    assert!(matches!(e, DomainError::ForeignOwner { owner: 65_534, .. }), "{e}");
    std::fs::remove_dir(&domain.root).unwrap();
}
