//! Records the git commit the binary is built from, for the run reports: `LAMINA_GIT_REVISION`
//! is `git rev-parse HEAD`, or `unknown` outside a git checkout or without git (a source
//! archive still builds; `build-support/git_revision.rs`, shared with `haptics/build.rs`).
//!
//! It also compiles the yardstick's plain-C baseline (`yardstick_c/lattice.c`, gcc or the
//! system C compiler, `-O3 -march=native`, with `-fopenmp` and libgomp when they work) for
//! `lamina bench yardstick`. Without a working C compiler the binary still builds: the
//! `lamina_yardstick_c` cfg is then unset and the bench says the C rows are skipped.

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
    record_git_revision();
}

include!("../build-support/git_revision.rs");
