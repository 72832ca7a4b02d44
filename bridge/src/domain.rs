//! Each user's Lamina lives in its own iceoryx2 domain, and one publisher of node frames per
//! prefix: [`UserDomain`] and [`PrefixLock`].
//!
//! # What a domain is
//! iceoryx2 keeps its management files under a root directory and names its shared memory
//! in `/dev/shm` with a file prefix. Lamina derives both from the effective user id:
//! - root directory `/tmp/lamina-<uid>/` (or `$LAMINA_IPC_DIR/`), created `0700` and used
//!   only when it is a real directory owned by the user with no group or other access;
//! - file prefix `iox2_lamina_u<uid>_`, so a user's shared memory never shares a name with
//!   another user's.
//!
//! iceoryx2 0.10 creates one file with global access, the domain's management segment
//! `/dev/shm/<prefix><hash>_node.<version>.global_mgmt` (mode `0666`); whoever can write it
//! can stop every process of the domain from creating a node. [`UserDomain::secure`] sets it
//! to `0600` once the node exists, and refuses a domain whose files belong to another user.
//!
//! # One core per prefix
//! [`PrefixLock`] is an exclusive `flock` on `<root>/<prefix>.nodes.lock`, taken by every
//! node-frame publisher; a second publisher on a live prefix is refused with the first one's
//! pid. The kernel releases the lock when its holder dies, even by `SIGKILL`, so a restarted
//! core takes over at once.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Environment variable naming the directory of the user's iceoryx2 domain instead of
/// `/tmp/lamina-<uid>`. All processes of one simulation must see the same value.
pub const IPC_DIR_ENV: &str = "LAMINA_IPC_DIR";

/// Where shared memory lives (Linux `shm_open`).
const SHM_DIR: &str = "/dev/shm";

/// Why a user's domain could not be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DomainError {
    /// The domain directory could not be created or inspected.
    #[error("{path}: {message}")]
    Io {
        /// The directory or file.
        path: PathBuf,
        /// OS error text.
        message: String,
    },
    /// The domain directory is a symbolic link or not a directory.
    #[error("{path}: the iceoryx2 domain must be a directory, not a link or a file")]
    NotADirectory {
        /// The path.
        path: PathBuf,
    },
    /// A domain file or directory belongs to another user (someone created it first).
    #[error(
        "{path}: belongs to uid {owner}, not to this user (uid {uid}); Lamina will not share its iceoryx2 domain with another user: remove it or set {IPC_DIR_ENV}"
    )]
    ForeignOwner {
        /// The path.
        path: PathBuf,
        /// Its owner.
        owner: u32,
        /// This process's effective user id.
        uid: u32,
    },
    /// The domain directory grants group or other users access.
    #[error("{path}: mode {mode:04o} lets other users in; the iceoryx2 domain must be 0700 (chmod 700 it)")]
    TooOpen {
        /// The directory.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> DomainError + '_ {
    move |e| DomainError::Io { path: path.to_path_buf(), message: e.to_string() }
}

/// The effective user id of this process.
pub fn effective_uid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// A user's iceoryx2 domain: its root directory and file prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UserDomain {
    /// Root directory of iceoryx2's management files, ending in `/`.
    pub root: PathBuf,
    /// iceoryx2's file prefix: `iox2_lamina_u<uid>_`.
    pub file_prefix: String,
    /// The user.
    pub uid: u32,
}

impl UserDomain {
    /// The domain of this process's effective user: `$LAMINA_IPC_DIR` or `/tmp/lamina-<uid>`.
    pub fn current() -> Self {
        let uid = effective_uid();
        let root = std::env::var_os(IPC_DIR_ENV)
            .filter(|v| !v.is_empty())
            .map_or_else(|| std::env::temp_dir().join(format!("lamina-{uid}")), PathBuf::from);
        Self { root, file_prefix: format!("iox2_lamina_u{uid}_"), uid }
    }

