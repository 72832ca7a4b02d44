//! Lamina's physics core: the layered mass-spring model, spring laws, the solver, scenes,
//! the generator, material fitting, the studies and the yardstick benchmark. It reads scene,
//! model, surface and material files, and writes model files and VTK time series when asked
//! ([`io`]); [`solver::Simulation::step`] does no I/O. Nothing here knows of iceoryx2,
//! windows or devices.
//!
//! # The pipeline
//! 1. [`scene::Scene`] reads a scene file (or [`scene::Scene::builtin_default`]): where the
//!    model comes from, the solver settings, the effects, the tool, the rate.
//! 2. [`scene::Scene::build_model`] gives the [`model::Model`] (nodes, bilinear springs,
//!    layers, in `f64` SI units), generated from segmented surfaces ([`generator`]) or read
//!    from the XML model format ([`io`]).
//! 3. [`solver::Simulation`] steps it in `f32` or `f64` with the chosen integrator and only
//!    the effects the scene asks for; [`hand_tool::HandTool`] moves a haptic tool in it.
//! 4. [`solver::Simulation::state`] gives positions and velocities after each step.
//!
//! # Examples
//!
//! Load the built-in default scene (a layered limb, 1,032 nodes), step 0.1 s, read a node:
//!
//! ```
//! use lamina_core::scene::Scene;
//! use lamina_core::solver::Simulation;
//!
//! let scene = Scene::builtin_default();
//! let model = scene.build_model()?;
//! let mut sim = Simulation::<f32>::new(&model, scene.solver.clone(), scene.effects.clone())?;
//! for _ in 0..scene.rate_hz / 10 {
//!     sim.step();
//! }
//! let x = sim.state().x.get_f64(0); // node 0's position, m
//! assert!(x.iter().all(|c| c.is_finite()));
//! assert!((sim.state().time - 0.1).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod fit;
pub mod generator;
pub mod hand_tool;
pub mod incision;
pub mod io;
pub mod law;
pub mod model;
pub mod real;
pub mod scene;
pub mod solver;
pub mod study;
pub mod yardstick;

/// README.md's library example is this crate's doctest above, line for line, so the README
/// shows code that compiles and runs.
#[cfg(test)]
mod readme_example {
    /// The lines between the first fence opening with `open` and the next closing fence.
    fn fenced<'a>(lines: impl Iterator<Item = &'a str>, open: &str) -> Vec<&'a str> {
        lines.skip_while(|l| !l.starts_with(open)).skip(1).take_while(|l| *l != "```").collect()
    }

    #[test]
    fn readme_library_example_is_the_crate_doctest_works() {
        let readme = fenced(include_str!("../../README.md").lines(), "```rust");
        let doc_lines =
            include_str!("lib.rs").lines().filter_map(|l| l.strip_prefix("//! ").or((l == "//!").then_some("")));
        // Lines starting with `# ` are hidden from the rendered doctest, as from the README.
        let doctest: Vec<&str> = fenced(doc_lines, "```").into_iter().filter(|l| !l.starts_with("# ")).collect();
        assert!(doctest.len() > 5, "the crate doctest: {doctest:?}");
        assert_eq!(readme, doctest, "README.md's ```rust block against core/src/lib.rs's doctest");
    }
}
