//! Lamina's physics core: the layered mass-spring model, spring laws, the solver, scenes
//! and the yardstick benchmark. No I/O beyond reading scene files; nothing here knows of
//! iceoryx2, windows or devices.

pub mod fit;
pub mod generator;
pub mod io;
pub mod law;
pub mod model;
pub mod real;
pub mod scene;
pub mod solver;
pub mod study;
pub mod yardstick;