    /// Creates the root directory (`0700`) if missing and checks it: a real directory,
    /// owned by this user, no group or other access.
    ///
    /// # Errors
    /// [`DomainError`] naming the directory and what is wrong.
    pub fn prepare(&self) -> Result<(), DomainError> {
        match std::fs::DirBuilder::new().mode(0o700).create(&self.root) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(io(&self.root)(e)),
        }
        let meta = std::fs::symlink_metadata(&self.root).map_err(io(&self.root))?;
        if !meta.is_dir() {
            return Err(DomainError::NotADirectory { path: self.root.clone() });
        }
        if meta.uid() != self.uid {
            return Err(DomainError::ForeignOwner { path: self.root.clone(), owner: meta.uid(), uid: self.uid });
        }
        if meta.mode() & 0o077 != 0 {
            return Err(DomainError::TooOpen { path: self.root.clone(), mode: meta.mode() & 0o7777 });
        }
        self.check_shared_memory(false)
    }

    /// After the iceoryx2 node exists: takes group and other access away from the domain's
    /// management segment (created `0666` by iceoryx2), and refuses shared memory of the
    /// domain owned by another user.
    ///
    /// # Errors
    /// [`DomainError::ForeignOwner`] for a file planted by another user.
    pub fn secure(&self) -> Result<(), DomainError> {
        self.check_shared_memory(true)
    }

    /// The domain's files in `/dev/shm`: each must be this user's; with `restrict`, the
    /// management segment is set to `0600`.
    fn check_shared_memory(&self, restrict: bool) -> Result<(), DomainError> {
        let Ok(entries) = std::fs::read_dir(SHM_DIR) else { return Ok(()) };
        for entry in entries.flatten() {
            let name = entry.file_name();
            let Some(name) = name.to_str() else { continue };
            if !name.starts_with(&self.file_prefix) {
                continue;
            }
            let path = entry.path();
            let Ok(meta) = std::fs::symlink_metadata(&path) else { continue };
            if meta.uid() != self.uid {
                return Err(DomainError::ForeignOwner { path, owner: meta.uid(), uid: self.uid });
            }
            if restrict && name.ends_with(".global_mgmt") && meta.mode() & 0o077 != 0 {
                std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).map_err(io(&path))?;
            }
        }
        Ok(())
    }
}

/// Why a prefix lock was not taken.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PrefixLockError {
    /// Another process publishes node frames on the prefix.
    #[error("prefix '{prefix}' is live: another process{} already publishes its node frames (lock {lock}); stop it or choose another --prefix", .holder_pid.map_or(String::new(), |p| format!(" (pid {p})")))]
    InUse {
        /// The service prefix.
        prefix: String,
        /// The holder's process id, as it wrote it in the lock file.
        holder_pid: Option<u32>,
        /// The lock file.
        lock: PathBuf,
    },
    /// The lock file could not be created or locked.
    #[error("{lock}: {message}")]
    Io {
        /// The lock file.
        lock: PathBuf,
        /// OS error text.
        message: String,
    },
}

/// An exclusive lock on a service prefix, held while it lives (see the module docs).
#[derive(Debug)]
pub struct PrefixLock {
    _file: File,
    path: PathBuf,
}

impl PrefixLock {
    /// Takes the lock of `prefix` in `domain`, or says who holds it.
    ///
    /// # Errors
    /// [`PrefixLockError::InUse`] naming the prefix and the holder's pid.
    pub fn acquire(domain: &UserDomain, prefix: &str) -> Result<Self, PrefixLockError> {
        let escaped: String = prefix
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                    c.to_string()
                } else {
                    format!("%{:02X}", c as u32)
                }
            })
            .collect();
        let path = domain.root.join(format!("{escaped}.nodes.lock"));
        let failed = |e: std::io::Error| PrefixLockError::Io { lock: path.clone(), message: e.to_string() };
        // The holder removes the file when it lets go; a file locked after it was removed is
        // not the lock any more, so the check below retries with the new one.
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .mode(0o600)
                .custom_flags(libc::O_NOFOLLOW)
                .open(&path)
                .map_err(failed)?;
            // SAFETY: a valid open file descriptor; flock has no other preconditions.
            if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
                let err = std::io::Error::last_os_error();
                if err.raw_os_error() != Some(libc::EWOULDBLOCK) {
                    return Err(failed(err));
                }
                let mut text = String::new();
                let _ = file.read_to_string(&mut text);
                return Err(PrefixLockError::InUse {
                    prefix: prefix.to_owned(),
                    holder_pid: text.trim().parse().ok(),
                    lock: path,
                });
            }
            let held = file.metadata().map_err(failed)?;
            let same = std::fs::symlink_metadata(&path).is_ok_and(|m| m.ino() == held.ino() && m.dev() == held.dev());
            if !same {
                continue;
            }
            file.set_len(0).map_err(failed)?;
            file.rewind().map_err(failed)?;
            write!(file, "{}", std::process::id()).map_err(failed)?;
            return Ok(Self { _file: file, path });
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for PrefixLock {
    /// Removes the lock file while still holding the lock, then lets go (closing the file).
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}
