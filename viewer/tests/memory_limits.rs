//! Volumes too large to convert are refused from their header under a real address-space
//! limit: this test runs itself again in a child process whose `RLIMIT_AS` is 4 GiB (set
//! with `setrlimit` between fork and exec), where the child reads the volume. A volume
//! converted before its estimate is checked aborts there ("memory allocation of 8000000000
//! bytes failed"); it must instead be refused with the file, the estimate and the budget.
//!
//! The files are 1000^3 uint8 voxels (0.93 GiB of texture, within the 1 GiB texture limit;
//! 7.45 GiB as 64-bit floats), gzip-compressed NIfTI-1 and NRRD written here byte by byte.
//! They hold their headers and the first voxels only: the refusal comes from the header,
//! before a voxel is read.

use std::io::Write;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lamina_viewer::view_model::VolumeSpec;
use lamina_viewer::volume_file::read_volume;

/// The address-space limit of the child, bytes.
const LIMIT: u64 = 4 << 30;
/// Set in the child: the volume it reads.
const CHILD_VOLUME: &str = "LAMINA_MEMORY_LIMITS_VOLUME";
/// The child's exit code when the read was refused (0: read).
const REFUSED: i32 = 3;

/// A gzip stream of `bytes`.
fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

/// A single-file NIfTI-1 header (352 bytes) of `dims` uint8 voxels, 0.1 mm spacing.
fn nifti_header(dims: [u16; 3]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (k, d) in [3u16, dims[0], dims[1], dims[2], 1, 1, 1, 1].into_iter().enumerate() {
        h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes()); // datatype uint8
    h[72..74].copy_from_slice(&8i16.to_le_bytes()); // bitpix
    for (k, p) in [1.0f32, 0.1, 0.1, 0.1, 1.0, 1.0, 1.0, 1.0].into_iter().enumerate() {
        h[76 + 4 * k..80 + 4 * k].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352.0f32.to_le_bytes()); // vox_offset
    h[123] = 2; // xyzt_units: millimetres
    h[344..348].copy_from_slice(b"n+1\0");
    h
}

/// This test binary again, running only `test`, with `RLIMIT_AS` at [`LIMIT`] and the child
/// told to read `volume`.
fn child_reading(test: &str, volume: &Path) -> Output {
    let mut cmd = Command::new(std::env::current_exe().unwrap());
    cmd.args(["--exact", test, "--nocapture", "--test-threads=1"])
        .env(CHILD_VOLUME, volume)
        .env_remove("LAMINA_MEMORY_LIMIT");
    // SAFETY: between fork and exec the closure calls only setrlimit(2), which is
    // async-signal-safe, and builds its error from errno.
    unsafe {
        cmd.pre_exec(|| {
            let limit = libc::rlimit { rlim_cur: LIMIT, rlim_max: LIMIT };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    cmd.output().unwrap()
}

/// In the child: reads the volume, prints the outcome and exits.
fn child() -> Option<()> {
    let path = PathBuf::from(std::env::var_os(CHILD_VOLUME)?);
    match read_volume(&VolumeSpec { path, ..VolumeSpec::default() }) {
        Ok(v) => {
            eprintln!("read {:?}", v.size);
            std::process::exit(0)
        }
        Err(e) => {
            eprintln!("refused: {e}");
            std::process::exit(REFUSED)
        }
    }
}

/// The budget a refusal gives: N in "more than the X GiB (N bytes) available".
fn budget_bytes(err: &str) -> u64 {
    let tail = err.split("more than the ").nth(1).unwrap_or_else(|| panic!("no budget in: {err}"));
    let inside = tail.split('(').nth(1).and_then(|t| t.split(" bytes)").next()).unwrap();
    inside.replace(',', "").parse().unwrap_or_else(|_| panic!("no byte count in: {err}"))
}

#[test]
fn memory_limits_gzip_volume_1000_cubed_under_rlimit_as_fail() {
    const TEST: &str = "memory_limits_gzip_volume_1000_cubed_under_rlimit_as_fail";
    if child().is_some() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("lamina_volume_memory_limits_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let nii = dir.join("huge.nii.gz");
    let mut bytes = nifti_header([1000, 1000, 1000]);
    bytes.extend_from_slice(&[7u8; 64]);
    std::fs::write(&nii, gzip(&bytes)).unwrap();
    let nrrd = dir.join("huge.nrrd");
    let mut bytes =
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1000 1000 1000\nspacings: 0.1 0.1 0.1\nencoding: gzip\n\n"
            .to_vec();
    bytes.extend_from_slice(&gzip(&[7u8; 64]));
    std::fs::write(&nrrd, bytes).unwrap();
    for path in [&nii, &nrrd] {
        let out = child_reading(TEST, path);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(REFUSED), "{:?}\n{err}", out.status);
        assert!(!err.contains("memory allocation of") && !err.contains("panicked"), "{err}");
        // 1e9 bytes read, 8e9 bytes of floats, 1e9 bytes of texture.
        for part in [
            &format!("refused: volume {}: reading 1000x1000x1000 voxels", path.display()),
            "and converting them to 64-bit floats (7.45 GiB (8,000,000,000 bytes))",
            "needs about 9.31 GiB (10,000,000,000 bytes), more than the ",
        ] {
            assert!(err.contains(part), "no '{part}' in: {err}");
        }
        let budget = budget_bytes(&err);
        assert!(budget > 0 && budget <= LIMIT, "budget {budget} bytes: {err}");
        let sources = ["RLIMIT_AS minus this process's virtual size", "MemAvailable", "the cgroup's memory.max"];
        assert!(sources.iter().any(|s| err.contains(&format!("available ({s}"))), "{err}");
    }
    // The committed 16^3 phantom reads under the same limit.
    let phantom = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/phantom16.nii");
    let out = child_reading(TEST, &phantom);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("read [16, 16, 16]"));
    std::fs::remove_dir_all(&dir).unwrap();
}
