//! Records the git commit the binary is built from, for the run reports: `LAMINA_GIT_REVISION`
//! is `git rev-parse HEAD`, or `unknown` outside a git checkout or without git (a source
//! archive still builds). Cargo reruns this when the checked-out commit changes.
//!
//! It also compiles the yardstick's plain-C baseline (`yardstick_c/lattice.c`, gcc or the
//! system C compiler, `-O3 -march=native`, with `-fopenmp` and libgomp when they work) for
//! `lamina bench yardstick`. Without a working C compiler the binary still builds: the
//! `lamina_yardstick_c` cfg is then unset and the bench says the C rows are skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(dir: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).current_dir(dir).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (out.status.success() && !text.is_empty()).then_some(text)
}

/// Compiles the C baseline; returns what was built (`None`: no C compiler that works).
fn yardstick_c() -> Option<&'static str> {
    println!("cargo:rerun-if-changed=yardstick_c/lattice.c");
    println!("cargo::rustc-check-cfg=cfg(lamina_yardstick_c)");
    println!("cargo::rustc-check-cfg=cfg(lamina_yardstick_c_openmp)");
    let build = |openmp: bool| {
        let mut b = cc::Build::new();
        b.file("yardstick_c/lattice.c").opt_level(3).flag_if_supported("-march=native").cargo_warnings(false);
        if openmp {
            b.flag("-fopenmp");
        }
        b.try_compile("lamina_yardstick_c")
    };
    if build(true).is_ok() {
        println!("cargo:rustc-link-lib=gomp");
        println!("cargo:rustc-cfg=lamina_yardstick_c");
        println!("cargo:rustc-cfg=lamina_yardstick_c_openmp");
        return Some("C and C+OpenMP");
    }
    if build(false).is_ok() {
        println!("cargo:rustc-cfg=lamina_yardstick_c");
        println!("cargo:warning=yardstick C baseline built without OpenMP (-fopenmp failed): C+OpenMP rows skipped");
        return Some("C");
    }
    println!("cargo:warning=no working C compiler: the yardstick's C baseline rows are skipped");
    None
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let _ = yardstick_c();
    let dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let revision = git(&dir, &["rev-parse", "HEAD"]).filter(|r| r.chars().all(|c| c.is_ascii_hexdigit()));
    println!("cargo:rustc-env=LAMINA_GIT_REVISION={}", revision.as_deref().unwrap_or("unknown"));
    if revision.is_none() {
        return;
    }
    // The files that change when another commit is checked out or committed: HEAD, the
    // branch it names, and packed-refs (only those that exist: a missing one would rerun this
    // every build).
    let absolute = |p: String| if Path::new(&p).is_absolute() { PathBuf::from(p) } else { dir.join(p) };
    let git_dir = git(&dir, &["rev-parse", "--git-dir"]).map(absolute);
    let common = git(&dir, &["rev-parse", "--git-common-dir"]).map(absolute);
    let mut watch = Vec::new();
    if let Some(g) = &git_dir {
        watch.push(g.join("HEAD"));
    }
    if let Some(c) = &common {
        watch.push(c.join("packed-refs"));
        if let Some(branch) = git(&dir, &["symbolic-ref", "-q", "HEAD"]) {
            // A packed branch has no file of its own until its next commit writes one:
            // then watch the folder it will appear in.
            let file = c.join(branch);
            match file.parent() {
                Some(folder) if !file.exists() => watch.push(folder.to_path_buf()),
                _ => watch.push(file),
            }
        }
    }
    for path in watch.into_iter().filter(|p| p.exists()) {
        println!("cargo:rerun-if-changed={}", path.display());
    }
}
