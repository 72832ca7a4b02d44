//! Lamina's physics core: the layered mass-spring model, spring laws, the solver, scenes
//! and the yardstick benchmark. No I/O beyond reading scene and model files; nothing here
//! knows of iceoryx2, windows or devices.
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
pub mod io;
pub mod law;
pub mod model;
pub mod real;
pub mod scene;
pub mod solver;
pub mod study;
pub mod yardstick;
