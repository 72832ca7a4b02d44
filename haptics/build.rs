//! Records the git commit the binary is built from, for the run reports: `LAMINA_GIT_REVISION`
//! is `git rev-parse HEAD`, or `unknown` outside a git checkout or without git (a source
//! archive still builds; `build-support/git_revision.rs`, shared with `cli/build.rs`).

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    record_git_revision();
}

include!("../build-support/git_revision.rs");
