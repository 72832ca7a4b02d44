// The git-revision step of `cli/build.rs` and `haptics/build.rs`, included by both with
// `include!`: one copy of the code, without a build-dependency crate for 40 lines.
//
// It sets `LAMINA_GIT_REVISION` for the crate being built: `git rev-parse HEAD`, or `unknown`
// outside a git checkout or without git (a source archive still builds). Cargo reruns the
// build script when the checked-out commit changes.

/// Output of `git ARGS` run in `dir`, trimmed; `None` when git is missing, fails or prints
/// nothing.
fn git(dir: &std::path::Path, args: &[&str]) -> Option<String> {
    let out = std::process::Command::new("git").args(args).current_dir(dir).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (out.status.success() && !text.is_empty()).then_some(text)
}

/// Prints `cargo:rustc-env=LAMINA_GIT_REVISION=...` and the files whose change means another
/// commit is checked out (HEAD, the branch it names, packed-refs).
fn record_git_revision() {
    use std::path::{Path, PathBuf};
    println!("cargo:rerun-if-changed=../build-support/git_revision.rs");
    let dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let revision = git(&dir, &["rev-parse", "HEAD"]).filter(|r| r.chars().all(|c| c.is_ascii_hexdigit()));
    println!("cargo:rustc-env=LAMINA_GIT_REVISION={}", revision.as_deref().unwrap_or("unknown"));
    if revision.is_none() {
        return;
    }
    // Only files that exist are watched: a missing one would rerun the script every build.
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
